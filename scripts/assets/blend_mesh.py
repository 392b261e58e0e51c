#!/usr/bin/env python3
"""Read the base mesh (vertices and faces, no modifiers) of a mesh in a Blender .blend file and write OBJ.

Written for the old (pre-2.63, "MFace") mesh layout that Blender 2.4x-2.62 files use, such as
assimp's test model SuzanneSubdiv_252.blend.  The file's own SDNA (its embedded struct catalogue) is
read to find field offsets, so nothing about struct layouts is hard-coded except field names.
Modifiers (e.g. Subdivision Surface) live on the Object, not the Mesh, and are ignored: what is
written is exactly the mesh data as stored.

Output transform: each vertex (x, y, z) in mesh-local coordinates becomes (sx*x, sy*y, sz*z) with
--scale SX SY SZ.  A quad (v1, v2, v3, v4) is split along its shorter diagonal: (v1, v2, v3), (v1, v3, v4)
if |v1 v3| <= |v2 v4|, else (v1, v2, v4), (v2, v3, v4) (--quad-split v1v3 always uses the first).
--reverse-winding then reverses the corner list of each face, which flips every triangle (and swaps
the order of a quad's two triangles).  --weld merges vertices with identical coordinates, keeping
first-occurrence order (the Suzanne file stores 1198 vertices at 505 distinct positions).
Coordinates are written with 7 significant digits (the data are float32), trailing zeros removed.

usage: blend_mesh.py INPUT.blend OUTPUT.obj [--mesh NAME] [--object-name NAME] [--scale SX SY SZ]
                     [--reverse-winding] [--weld] [--quad-split shortest|v1v3] [--comment TEXT ...]
"""

import argparse
import gzip
import math
import struct
import sys

from objio import AssetError, fail, write_obj


class Blend:
    def __init__(self, path):
        self.path = path
        with open(path, "rb") as f:
            data = f.read()
        if data[:2] == b"\x1f\x8b":  # "compressed" .blend files are gzip streams
            data = gzip.decompress(data)
        if data[:7] != b"BLENDER":
            raise AssetError(f"{path}: not a .blend file (no BLENDER header)")
        self.ptr = {b"_": 4, b"-": 8}[data[7:8]]
        self.end = {b"v": "<", b"V": ">"}[data[8:9]]
        self.version = data[9:12].decode()
        self.data = data
        self.blocks = []  # (code, offset of data, size, old address, sdna index, count)
        self.by_addr = {}
        pfmt = "I" if self.ptr == 4 else "Q"
        hfmt = self.end + "4si" + pfmt + "ii"
        hsize = struct.calcsize(hfmt)
        off = 12
        while off + hsize <= len(data):
            code, size, addr, sdna, count = struct.unpack_from(hfmt, data, off)
            off += hsize
            code = code.rstrip(b"\0").decode("latin-1")
            if code == "ENDB":
                break
            blk = (code, off, size, addr, sdna, count)
            self.blocks.append(blk)
            self.by_addr[addr] = blk
            off += size
        dna = [b for b in self.blocks if b[0] == "DNA1"]
        if not dna:
            raise AssetError(f"{path}: no DNA1 block")
        self._read_sdna(dna[0])

    def _read_sdna(self, blk):
        d, off = self.data, blk[1]
        e = self.end

        def expect(tag):
            nonlocal off
            if d[off:off + 4] != tag:
                raise AssetError(f"{self.path}: SDNA: expected {tag!r} at {off}")
            off += 4

        def strings(n):
            nonlocal off
            out = []
            for _ in range(n):
                z = d.index(b"\0", off)
                out.append(d[off:z].decode("latin-1"))
                off = z + 1
            return out

        def align():
            nonlocal off
            off = (off + 3) & ~3

        expect(b"SDNA")
        expect(b"NAME")
        (n,) = struct.unpack_from(e + "i", d, off); off += 4
        self.names = strings(n); align()
        expect(b"TYPE")
        (n,) = struct.unpack_from(e + "i", d, off); off += 4
        self.types = strings(n); align()
        expect(b"TLEN")
        self.tlen = list(struct.unpack_from(e + "%dh" % n, d, off)); off += 2 * n; align()
        expect(b"STRC")
        (n,) = struct.unpack_from(e + "i", d, off); off += 4
        self.structs = []  # (type name, {field name: (offset, type name, decl)})
        self.struct_index = {}
        for _ in range(n):
            t, nf = struct.unpack_from(e + "hh", d, off); off += 4
            fields, foff = {}, 0
            for _ in range(nf):
                ft, fn = struct.unpack_from(e + "hh", d, off); off += 4
                decl = self.names[fn]
                size = self.ptr if ("*" in decl or decl.startswith("(")) else self.tlen[ft]
                mult = 1
                for part in decl.split("[")[1:]:
                    mult *= int(part.rstrip("]"))
                bare = decl.lstrip("*").split("[")[0]
                fields[bare] = (foff, self.types[ft], decl)
                foff += size * mult
            self.struct_index[self.types[t]] = len(self.structs)
            self.structs.append((self.types[t], fields))

    def struct_of(self, blk):
        return self.structs[blk[4]]

    def field(self, sname, fname):
        s = self.structs[self.struct_index[sname]][1]
        if fname not in s:
            raise AssetError(f"{self.path}: struct {sname} has no field '{fname}' (this .blend layout is not supported)")
        return s[fname]

    def read(self, base, sname, fname, fmt):
        off, _, _ = self.field(sname, fname)
        return struct.unpack_from(self.end + fmt, self.data, base + off)

    def read_ptr(self, base, sname, fname):
        return self.read(base, sname, fname, "I" if self.ptr == 4 else "Q")[0]

    def id_name(self, base, sname):
        off, _, decl = self.field(sname, "id")
        noff, _, ndecl = self.field("ID", "name")
        raw = self.data[base + off + noff: base + off + noff + 66]
        return raw.split(b"\0")[0].decode("latin-1")


