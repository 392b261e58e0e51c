#!/usr/bin/env python3
"""Render a scene exported by `rtdiff export SCENE --to mitsuba -o DIR` with Mitsuba 3 and the
rtdiff_whitted plugin; write a linear float32 EXR (byte-deterministic) and print a JSON line with
the variant, samples, seeds and timing.

  .venv/bin/python scripts/mitsuba/render.py DIR -o OUT.exr [--seed S] [--seeds K --variance VAR.exr]
                                             [--passes N] [--variant scalar_rgb|llvm_ad_rgb]

With --seeds K the image is the mean of K renders with seeds S..S+K-1, and --variance writes the
per-pixel unbiased sample variance of those K renders (the noise estimate for a Welch test).
"""
import argparse
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import numpy as np  # noqa: E402

import rtdiff_mitsuba as rm  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scene_dir")
    ap.add_argument("-o", "--output", required=True)
    ap.add_argument("--seed", type=int, default=None, help="first seed (default: the scene's)")
    ap.add_argument("--seeds", type=int, default=1, help="independent renders averaged (K)")
    ap.add_argument("--variance", help="write the per-pixel variance across the K renders here")
    ap.add_argument("--passes", type=int, default=None, help="samples per pixel (default spp x dof_samples)")
    ap.add_argument("--variant", default=None)
    a = ap.parse_args()
    if not os.path.isfile(os.path.join(a.scene_dir, "scene.xml")):
        sys.exit(f"render.py: {a.scene_dir}: no scene.xml (make one with rtdiff export)")
    if a.seeds < 1 or (a.variance and a.seeds < 2):
        sys.exit("render.py: --seeds must be >= 1 (>= 2 with --variance)")
    mi = rm.setup(a.variant)
    cfg = rm.config(a.scene_dir)
    scene = rm.load(mi, a.scene_dir)
    seed0 = cfg["seed"] if a.seed is None else a.seed
    imgs, times = [], []
    for k in range(a.seeds):
        t0 = time.perf_counter()
        imgs.append(rm.render(mi, scene, cfg, seed0 + k, a.passes).astype(np.float64))
        times.append(time.perf_counter() - t0)
    stack = np.stack(imgs)
    mean = stack.mean(axis=0).astype(np.float32)
    rm.write_exr(a.output, mean)
    if a.variance:
        rm.write_exr(a.variance, stack.var(axis=0, ddof=1).astype(np.float32))
    print(json.dumps({
        "scene_dir": a.scene_dir, "output": a.output, "variance": a.variance,
        "mitsuba": mi.__version__, "variant": mi.variant(),
        "width": cfg["width"], "height": cfg["height"],
        "samples_per_pixel": a.passes or cfg["spp"] * cfg["dof_samples"],
        "seeds": list(range(seed0, seed0 + a.seeds)), "deterministic": cfg["deterministic"],
        "render_seconds": round(sum(times), 4), "seconds_per_seed": [round(t, 4) for t in times],
        "warnings": cfg["warnings"],
    }))


if __name__ == "__main__":
    main()
