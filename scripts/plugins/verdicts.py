#!/usr/bin/env python3
"""The verdict tables of docs/plugins.md, reproduced by one command each:

    python3 scripts/plugins/verdicts.py dragons [--count N]   # dragon_res4 .. dragon_full
    python3 scripts/plugins/verdicts.py assimp  [--count N]   # every mesh of the assimp corpus

For each mesh: `rtdiff parity MESH --tracer plugin:LIB --json` for the plugins of plugins/
(tinybvh, obvhs; vs Embree robust HIGH, every set, the exact arbiter), and Embree's default
mode as a program (`rtdiff rays`, scripts/program/embree_hits.py, `rtdiff judge --json`).
Prints one Markdown row per mesh and tracer: rays, answers that agree with the reference,
that differ but are exact or within the bound, wrong ones by class, leaks per million rays of
the edges and vertices sets, false self-intersections per million spawned rays. Needs
`cargo build --release --features embree`, the plugins built (`cargo build --release
--manifest-path plugins/Cargo.toml`) and, for the program path, a Python with embreex
(RTDIFF_PROGRAM_PYTHON or .venv/bin/python).
"""
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
RTDIFF = ROOT / "target/release/rtdiff"
PLUGINS = ["tinybvh", "obvhs"]
DRAGONS = ["dragon_res4.obj", "dragon_res3.obj", "dragon_87k.obj", "dragon_res2.obj", "dragon_full.obj"]


def meshes(which):
    if which == "dragons":
        return [ROOT / "assets" / m for m in DRAGONS]
    out = []
    for sub in ["OBJ", "PLY"]:
        for p in sorted((ROOT / "assets/assimp" / sub).iterdir()):
            if p.suffix in (".obj", ".ply"):
                out.append(p)
    return out


def run_json(args):
    r = subprocess.run([str(RTDIFF), *args, "--json"], capture_output=True, text=True)
    if r.returncode not in (0, 2):
        return None, r.stderr.strip().splitlines()[-1] if r.stderr.strip() else "error"
    return json.loads(r.stdout), None


def row(mesh, tracer, report):
    rows = report["verdict"]["rows"]
    sets = {s["set"]: s for s in report["sets"]}
    rays = sum(r["rays"] for r in rows)
    agree = sum(r["agree"] for r in rows)
    exact = sum(r["differ_exact"] for r in rows)
    within = sum(r["within_bound"] for r in rows)
    wrong = sum(r["wrong"] for r in rows)
    by = {}
    for r in rows:
        for k, n in r["wrong_by"].items():
            by[k] = by.get(k, 0) + n
    crossing = sum(r["rays"] for r in rows if r["set"] in ("edges", "vertices"))
    leaks = sum(r["leaks"] for r in rows if r["set"] in ("edges", "vertices"))
    ref_leaks = sum(s["reference_leaks"] for s in sets.values() if s["set"] in ("edges", "vertices"))
    spawned = sum(s["spawned_rays"] for s in sets.values())
    selfh = sum(r["false_self_hits"] for r in rows)
    per_m = lambda n, d: f"{n * 1e6 / d:.0f}" if d else "-"
    wrong_text = f"{wrong}" + (f" ({', '.join(f'{k} {n}' for k, n in sorted(by.items()))})" if by else "")
    return (f"| {mesh} | {tracer} | {rays} | {agree} | {exact} / {within} | {wrong_text} | "
            f"{per_m(leaks, crossing)} ({per_m(ref_leaks, crossing)}) | {per_m(selfh, spawned)} |")


def main():
    which = sys.argv[1] if len(sys.argv) > 1 else "dragons"
    count = sys.argv[sys.argv.index("--count") + 1] if "--count" in sys.argv else "10000"
    py = os.environ.get("RTDIFF_PROGRAM_PYTHON", str(ROOT / ".venv/bin/python"))
    print("| mesh | tracer | rays | agree | differ: exact / within bound | wrong (by class) | leaks per M edge/vertex rays (reference's) | false self-hits per M spawned |")
    print("|---|---|---:|---:|---:|---|---:|---:|")
    for m in meshes(which):
        name = m.relative_to(ROOT / "assets")
        for lib in PLUGINS:
            so = ROOT / f"plugins/target/release/librtdiff_{lib}.so"
            rep, err = run_json(["parity", str(m), "--tracer", f"plugin:{so}", "--count", count])
            if rep is None and which == "assimp":
                break  # a point cloud or a broken file: no triangles to trace
            print(row(name, lib, rep) if rep else f"| {name} | {lib} | {err} | | | | | |", flush=True)
        if rep is None:
            continue
        if m.suffix != ".obj":
            continue  # the program path's script reads OBJ
        with tempfile.TemporaryDirectory() as d:
            rays, hits = Path(d) / "rays.csv", Path(d) / "hits.csv"
            r = subprocess.run([str(RTDIFF), "rays", str(m), "--count", count, "-o", str(rays)], capture_output=True, text=True)
            if r.returncode != 0:
                print(f"| {name} | embree default | {r.stderr.strip().splitlines()[-1]} | | | | | |")
                continue
            subprocess.run([py, str(ROOT / "scripts/program/embree_hits.py"), str(m), str(rays), str(hits)],
                           check=True, capture_output=True)
            rep, err = run_json(["judge", str(m), "--rays", str(rays), "--hits", str(hits), "--name", "embree-default"])
            print(row(name, "embree default (program)", rep) if rep else f"| {name} | embree default | {err} | | | | | |",
                  flush=True)


if __name__ == "__main__":
    main()