def read_mesh(b, mesh_name=None):
    meshes = [blk for blk in b.blocks if blk[0] == "ME"]
    if not meshes:
        raise AssetError(f"{b.path}: no mesh (ME block) in the file")
    names = [b.id_name(blk[1], "Mesh") for blk in meshes]
    if mesh_name is None:
        if len(meshes) != 1:
            raise AssetError(f"{b.path}: {len(meshes)} meshes ({', '.join(names)}); name one with --mesh")
        blk, name = meshes[0], names[0]
    else:
        hits = [m for m, n in zip(meshes, names) if n[2:] == mesh_name or n == mesh_name]
        if not hits:
            raise AssetError(f"{b.path}: no mesh named '{mesh_name}' (found {', '.join(names)})")
        blk, name = hits[0], mesh_name
    base = blk[1]
    totvert = b.read(base, "Mesh", "totvert", "i")[0]
    totface = b.read(base, "Mesh", "totface", "i")[0]
    pv = b.read_ptr(base, "Mesh", "mvert")
    pf = b.read_ptr(base, "Mesh", "mface")
    if pv not in b.by_addr or pf not in b.by_addr:
        raise AssetError(f"{b.path}: mesh '{name}' has no MVert/MFace data (a newer, BMesh-era file?)")
    vblk, fblk = b.by_addr[pv], b.by_addr[pf]
    vsize = b.tlen[b.types.index("MVert")]
    fsize = b.tlen[b.types.index("MFace")]
    if vblk[5] != totvert or fblk[5] != totface:
        raise AssetError(f"{b.path}: mesh '{name}': block counts {vblk[5]}/{fblk[5]} disagree with "
                         f"totvert/totface {totvert}/{totface}")
    verts = [b.read(vblk[1] + i * vsize, "MVert", "co", "3f") for i in range(totvert)]
    faces = []
    for i in range(totface):
        fb = fblk[1] + i * fsize
        v = [b.read(fb, "MFace", k, "I")[0] for k in ("v1", "v2", "v3", "v4")]
        faces.append(tuple(v if v[3] != 0 else v[:3]))  # v4 == 0 marks a triangle in MFace
    return name[2:], verts, faces


def fmt(x):
    """Shortest decimal text of x rounded to 7 significant digits (float32 data), no trailing zeros."""
    s = "%.7g" % x
    if "e" not in s and "." in s:
        s = s.rstrip("0").rstrip(".")
    if s == "-0":
        s = "0"
    return s


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("input")
    ap.add_argument("output")
    ap.add_argument("--mesh", help="mesh datablock name (default: the only mesh in the file)")
    ap.add_argument("--object-name", help="name written on the OBJ 'o' line (default: the mesh name)")
    ap.add_argument("--scale", nargs=3, type=float, default=[1.0, 1.0, 1.0], metavar=("SX", "SY", "SZ"))
    ap.add_argument("--reverse-winding", action="store_true",
                    help="reverse the corner order of each face (after splitting quads)")
    ap.add_argument("--quad-split", choices=["shortest", "v1v3"], default="shortest",
                    help="split quads along the shorter diagonal (default; ties use v1-v3) or always v1-v3")
    ap.add_argument("--weld", action="store_true",
                    help="merge vertices with identical coordinates (keeps first-occurrence order)")
    ap.add_argument("--comment", action="append", default=[])
    a = ap.parse_args()
    try:
        b = Blend(a.input)
        name, verts, faces = read_mesh(b, a.mesh)
        nstored = len(verts)
        sx, sy, sz = a.scale
        if a.weld:
            # Merge vertices whose stored coordinates are identical; first occurrence keeps its place.
            index, remap, kept = {}, [], []
            for v in verts:
                if v not in index:
                    index[v] = len(kept)
                    kept.append(v)
                remap.append(index[v])
            verts = kept
            faces = [tuple(remap[i] for i in f) for f in faces]
        positions = [(fmt(sx * x), fmt(sy * y), fmt(sz * z)) for x, y, z in verts]
        tris = []
        for f in faces:
            if len(f) == 3:
                corners = list(f)
            elif a.quad_split == "shortest" and math.dist(verts[f[1]], verts[f[3]]) < math.dist(verts[f[0]], verts[f[2]]):
                corners = [f[0], f[1], f[3], f[1], f[2], f[3]]  # along the v2-v4 diagonal
            else:
                corners = [f[0], f[1], f[2], f[0], f[2], f[3]]  # along the v1-v3 diagonal
            if a.reverse_winding:
                corners.reverse()  # flips every triangle (and the order of a quad's two triangles)
            tris.extend(tuple(corners[k:k + 3]) for k in range(0, len(corners), 3))
        write_obj(a.output, a.comment, a.object_name or name, positions, tris)
        print(f"{a.input}: Blender {b.version}, mesh '{name}': {nstored} stored vertices, {len(verts)} written, "
              f"{len(faces)} faces -> {len(tris)} triangles", file=sys.stderr)
    except (AssetError, OSError, ValueError, KeyError, IndexError, struct.error) as e:
        fail(f"{a.input}: {e}")


if __name__ == "__main__":
    main()
