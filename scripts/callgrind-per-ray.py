#!/usr/bin/env python3
"""Instructions per call, instruction by instruction, from a callgrind profile.

Annotates the disassembly of one function of one object (an executable or a
shared library, with or without symbols) with how many times each
instruction ran per call of that function, so that two libraries' kernels
can be compared block by block (docs/bvh.md, "Embree's walk, counted").

    valgrind --tool=callgrind --dump-instr=yes --callgrind-out-file=cg.out \\
        --toggle-collect='outside_loop::trace_*' \\
        ./target/release/examples/outside_loop --split --only incoherent-hits:embree-default ... MESH
    scripts/callgrind-per-ray.py cg.out --object libembree4

The function is the symbol holding the object's most executed instruction
(from nm; in an object without symbols, the hottest run of code whose
executed addresses lie less than --gap bytes apart), or the range
--start/--stop; the calls are the count of its first executed instruction
(its entry, once per call) unless --calls is given. Needs nm and objdump
(binutils). --self-test checks the parser.
"""

import argparse
import collections
import re
import signal
import subprocess
import sys


def parse(lines):
    """Self cost (first event) per (object path, instruction address) of a
    callgrind profile written with --dump-instr=yes."""
    counts = collections.Counter()
    names = {}
    obj = None
    addr = 0
    after_calls = False
    for raw in lines:
        line = raw.rstrip("\n")
        if line.startswith("positions:") and "instr" not in line.split()[1:]:
            raise ValueError("no instruction addresses (profile it with --dump-instr=yes)")
        m = re.match(r"(c?ob)=\((\d+)\)(?: (.*))?$", line)
        if m:
            if m.group(3):
                names[m.group(2)] = m.group(3)
            if m.group(1) == "ob":
                obj = names.get(m.group(2))
            continue
        if line.startswith("calls="):
            after_calls = True
            continue
        if not line or line[0] not in "0123456789+-*":
            continue
        fields = line.split()
        pos = fields[0]
        if pos.startswith("0x"):
            addr = int(pos, 16)
        elif pos[0] in "+-":
            step = int(pos[1:], 16) if pos[1:].startswith("0x") else int(pos[1:])
            addr = addr + step if pos[0] == "+" else addr - step
        elif pos != "*":
            addr = int(pos)
        if after_calls:
            # The inclusive cost of a call, not this instruction's own.
            after_calls = False
            continue
        # Positions are "instr line" (two columns) or "instr" (one).
        rest = fields[1:]
        if len(rest) >= 2:
            cost = int(rest[1])
        elif rest:
            cost = int(rest[0])
        else:
            cost = 0
        counts[(obj, addr)] += cost
    return counts


def symbol_around(obj, addr):
    """(start, end) of the sized function symbol of `obj` holding `addr`, or None."""
    for extra in ([], ["-D"]):
        try:
            out = subprocess.run(["nm", "-S", "--defined-only", *extra, obj],
                                 capture_output=True, text=True, check=True).stdout
        except (OSError, subprocess.CalledProcessError):
            continue
        for line in out.splitlines():
            f = line.split()
            if len(f) >= 4 and f[2] in "tTwW":
                start, size = int(f[0], 16), int(f[1], 16)
                if start <= addr < start + size:
                    return start, start + size
    return None


def hottest_run(addrs, gap):
    """The run of sorted addresses (neighbours under `gap` apart) with the largest total."""
    runs = []
    for a in sorted(addrs):
        if runs and a - runs[-1][-1] < gap:
            runs[-1].append(a)
        else:
            runs.append([a])
    return max(runs, key=lambda r: sum(addrs[a] for a in r))


