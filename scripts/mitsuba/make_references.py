#!/usr/bin/env python3
"""Regenerate reference/: Mitsuba 3 renders of every scene of scenes/ that has an oracle, in the
`phong` and the `physical` model, through `rtdiff export` and the rtdiff_whitted plugin.

  .venv/bin/python scripts/mitsuba/make_references.py [--rtdiff target/release/rtdiff] [--only NAME ...]

Deterministic scenes (pixel centres, point lights, mirrors, textures) get one render; scenes that
sample area lights get K independent renders (seeds 0..K-1) stored as their mean and per-pixel
variance (for the Welch test of tests/mitsuba_reference.rs). Images are written by OpenImageIO in
one thread with zip compression, so a regeneration gives byte-identical files (their sha256 are in
reference/manifest.json); the manifest's render seconds naturally vary.
"""
import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import numpy as np  # noqa: E402

import rtdiff_mitsuba as rm  # noqa: E402

# Image size of every reference: large enough for ~16K pixel comparisons per scene, small
# enough to keep reference/ well under 25 MB and the cargo test to seconds.
WIDTH = HEIGHT = 128
# Independent Mitsuba renders of a noisy scene (the Welch test's reference sample size K; see
# tests/mitsuba_reference.rs for why 64: with K = 16 and 8 the per-pixel t-tests' far tails, where
# Benjamini-Hochberg decides, rest on variances estimated from a handful of seeds).
SEEDS = 64
MODELS = ("phong", "physical")
# Scenes without an image oracle, and why (docs/oracles.md repeats this).
NO_ORACLE = {}
# Feature switches of a scene's reference: bloom is a post-process outside Mitsuba (its oracle is
# OpenImageIO, tests/mitsuba_live.rs), so all_features is referenced before bloom. It is the only
# reference with glossy reflection, transparency, depth of field (thin lens), bilinear textures,
# interpolated normals and a point + parallelogram light together.
FEATURES = {"all_features": ["bloom=off"]}


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rtdiff", default=os.path.join(ROOT, "target", "release", "rtdiff"))
    ap.add_argument("--out", default=os.path.join(ROOT, "reference"))
    ap.add_argument("--only", nargs="*", help="scene names to regenerate (manifest entries of the others kept)")
    ap.add_argument("--variant", default=None)
    a = ap.parse_args()
    if not os.access(a.rtdiff, os.X_OK):
        sys.exit(f"make_references.py: {a.rtdiff}: not found (cargo build --release first)")
    os.makedirs(a.out, exist_ok=True)
    mi = rm.setup(a.variant)
    manifest_path = os.path.join(a.out, "manifest.json")
    old = {}
    if a.only and os.path.exists(manifest_path):
        with open(manifest_path) as f:
            old = {(e["name"], e["model"]): e for e in json.load(f)["references"]}
    scenes = sorted(f[:-5] for f in os.listdir(os.path.join(ROOT, "scenes")) if f.endswith(".json"))
    entries = []
    jobs = [(name, name, FEATURES.get(name, [])) for name in scenes if name not in NO_ORACLE]
    for ref_name, name, features in jobs:
        for model in MODELS:
            if a.only and ref_name not in a.only:
                if (ref_name, model) in old:
                    entries.append(old[(ref_name, model)])
                continue
            entries.append(make_one(mi, a, ref_name, name, features, model))
    manifest = {
        "generator": "scripts/mitsuba/make_references.py",
        "mitsuba": mi.__version__,
        "variant": mi.variant(),
        "width": WIDTH,
        "height": HEIGHT,
        "no_oracle": NO_ORACLE,
        "references": entries,
    }
    with open(manifest_path, "w") as f:
        json.dump(manifest, f, indent=2)
        f.write("\n")
    total = sum(os.path.getsize(os.path.join(a.out, x)) for x in os.listdir(a.out))
    print(f"reference/: {len(entries)} references, {total / 1e6:.2f} MB", file=sys.stderr)


def make_one(mi, a, ref_name, name, features, model):
    scene_rel = f"scenes/{name}.json"
    scene_path = os.path.join(ROOT, scene_rel)
    with tempfile.TemporaryDirectory(prefix="rtdiff-ref-") as tmp:
        cmd = [a.rtdiff, "export", scene_path, "--to", "mitsuba", "-o", tmp, "--model", model,
               "--width", str(WIDTH), "--height", str(HEIGHT), "--quiet"]
        for f in features:
            cmd += ["--feature", f]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        cfg = rm.config(tmp)
        scene = rm.load(mi, tmp)
        k = 1 if cfg["deterministic"] else SEEDS
        imgs, secs = [], []
        for seed in range(k):
            t0 = time.perf_counter()
            imgs.append(rm.render(mi, scene, cfg, seed).astype(np.float64))
            secs.append(time.perf_counter() - t0)
    stack = np.stack(imgs)
    base = f"{ref_name}.{model}"
    mean_file = f"{base}.exr"
    rm.write_exr(os.path.join(a.out, mean_file), stack.mean(axis=0).astype(np.float32))
    entry = {
        "name": ref_name,
        "scene": scene_rel,
        "features": features,
        "scene_sha256": sha256(scene_path),
        "traced_sha256": cfg["traced_sha256"],
        "model": model,
        "deterministic": cfg["deterministic"],
        "mitsuba_spp": cfg["mitsuba_spp"],
        "light_samples": cfg["light_samples"] if cfg["plan"]["area_lights"] else None,
        "seeds": list(range(k)),
        "render_seconds": round(sum(secs), 3),
        "image": mean_file,
        "image_sha256": sha256(os.path.join(a.out, mean_file)),
        "export_warnings": cfg["warnings"],
    }
    if k > 1:
        var_file = f"{base}.var.exr"
        rm.write_exr(os.path.join(a.out, var_file), stack.var(axis=0, ddof=1).astype(np.float32))
        entry["variance"] = var_file
        entry["variance_sha256"] = sha256(os.path.join(a.out, var_file))
    print(f"{base}: {'deterministic' if k == 1 else f'{k} seeds'}, {entry['render_seconds']} s", file=sys.stderr)
    return entry


if __name__ == "__main__":
    main()
