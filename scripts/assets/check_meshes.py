#!/usr/bin/env python3
"""Check the authored meshes in scenes/meshes/ (or --dir DIR): counts, closedness, winding, normals,
texture coordinates, the texture PNG and the Cornell box layout and materials; the cube's glTF, GLB and
STL copies hold the OBJ's triangles in the OBJ's order (and the glTF ones its uvs and texture).

Standard library only.  Prints one line per failed check and a closing line 'N passed, N failed';
exits 1 if any check failed.

usage: check_meshes.py [--dir DIR] [-v]
"""

import argparse
import base64
import json
import math
import os
import struct
import sys
import zlib
from collections import Counter

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_DIR = os.path.normpath(os.path.join(HERE, "..", "..", "scenes", "meshes"))

CORNELL_MATERIALS = {  # name: (Kd, Ks, Ns), from ../shared/notes/scenes.md
    "floor": ((0.725, 0.71, 0.68), (0, 0, 0), 10),
    "ceiling": ((0.725, 0.71, 0.68), (0, 0, 0), 10),
    "back": ((0.725, 0.71, 0.68), (0, 0, 0), 10),
    "left": ((0.63, 0.065, 0.05), (0, 0, 0), 10),
    "right": ((0.14, 0.45, 0.091), (0, 0, 0), 10),
    "light": ((0.78, 0.78, 0.78), (0, 0, 0), 10),
    "shortbox": ((0.725, 0.71, 0.68), (0, 0, 0), 10),
    "tallbox": ((0.01, 0.01, 0.01), (0.95, 0.95, 0.95), 4),
}
CORNELL_TRIANGLES = {"floor": 2, "ceiling": 2, "back": 2, "left": 2, "right": 2, "light": 2,
                     "shortbox": 10, "tallbox": 10}


# ------------------------------------------------------------------ vectors
def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def length(a):
    return math.sqrt(dot(a, a))


def unit(a):
    n = length(a)
    return (a[0] / n, a[1] / n, a[2] / n)


def mean(pts):
    return tuple(sum(p[k] for p in pts) / len(pts) for k in range(3))


# ------------------------------------------------------------------ parsing
class Obj:
    def __init__(self, path):
        self.path = path
        self.v, self.vt, self.vn = [], [], []
        self.tris = []  # list of dicts: v (3 indices), vt (3 or None), vn (3 or None), mtl, obj
        self.mtllibs = []
        mtl, obj = None, None
        with open(path, encoding="ascii") as f:
            for n, line in enumerate(f, 1):
                w = line.split()
                if not w or w[0].startswith("#"):
                    continue
                where = f"{path}:{n}"
                if w[0] == "v":
                    self.v.append(tuple(float(x) for x in w[1:4]))
                elif w[0] == "vt":
                    self.vt.append(tuple(float(x) for x in w[1:3]))
                elif w[0] == "vn":
                    self.vn.append(tuple(float(x) for x in w[1:4]))
                elif w[0] == "usemtl":
                    mtl = w[1]
                elif w[0] in ("o", "g"):
                    obj = w[1] if len(w) > 1 else None
                elif w[0] == "mtllib":
                    self.mtllibs.append(w[1])
                elif w[0] == "f":
                    corners = [self._corner(c, where) for c in w[1:]]
                    if len(corners) != 3:
                        raise ValueError(f"{where}: face with {len(corners)} corners (only triangles are expected)")
                    self.tris.append({
                        "v": tuple(c[0] for c in corners),
                        "vt": tuple(c[1] for c in corners) if all(c[1] is not None for c in corners) else None,
                        "vn": tuple(c[2] for c in corners) if all(c[2] is not None for c in corners) else None,
                        "mtl": mtl, "obj": obj, "line": n})
                elif w[0] in ("s", "l"):
                    pass
                else:
                    raise ValueError(f"{where}: unexpected statement '{w[0]}'")

    def _corner(self, text, where):
        parts = (text.split("/") + ["", ""])[:3]
        sizes = (len(self.v), len(self.vt), len(self.vn))
        out = []
        for k, p in enumerate(parts):
            if p == "":
                out.append(None)
                continue
            i = int(p)
            i = i - 1 if i > 0 else sizes[k] + i
            if not 0 <= i < sizes[k]:
                raise ValueError(f"{where}: index {p} out of range")
            out.append(i)
        if out[0] is None:
            raise ValueError(f"{where}: corner '{text}' has no vertex index")
        return tuple(out)

    def pos(self, t):
        return [self.v[i] for i in t["v"]]

    def normal(self, t):
        a, b, c = self.pos(t)
        return cross(sub(b, a), sub(c, a))

    def centroid(self, t):
        return mean(self.pos(t))


