#!/usr/bin/env python3
"""Mitsuba's render of a peer's scene kept under tests/peer/, for tests/mitsuba_live.rs.

  .venv/bin/python scripts/mitsuba/peer_scene.py tests/peer/mitsuba_cornell_box/cornell_box.xml \
      -o MEAN.exr --variance VAR.exr [--seeds 64] [--spp 16] [--builtin cornell_box]

Renders the scene with Mitsuba's own plugins after three changes that fit it to rtdiff's model,
made on the XML text and printed: the `path` integrator's max_depth becomes 2 (direct light only:
rtdiff is a Whitted tracer), hide_emitters is set (rtdiff's lights are not surfaces) and the
reconstruction filter becomes a box (rtdiff averages each pixel's samples). K renders with
independent seeds give the mean and the per-pixel one-image variance (for Welch's test).

--builtin NAME first checks that the XML is a faithful transcription of Mitsuba's built-in scene
dictionary (mi.NAME()): both loaded without merging shapes, every traversed parameter equal to
1e-6 (relative above 1, absolute below), the same shapes, emitters and sensor; a difference is an error.
"""
import argparse
import json
import os
import sys
import time
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import numpy as np  # noqa: E402

import rtdiff_mitsuba as rm  # noqa: E402


def fitted_xml(path):
    """The scene's XML with the three changes (see the module doc), and a list saying what changed."""
    tree = ET.parse(path)
    root = tree.getroot()
    changes = []
    integrator = root.find("integrator")
    if integrator is None or integrator.get("type") != "path":
        sys.exit(f"peer_scene.py: {path}: expected a path integrator")
    depth = integrator.find("integer[@name='max_depth']")
    if depth is None:
        depth = ET.SubElement(integrator, "integer", name="max_depth")
    changes.append(f"path max_depth {depth.get('value', '-1')} -> 2")
    depth.set("value", "2")
    ET.SubElement(integrator, "boolean", name="hide_emitters", value="true")
    changes.append("hide_emitters true")
    for rf in root.iter("rfilter"):
        changes.append(f"rfilter {rf.get('type')} -> box")
        rf.set("type", "box")
        for child in list(rf):
            rf.remove(child)
    return ET.tostring(root, encoding="unicode"), changes


def check_builtin(mi, path, name):
    """Error unless `path` loads to the same parameters as mi.<name>()."""
    ours = mi.load_file(path, optimize=False)
    theirs = mi.load_dict(getattr(mi, name)(), optimize=False)
    pa, pb = mi.traverse(ours), mi.traverse(theirs)
    ka, kb = set(pa.keys()), set(pb.keys())
    if ka != kb:
        sys.exit(f"peer_scene.py: {path} is not mi.{name}(): parameters only here {sorted(ka - kb)}, "
                 f"only there {sorted(kb - ka)}")
    worst = 0.0
    for k in sorted(ka):
        a, b = pa[k], pb[k]
        if hasattr(a, "matrix"):
            a, b = a.matrix, b.matrix
        try:
            x, y = np.array(a, dtype=np.float64).reshape(-1), np.array(b, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            continue
        if x.shape != y.shape:
            sys.exit(f"peer_scene.py: {path} is not mi.{name}(): {k} has {x.size} values, {y.size} there")
        if x.size:
            # Relative above 1, absolute below: cos(90 degrees) is -4.4e-8 in one float32 rotation
            # and 0 or -8.3e-9 in another, a rounding of the same transform.
            worst = max(worst, float(np.max(np.abs(x - y) / np.maximum(np.maximum(np.abs(x), np.abs(y)), 1.0))))
    if worst > 1e-6:
        sys.exit(f"peer_scene.py: {path} is not mi.{name}(): parameters differ by {worst:.2e} relative")
    shapes = lambda s: sorted(sh.id() for sh in s.shapes())  # noqa: E731
    if shapes(ours) != shapes(theirs) or len(ours.emitters()) != len(theirs.emitters()):
        sys.exit(f"peer_scene.py: {path} is not mi.{name}(): shapes {shapes(ours)} / {shapes(theirs)}")
    return {"builtin": name, "parameters": len(ka), "max_relative_difference": worst}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--variance", required=True)
    ap.add_argument("--seeds", type=int, default=64)
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--builtin", default=None)
    ap.add_argument("--variant", default=None)
    a = ap.parse_args()
    if a.seeds < 2:
        sys.exit("peer_scene.py: --seeds must be >= 2")
    mi = rm.setup(a.variant)
    info = {"scene": a.scene, "mitsuba": mi.__version__, "variant": mi.variant()}
    if a.builtin:
        info["transcription"] = check_builtin(mi, a.scene, a.builtin)
    text, changes = fitted_xml(a.scene)
    # Relative paths in the XML resolve against its folder.
    resolver = mi.file_resolver() if hasattr(mi, "file_resolver") else mi.Thread.thread().file_resolver()
    resolver.prepend(os.path.dirname(os.path.abspath(a.scene)))
    scene = mi.load_string(text)
    imgs, t0 = [], time.perf_counter()
    for k in range(a.seeds):
        img = np.array(mi.render(scene, seed=rm._seed32(k, 0), spp=a.spp), dtype=np.float64)[:, :, :3]
        imgs.append(img)
    stack = np.stack(imgs)
    rm.write_exr(a.output, stack.mean(axis=0).astype(np.float32))
    rm.write_exr(a.variance, stack.var(axis=0, ddof=1).astype(np.float32))
    info.update({"changes": changes, "seeds": a.seeds, "spp": a.spp,
                 "render_seconds": round(time.perf_counter() - t0, 3)})
    print(json.dumps(info))


if __name__ == "__main__":
    main()
