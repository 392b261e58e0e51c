"""Small helpers shared by the asset converters: writing and reading plain OBJ files.

The OBJ files written here hold positions and triangle faces only:
    # comment lines
    o NAME
    v X Y Z          (one per vertex; numbers are written as text, see `write_obj`)
    f A B C          (1-based vertex indices, one triangle per line)
"""

import math
import sys


class AssetError(Exception):
    """A problem with an input or output file; the message names the file and the problem."""


def fail(msg):
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(1)


def check_number_text(text, where):
    """Raise AssetError unless `text` is a finite decimal number."""
    try:
        x = float(text)
    except ValueError:
        raise AssetError(f"{where}: '{text}' is not a number") from None
    if not math.isfinite(x):
        raise AssetError(f"{where}: non-finite coordinate '{text}'")
    return text


def write_obj(path, comments, name, positions, triangles):
    """Write an OBJ file.

    positions: list of (x, y, z) where each coordinate is already a string (so that the caller
               decides the number formatting; the converters keep the source's own text)
    triangles: list of (a, b, c) 0-based vertex indices
    """
    nv = len(positions)
    for t, tri in enumerate(triangles):
        if len(tri) != 3:
            raise AssetError(f"{path}: face {t} has {len(tri)} vertices, expected 3")
        for i in tri:
            if not 0 <= i < nv:
                raise AssetError(f"{path}: face {t} refers to vertex {i}, but there are only {nv}")
    out = []
    for c in comments:
        out.append(f"# {c}\n")
    out.append(f"o {name}\n")
    out.extend(f"v {x} {y} {z}\n" for x, y, z in positions)
    out.extend(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in triangles)
    with open(path, "w", encoding="ascii", newline="\n") as f:
        f.write("".join(out))


def count_obj(path):
    """Return (vertex count, triangle count) of an OBJ file; faces with more than 3 vertices count as fans."""
    nv = nt = 0
    with open(path, encoding="ascii", errors="replace") as f:
        for line in f:
            if line.startswith("v "):
                nv += 1
            elif line.startswith("f "):
                nt += len(line.split()) - 3
    return nv, nt