def self_test():
    sample = """version: 1
positions: instr line
events: Ir
ob=(1) /lib/libk.so
fl=(1) ???
fn=(1) kernel
0x100 0 5
+4 * 5
+2 * 3
calls=1 0x900 0
+3 * 40
-1 * 7
ob=(2) /bin/main
fn=(2) main
0x50 0 1
cob=(1)
cfn=(1)
calls=1 0x100 0
+2 * 13
ob=(1)
fn=(1)
0x10a 0 2
"""
    c = parse(sample.splitlines())
    lib = {a: v for (o, a), v in c.items() if o == "/lib/libk.so"}
    assert lib == {0x100: 5, 0x104: 5, 0x106: 3, 0x108: 7, 0x10A: 2}, lib
    main = {a: v for (o, a), v in c.items() if o == "/bin/main"}
    assert main == {0x50: 1}, main
    try:
        parse(["positions: line", "events: Ir", "fn=(1) f", "12 3"])
        raise AssertionError("a profile without instruction addresses was read")
    except ValueError:
        pass
    run = hottest_run({0x100: 5, 0x104: 5, 0x2000: 30, 0x2008: 1}, 0x400)
    assert run == [0x2000, 0x2008], run
    print("callgrind-per-ray: self-test passed")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("profile", nargs="?", help="callgrind output written with --dump-instr=yes")
    ap.add_argument("--object", help="a substring of the object's path (executable or library)")
    ap.add_argument("--start", type=lambda x: int(x, 16), help="first address (hex), with --stop")
    ap.add_argument("--stop", type=lambda x: int(x, 16), help="address past the last (hex)")
    ap.add_argument("--calls", type=int, help="divide by this count instead of the entry's")
    ap.add_argument("--gap", type=lambda x: int(x, 0), default=0x400, help="largest gap inside a function (bytes)")
    ap.add_argument("--min", type=float, default=0.0, help="print only instructions run more often per call")
    ap.add_argument("--self-test", action="store_true", help="check the parser on a built-in profile and exit")
    args = ap.parse_args()
    # Quiet when piped into `head`.
    signal.signal(signal.SIGPIPE, signal.SIG_DFL)
    if args.self_test:
        self_test()
        return 0
    if not args.profile or not args.object:
        ap.error("a profile and --object are required")
    try:
        with open(args.profile, encoding="utf-8", errors="replace") as f:
            counts = parse(f)
    except OSError as e:
        sys.exit(f"callgrind-per-ray: {args.profile}: {e.strerror}")
    except ValueError as e:
        sys.exit(f"callgrind-per-ray: {args.profile}: {e}")
    objs = sorted({o for o, _ in counts if o and args.object in o})
    if len(objs) != 1:
        sys.exit(f"callgrind-per-ray: {args.profile}: --object {args.object!r} matches {objs or 'no object'}")
    obj = objs[0]
    addrs = {a: v for (o, a), v in counts.items() if o == obj and v > 0}
    if args.start is not None and args.stop is not None:
        run = sorted(a for a in addrs if args.start <= a < args.stop)
        start, stop = args.start, args.stop
    else:
        hottest = max(addrs, key=addrs.get)
        sym = symbol_around(obj, hottest)
        if sym:
            start, stop = sym
            run = sorted(a for a in addrs if start <= a < stop)
        else:
            run = hottest_run(addrs, args.gap)
            start, stop = run[0], run[-1] + 16
    if not run:
        sys.exit(f"callgrind-per-ray: no instruction of {obj} ran in {start:#x}..{stop:#x}")
    calls = args.calls or addrs[run[0]]
    try:
        dis = subprocess.run(
            ["objdump", "-d", "--no-show-raw-insn", f"--start-address={start:#x}", f"--stop-address={stop:#x}", obj],
            capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError) as e:
        sys.exit(f"callgrind-per-ray: objdump on {obj}: {e}")
    total = 0.0
    print(f"# {obj} {start:#x}..{stop:#x}: instructions per call, {calls} calls")
    for line in dis.splitlines():
        m = re.match(r"\s*([0-9a-f]+):\s*(.*)", line)
        if not m:
            continue
        per = addrs.get(int(m.group(1), 16), 0) / calls
        total += per
        if per > args.min:
            print(f"{per:8.3f}  {m.group(1)}: {m.group(2)}")
    print(f"# total {total:.1f} instructions per call in the range")
    return 0


if __name__ == "__main__":
    sys.exit(main())
