#!/usr/bin/env python3
"""Convert a CommonJS mesh module (npm `teapot`, `bunny`) to OBJ.

These modules are `exports.positions=[[x,y,z],...]` and `exports.cells=[[a,b,c],...]` (0-based indices).
The coordinates are copied as the module spells them (so the OBJ is a lossless copy of the numbers).

usage: js_to_obj.py INPUT.js OUTPUT.obj --name NAME --comment TEXT [--comment TEXT ...]
"""

import argparse
import json
import re

from objio import AssetError, check_number_text, fail, write_obj


def read_array(src, key, path):
    m = re.search(r"exports\." + key + r"\s*=\s*", src)
    if not m:
        raise AssetError(f"{path}: no 'exports.{key}=' found")
    # The value is a JSON array; decode just that value and stop at its end.
    dec = json.JSONDecoder(parse_float=str, parse_int=str)
    try:
        value, _ = dec.raw_decode(src, m.end())
    except json.JSONDecodeError as e:
        raise AssetError(f"{path}: exports.{key} is not a JSON array: {e}") from None
    if not isinstance(value, list):
        raise AssetError(f"{path}: exports.{key} is not an array")
    return value


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--name", required=True)
    ap.add_argument("--comment", action="append", default=[])
    a = ap.parse_args()
    try:
        with open(a.input, encoding="utf-8") as f:
            src = f.read()
        pos = read_array(src, "positions", a.input)
        cells = read_array(src, "cells", a.input)
        positions = []
        for i, p in enumerate(pos):
            if not (isinstance(p, list) and len(p) == 3):
                raise AssetError(f"{a.input}: positions[{i}] is not [x, y, z]")
            positions.append(tuple(check_number_text(c, f"{a.input}: positions[{i}]") for c in p))
        triangles = []
        for i, c in enumerate(cells):
            if not (isinstance(c, list) and len(c) == 3):
                raise AssetError(f"{a.input}: cells[{i}] is not a triangle")
            triangles.append(tuple(int(x) for x in c))
        write_obj(a.output, a.comment, a.name, positions, triangles)
    except (AssetError, OSError) as e:
        fail(str(e))


if __name__ == "__main__":
    main()