def read_mtl(path):
    mats, cur = {}, None
    with open(path, encoding="ascii") as f:
        for line in f:
            w = line.split()
            if not w or w[0].startswith("#"):
                continue
            if w[0] == "newmtl":
                cur = mats.setdefault(w[1], {})
            elif cur is None:
                raise ValueError(f"{path}: '{w[0]}' before any newmtl")
            else:
                cur[w[0]] = w[1:]
    return mats


def read_png(path):
    """Decode an 8-bit RGB/RGBA non-interlaced PNG (all five filter types); return (w, h, rows of pixels)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    off, idat, hdr = 8, b"", None
    while off < len(data):
        (n,) = struct.unpack(">I", data[off:off + 4])
        kind, body = data[off + 4:off + 8], data[off + 8:off + 8 + n]
        (crc,) = struct.unpack(">I", data[off + 8 + n:off + 12 + n])
        if zlib.crc32(kind + body) & 0xFFFFFFFF != crc:
            raise ValueError(f"{path}: bad CRC in chunk {kind!r}")
        if kind == b"IHDR":
            hdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
        off += 12 + n
    w, h, depth, ctype, _, _, interlace = hdr
    if depth != 8 or ctype not in (2, 6) or interlace:
        raise ValueError(f"{path}: only 8-bit RGB/RGBA non-interlaced PNGs are supported here")
    bpp = 3 if ctype == 2 else 4
    raw = zlib.decompress(idat)
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        ft = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            if ft == 1:
                line[i] = (line[i] + a) & 255
            elif ft == 2:
                line[i] = (line[i] + b) & 255
            elif ft == 3:
                line[i] = (line[i] + (a + b) // 2) & 255
            elif ft == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[i] = (line[i] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append([tuple(line[x * bpp:x * bpp + 3]) for x in range(w)])
        prev = line
    return w, h, rows


# ------------------------------------------------------------------ checks
class Checker:
    def __init__(self, verbose):
        self.passed = self.failed = 0
        self.verbose = verbose

    def check(self, cond, what):
        if cond:
            self.passed += 1
            if self.verbose:
                print(f"ok   {what}")
        else:
            self.failed += 1
            print(f"FAIL {what}")
        return cond


def edge_report(obj):
    """(closed, consistent, boundary edges, non-manifold edges) by vertex index."""
    directed = Counter()
    for t in obj.tris:
        a, b, c = t["v"]
        for e in ((a, b), (b, c), (c, a)):
            directed[e] += 1
    undirected = Counter()
    for (a, b), n in directed.items():
        undirected[(min(a, b), max(a, b))] += n
    boundary = sum(1 for n in undirected.values() if n == 1)
    nonmanifold = sum(1 for n in undirected.values() if n > 2)
    consistent = all(n == 1 and directed.get((b, a), 0) == 1 for (a, b), n in directed.items())
    return boundary == 0 and nonmanifold == 0, consistent, boundary, nonmanifold, len(undirected)


def signed_volume(obj):
    return sum(dot(obj.v[t["v"][0]], cross(obj.v[t["v"][1]], obj.v[t["v"][2]])) for t in obj.tris) / 6.0


def check_common(ck, name, obj):
    degenerate = sum(1 for t in obj.tris if length(obj.normal(t)) < 1e-12)
    ck.check(degenerate == 0, f"{name}: no degenerate triangles ({degenerate})")
    if obj.vn:
        bad = 0
        for t in obj.tris:
            if t["vn"] is None:
                bad += 1
                continue
            g = unit(obj.normal(t))
            bad += any(dot(unit(obj.vn[i]), g) < 0.999 for i in t["vn"])
        ck.check(bad == 0, f"{name}: every corner's vn agrees with the geometric normal ({bad} triangles disagree)")


def check_closed(ck, name, obj, volume):
    closed, consistent, boundary, nonmanifold, edges = edge_report(obj)
    ck.check(closed, f"{name}: closed ({boundary} boundary, {nonmanifold} non-manifold edges)")
    ck.check(consistent, f"{name}: consistently wound (every edge used once in each direction)")
    euler = len({i for t in obj.tris for i in t["v"]}) - edges + len(obj.tris)
    ck.check(euler == 2, f"{name}: Euler characteristic V - E + F = {euler} (2 for a sphere)")
    vol = signed_volume(obj)
    if volume is None:
        ck.check(vol > 0, f"{name}: positive signed volume {vol:.6f} (outward winding)")
    else:
        ck.check(abs(vol - volume) < 1e-9, f"{name}: signed volume {vol:.6f}, expected {volume:.6f} (outward winding)")


def check_single_triangle(ck, d):
    o = Obj(os.path.join(d, "single_triangle.obj"))
    ck.check(len(o.tris) == 1 and len(o.v) == 3, f"single_triangle: 1 triangle, 3 vertices ({len(o.tris)}, {len(o.v)})")
    n = unit(o.normal(o.tris[0]))
    ck.check(dot(n, (0, 0, -1)) > 0.999, f"single_triangle: faces -z (normal {n})")
    check_common(ck, "single_triangle", o)


def check_cube(ck, d, fname, textured):
    name = fname[:-4]
    o = Obj(os.path.join(d, fname))
    ck.check(len(o.tris) == 12 and len(o.v) == 8, f"{name}: 12 triangles, 8 vertices ({len(o.tris)}, {len(o.v)})")
    ck.check(all(abs(c) == 0.5 for p in o.v for c in p), f"{name}: corners at +-0.5")
    check_closed(ck, name, o, 1.0)
    out = sum(1 for t in o.tris if dot(o.normal(t), o.centroid(t)) <= 0)
    ck.check(out == 0, f"{name}: every triangle faces away from the centre ({out} do not)")
    check_common(ck, name, o)
    if not textured:
        return
    ck.check(o.mtllibs == ["cube_textured.mtl"], f"{name}: mtllib cube_textured.mtl ({o.mtllibs})")
    mats = read_mtl(os.path.join(d, "cube_textured.mtl"))
    m = mats.get("cube_textured", {})
    ck.check(all(t["mtl"] == "cube_textured" for t in o.tris), f"{name}: every triangle uses material cube_textured")
    tex = m.get("map_Kd", [None])[-1]
    ck.check(tex == "cube_texture.png" and os.path.isfile(os.path.join(d, tex or "-")),
             f"{name}: map_Kd names an existing texture ({tex})")
    ck.check(m.get("map_Kd", [])[:2] == ["-clamp", "on"],
             f"{name}: map_Kd -clamp on (the reference scenes keep clamped lookups): {m.get('map_Kd')}")
    w, h, rows = read_png(os.path.join(d, "cube_texture.png"))
    ck.check((w, h) == (8, 8), f"{name}: texture is 8x8 ({w}x{h})")
    ck.check(rows[0][0] == (230, 40, 40) and rows[7][0] == (40, 70, 230),
             f"{name}: texture top-left texel red, bottom-left blue (row 0 is the top): {rows[0][0]}, {rows[7][0]}")
    ck.check(all(t["vt"] is not None for t in o.tris), f"{name}: every corner has a texture coordinate")
    ck.check(all(0 <= c <= 1 for uv in o.vt for c in uv), f"{name}: uvs inside [0, 1]")
    # Each face maps the texture unmirrored as seen from outside (uv triangle counter-clockwise, like the
    # geometry) and the image's top (v = 1) points towards +y on the sides, +z on top, -z on the bottom.
    bad_mirror = bad_up = 0
    for t in o.tris:
        p0, p1, p2 = o.pos(t)
        (u0, v0), (u1, v1), (u2, v2) = (o.vt[i] for i in t["vt"])
        area_uv = (u1 - u0) * (v2 - v0) - (u2 - u0) * (v1 - v0)
        bad_mirror += area_uv <= 0
        # dP/dv from the 2x2 system [e1 e2] = [dP/du dP/dv] [du; dv]
        du1, dv1, du2, dv2 = u1 - u0, v1 - v0, u2 - u0, v2 - v0
        det = du1 * dv2 - du2 * dv1
        e1, e2 = sub(p1, p0), sub(p2, p0)
        dpdv = tuple((-du2 * e1[k] + du1 * e2[k]) / det for k in range(3))
        n = unit(o.normal(t))
        want = (0, 0, 1) if n[1] > 0.5 else (0, 0, -1) if n[1] < -0.5 else (0, 1, 0)
        bad_up += dot(unit(dpdv), want) < 0.999
    ck.check(bad_mirror == 0, f"{name}: textures unmirrored seen from outside ({bad_mirror} triangles mirrored)")
    ck.check(bad_up == 0, f"{name}: image top towards +y (sides), +z (top), -z (bottom) ({bad_up} wrong)")


def polygon_overlap_2d(a, b):
    """Separating-axis test for two convex polygons (lists of (x, z))."""
    for poly in (a, b):
        for i in range(len(poly)):
            (x0, z0), (x1, z1) = poly[i], poly[(i + 1) % len(poly)]
            ax = (z0 - z1, x1 - x0)
            pa = [ax[0] * x + ax[1] * z for x, z in a]
            pb = [ax[0] * x + ax[1] * z for x, z in b]
            if max(pa) < min(pb) or max(pb) < min(pa):
                return False
    return True


def check_cornell(ck, d):
    name = "cornell_box"
    o = Obj(os.path.join(d, "cornell_box.obj"))
    ck.check(len(o.tris) == 32, f"{name}: 32 triangles ({len(o.tris)})")
    check_common(ck, name, o)
    # 16 quads: triangles come in coplanar pairs sharing an edge
    pairs_ok = True
    for k in range(0, len(o.tris), 2):
        a, b = o.tris[k], o.tris[k + 1]
        shared = set(a["v"]) & set(b["v"])
        pairs_ok &= len(shared) == 2 and dot(unit(o.normal(a)), unit(o.normal(b))) > 0.999999
        pairs_ok &= a["mtl"] == b["mtl"]
    ck.check(pairs_ok, f"{name}: triangles form 16 planar quads (consecutive pairs sharing an edge)")
    # materials
    ck.check(o.mtllibs == ["cornell_box.mtl"], f"{name}: mtllib cornell_box.mtl ({o.mtllibs})")
    mats = read_mtl(os.path.join(d, "cornell_box.mtl"))
    ck.check(set(mats) == set(CORNELL_MATERIALS), f"{name}: materials are {sorted(CORNELL_MATERIALS)} ({sorted(mats)})")
    for m, (kd, ks, ns) in CORNELL_MATERIALS.items():
        got = mats.get(m, {})
        ok = ([float(x) for x in got.get("Kd", [])] == list(kd) and [float(x) for x in got.get("Ks", [])] == list(ks)
              and [float(x) for x in got.get("Ns", [])] == [ns])
        ck.check(ok, f"{name}: material {m} Kd {kd} Ks {ks} Ns {ns} (file: {got})")
    counts = Counter(t["mtl"] for t in o.tris)
    ck.check(counts == Counter(CORNELL_TRIANGLES), f"{name}: triangles per material {dict(counts)}")
    # extents
    lo = tuple(min(p[k] for p in o.v) for k in range(3))
    hi = tuple(max(p[k] for p in o.v) for k in range(3))
    ck.check(lo == (-1, 0, -1) and hi == (1, 1.99, 1), f"{name}: bounds [-1,1] x [0,1.99] x [-1,1] ({lo}, {hi})")
    by = {m: [t for t in o.tris if t["mtl"] == m] for m in CORNELL_MATERIALS}

    def plane(m, axis, value):
        return all(abs(p[axis] - value) < 1e-12 for t in by[m] for p in o.pos(t))

    ck.check(plane("floor", 1, 0) and plane("ceiling", 1, 1.99) and plane("back", 2, 1)
             and plane("left", 0, 1) and plane("right", 0, -1),
             f"{name}: floor y=0, ceiling y=1.99, back z=+1, left (red) x=+1, right (green) x=-1")
    front = sum(1 for t in o.tris if all(abs(p[2] + 1) < 1e-9 for p in o.pos(t)))
    ck.check(front == 0, f"{name}: open side at z = -1 (no face there; {front} found)")
    room_c = (0, 0.995, 0)
    bad = [m for m in ("floor", "ceiling", "back", "left", "right")
           for t in by[m] if dot(o.normal(t), sub(room_c, o.centroid(t))) <= 0]
    ck.check(not bad, f"{name}: wall, floor and ceiling normals point into the room ({bad})")
    light_n = [unit(o.normal(t)) for t in by["light"]]
    ck.check(all(n[1] < -0.999999 for n in light_n), f"{name}: light quad faces down")
    ly = {p[1] for t in by["light"] for p in o.pos(t)}
    ck.check(ly == {1.989}, f"{name}: light quad at y = 1.989, 0.001 below the ceiling ({ly})")
    lx = [p[0] for t in by["light"] for p in o.pos(t)]
    lz = [p[2] for t in by["light"] for p in o.pos(t)]
    ck.check(-0.3 < min(lx) < 0 < max(lx) < 0.3 and -0.3 < min(lz) < 0 < max(lz) < 0.3,
             f"{name}: light quad near the ceiling centre (x {min(lx):.3f}..{max(lx):.3f}, z {min(lz):.3f}..{max(lz):.3f})")
    foot = {}
    for m, height in (("shortbox", 165 * 2 / 556), ("tallbox", 330 * 2 / 556)):
        pts = [p for t in by[m] for p in o.pos(t)]
        c = mean(list(dict.fromkeys(pts)))
        out = sum(1 for t in by[m] if dot(o.normal(t), sub(o.centroid(t), c)) <= 0)
        ck.check(out == 0, f"{name}: {m} faces point outward ({out} do not)")
        ys = sorted({p[1] for p in pts})
        ok = len(ys) == 2 and ys[0] == 0 and abs(ys[1] - height) < 1e-6
        ck.check(ok, f"{name}: {m} stands on the floor, height {height:.6f} (y values {ys})")
        inside = all(-1 < p[0] < 1 and -1 < p[2] < 1 for p in pts)
        ck.check(inside, f"{name}: {m} inside the room")
        top = [t for t in by[m] if unit(o.normal(t))[1] > 0.999]
        ck.check(len(top) == 2, f"{name}: {m} has a top quad facing up and 4 sides ({len(top)} top triangles)")
        foot[m] = list(dict.fromkeys((p[0], p[2]) for t in top for p in o.pos(t)))
        cx = sum(x for x, _ in foot[m]) / 4
        cz = sum(z for _, z in foot[m]) / 4
        foot[m].sort(key=lambda q: math.atan2(q[1] - cz, q[0] - cx))
    ck.check(not polygon_overlap_2d(foot["shortbox"], foot["tallbox"]), f"{name}: the two blocks do not overlap")
    sx = sum(x for x, _ in foot["shortbox"]) / 4
    tx = sum(x for x, _ in foot["tallbox"]) / 4
    sz = sum(z for _, z in foot["shortbox"]) / 4
    tz = sum(z for _, z in foot["tallbox"]) / 4
    ck.check(sx < 0 < tx and sz < tz,
             f"{name}: short block front right (x<0, nearer the open side), tall block back left (x>0) "
             f"as in the published data (short {sx:.3f},{sz:.3f}; tall {tx:.3f},{tz:.3f})")


def check_icosphere(ck, d):
    name = "icosphere"
    o = Obj(os.path.join(d, "icosphere.obj"))
    ck.check(len(o.tris) == 1280 and len(o.v) == 642, f"{name}: 1280 triangles, 642 vertices ({len(o.tris)}, {len(o.v)})")
    err = max(abs(length(p) - 1) for p in o.v)
    ck.check(err < 1e-8, f"{name}: vertices on the unit sphere (max error {err:.2e})")
    check_closed(ck, name, o, None)
    out = sum(1 for t in o.tris if dot(o.normal(t), o.centroid(t)) <= 0)
    ck.check(out == 0, f"{name}: every triangle faces outward ({out} do not)")
    check_common(ck, name, o)


def stl_triangles(path):
    """Triangles of a binary or ASCII STL as tuples of three (x, y, z)."""
    with open(path, "rb") as f:
        data = f.read()
    if len(data) >= 84 and 84 + 50 * struct.unpack("<I", data[80:84])[0] == len(data):
        n = struct.unpack("<I", data[80:84])[0]
        return [tuple(struct.unpack("<9f", data[84 + 50 * k + 12:84 + 50 * k + 48])[3 * j:3 * j + 3]
                      for j in range(3)) for k in range(n)]
    verts = [tuple(float(x) for x in l.split()[1:4]) for l in data.decode("ascii").splitlines()
             if l.split()[:1] == ["vertex"]]
    return [tuple(verts[3 * k:3 * k + 3]) for k in range(len(verts) // 3)]


def gltf_cube(path):
    """(triangles, uvs per corner, image) of the one-primitive glTF or GLB the generator writes."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        n = struct.unpack("<I", data[12:16])[0]
        doc = json.loads(data[20:20 + n])
        m = struct.unpack("<I", data[20 + n:24 + n])[0]
        buf = data[28 + n:28 + n + m]
    else:
        doc = json.loads(data)
        buf = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])

    def read(acc, fmt, k):
        a = doc["accessors"][acc]
        v = doc["bufferViews"][a["bufferView"]]
        off = v.get("byteOffset", 0)
        return list(struct.unpack(f"<{a['count'] * k}{fmt}", buf[off:off + a["count"] * k * struct.calcsize(fmt)]))

    prim = doc["meshes"][0]["primitives"][0]
    p = read(prim["attributes"]["POSITION"], "f", 3)
    t = read(prim["attributes"]["TEXCOORD_0"], "f", 2)
    idx = read(prim["indices"], "H", 1)
    tris = [tuple(tuple(p[3 * i:3 * i + 3]) for i in idx[3 * k:3 * k + 3]) for k in range(len(idx) // 3)]
    uvs = [tuple((t[2 * i], 1 - t[2 * i + 1]) for i in idx[3 * k:3 * k + 3]) for k in range(len(idx) // 3)]
    image = doc["images"][0]
    if "uri" in image:
        with open(os.path.join(os.path.dirname(path), image["uri"]), "rb") as f:
            png = f.read()
    else:
        v = doc["bufferViews"][image["bufferView"]]
        png = buf[v["byteOffset"]:v["byteOffset"] + v["byteLength"]]
    return tris, uvs, png


def check_cube_formats(ck, d):
    o = Obj(os.path.join(d, "cube_textured.obj"))
    tris = [tuple(o.v[i] for i in t["v"]) for t in o.tris]
    uvs = [tuple(o.vt[i] for i in t["vt"]) for t in o.tris]
    for name in ("cube.stl", "cube_ascii.stl"):
        got = stl_triangles(os.path.join(d, name))
        ck.check(got == tris, f"{name}: the OBJ cube's 12 triangles in its order ({len(got)} triangles)")
    with open(os.path.join(d, "cube_texture.png"), "rb") as f:
        png = f.read()
    for name in ("cube_textured.gltf", "cube_textured.glb"):
        got, got_uvs, got_png = gltf_cube(os.path.join(d, name))
        ck.check(got == tris, f"{name}: the OBJ cube's 12 triangles in its order ({len(got)} triangles)")
        ck.check(got_uvs == uvs, f"{name}: the OBJ cube's texture coordinates (v flipped as glTF's)")
        ck.check(got_png == png, f"{name}: the texture is cube_texture.png")


def check_wrap_rect(ck, d):
    o = Obj(os.path.join(d, "wrap_rect.obj"))
    ck.check(len(o.tris) == 2 and len(o.v) == 4, f"wrap_rect: 2 triangles, 4 vertices ({len(o.tris)}, {len(o.v)})")
    ck.check(all(dot(o.normal(t), (0, 0, -1)) > 0.999 for t in o.tris), "wrap_rect: both triangles face -z")
    us, vs = [uv[0] for uv in o.vt], [uv[1] for uv in o.vt]
    ck.check((min(us), max(us), min(vs), max(vs)) == (-1, 2, -0.5, 1.5),
             f"wrap_rect: u in [-1, 2], v in [-0.5, 1.5] ({min(us)}, {max(us)}, {min(vs)}, {max(vs)})")
    check_common(ck, "wrap_rect", o)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--dir", default=DEFAULT_DIR)
    ap.add_argument("-v", "--verbose", action="store_true", help="print passed checks too")
    a = ap.parse_args()
    ck = Checker(a.verbose)
    for fn in (lambda: check_single_triangle(ck, a.dir),
               lambda: check_cube(ck, a.dir, "cube.obj", False),
               lambda: check_cube(ck, a.dir, "cube_textured.obj", True),
               lambda: check_cornell(ck, a.dir),
               lambda: check_icosphere(ck, a.dir),
               lambda: check_cube_formats(ck, a.dir),
               lambda: check_wrap_rect(ck, a.dir)):
        try:
            fn()
        except (OSError, ValueError, KeyError, IndexError, TypeError, ZeroDivisionError) as e:
            ck.check(False, f"error: {e}")
    print(f"check_meshes: {ck.passed} passed, {ck.failed} failed")
    sys.exit(1 if ck.failed else 0)


if __name__ == "__main__":
    main()
