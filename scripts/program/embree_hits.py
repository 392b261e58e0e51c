#!/usr/bin/env python3
"""A tracer rtdiff cannot link, for the program path: Embree 4.4 in its default mode
(embreex's EmbreeScene, no robust flag) traces a ray file and writes a hit file.

    python scripts/program/embree_hits.py MESH.obj RAYS.csv HITS.csv

MESH.obj is read here, in its own coordinates, faces in file order and polygons fanned
from their first vertex (so primitive ids are triangle positions in the file); RAYS.csv is
`ox,oy,oz,dx,dy,dz,tnear,tfar` (`rtdiff rays` writes it; lines starting with # and the
header are skipped); HITS.csv gets `hit,t,prim,u,v` per ray. Embree's `rtcIntersect1` as
embreex calls it starts every ray at 0: a ray with tnear other than 0 is refused.
Then: rtdiff judge MESH.obj --rays RAYS.csv --hits HITS.csv
"""
import sys

import numpy as np
from embreex.mesh_construction import TriangleMesh
from embreex.rtcore_scene import EmbreeScene


def read_obj(path):
    """Vertices (float32, as written) and triangles (fans of each face, in file order)."""
    verts, tris = [], []
    raw = open(path, "rb").read()
    if raw.startswith((b"\xfe\xff", b"\xff\xfe")):
        text = raw.decode("utf-16")
    else:
        text = raw.decode("utf-8", errors="replace")
    for line in text.splitlines():
        parts = line.split()
        if not parts:
            continue
        if parts[0] == "v":
            verts.append([float(x) for x in parts[1:4]])
        elif parts[0] == "f":
            idx = []
            for tok in parts[1:]:
                i = int(tok.split("/")[0])
                idx.append(i - 1 if i > 0 else len(verts) + i)
            for k in range(1, len(idx) - 1):
                tris.append([idx[0], idx[k], idx[k + 1]])
    return np.array(verts, dtype=np.float32), np.array(tris, dtype=np.int32).reshape(-1, 3)


def read_rays(path):
    rows = []
    with open(path, encoding="utf-8") as f:
        for line in f:
            line = line.strip()
            if not line or line.startswith("#") or line.startswith("ox"):
                continue
            rows.append([float(x) for x in line.split(",")])
    return np.array(rows, dtype=np.float32).reshape(-1, 8)


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    mesh, rays_path, hits_path = sys.argv[1:]
    verts, tris = read_obj(mesh)
    rays = read_rays(rays_path)
    if np.any(rays[:, 6] != 0):
        sys.exit(f"{rays_path}: a ray with tnear other than 0 (embreex starts every ray at 0)")
    scene = EmbreeScene()  # Embree's default scene flags (not robust), default build quality
    TriangleMesh(scene, verts, tris)
    out = scene.run(rays[:, 0:3].copy(), rays[:, 3:6].copy(), dists=rays[:, 7].copy(), output=1)
    with open(hits_path, "w", encoding="utf-8") as f:
        f.write("hit,t,prim,u,v\n")
        for t, p, u, v in zip(out["tfar"], out["primID"], out["u"], out["v"]):
            if p < 0:
                f.write("0,,,,\n")
            else:
                # float() of a float32 is exact: the decimal reads back to the same float32.
                f.write(f"1,{float(t)!r},{p},{float(u)!r},{float(v)!r}\n")
    print(f"{len(rays)} rays, {int(np.sum(out['primID'] >= 0))} hits -> {hits_path}", file=sys.stderr)


if __name__ == "__main__":
    main()
