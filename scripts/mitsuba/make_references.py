#!/usr/bin/env python3
"""Regenerate reference/: Mitsuba 3 renders of every scene of scenes/ that has an oracle, in the
`phong` and the `physical` model, through `rtdiff export` and the rtdiff_whitted plugin, and the
native references of NATIVE: the physical model through Mitsuba's own emitters, BSDFs and
integrators (`rtdiff export --oracle native`).

  .venv/bin/python scripts/mitsuba/make_references.py [--rtdiff target/release/rtdiff] [--only NAME ...]
  .venv/bin/python scripts/mitsuba/make_references.py --refresh-manifest

--refresh-manifest re-exports every reference and rewrites what the export says about it
(traced_sha256, oracle, plugins, warnings) without rendering: for a change of the export's
description (a new field in the digest) that leaves the pixels alone. The image hashes are kept;
regenerate a sample to prove the pixels did not move (byte-identical files).

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
# Samples per pixel and seed of a noisy native reference, at least: Mitsuba's own render loop
# integrates over the pixel, and where a sub-pixel feature covers ~1.5% of a pixel (a shadow's
# edge beside the Cornell box's mirror) 64 seeds of 4 samples see it ~4 times and sometimes not at
# all (measured: 0 of 256 samples for seeds 0-63 at one pixel, whose variance estimate was then
# 6x too small and failed Welch's test against rtdiff and the plugin alike); 16 samples per seed
# see it ~15 times. More samples do not change the expected value.
NATIVE_MIN_SPP = 16
MODELS = ("phong", "physical")
# Scenes without an image oracle, and why (docs/oracles.md repeats this).
NO_ORACLE = {}
# Feature switches of a scene's reference: bloom is a post-process outside Mitsuba (its oracle is
# OpenImageIO, tests/mitsuba_live.rs), so all_features is referenced before bloom. It is the only
# reference with glossy reflection, transparency, depth of field (thin lens), bilinear textures,
# interpolated normals and a point + parallelogram light together.
FEATURES = {"all_features": ["bloom=off"]}
# Native references (physical model, Mitsuba's own plugins) and the rtdiff flags they need
# (docs/oracles.md): monkey's Kd 0.8 + Ks 0.5 mirrors have no blendbsdf, so its native
# reference has recursion off; the Cornell box's mirror is one bounce deep (the native oracle
# separates one bounce exactly); noisy native images integrate over the pixel, so rtdiff renders
# them with a 2 x 2 jittered grid of camera samples (--spp 4).
NATIVE = {
    "single_triangle": {},
    "cube_textured": {},
    "teapot": {},
    "spheres": {},
    "dragon": {},
    "custom": {},
    "monkey": {"features": ["recursive=off"]},
    "cornell_box": {"max_depth": 1, "spp": 4},
    "cornell_box_area_light": {},
    "depth_of_field": {"spp": 4},
    "texture_wrap": {},
    "texture_wrap_bilinear": {"scene": "texture_wrap", "features": ["bilinear_filtering=on"]},
}
# Scenes whose image size is part of the test (texture_wrap frames each rectangle as 96 x 64 pixels,
# 4 pixels per texel, so that no pixel centre lies on a texel edge).
SIZES = {"texture_wrap": (288, 64)}


def sha256(path):
    with open(path, "rb") as f:
        return hashlib.sha256(f.read()).hexdigest()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rtdiff", default=os.path.join(ROOT, "target", "release", "rtdiff"))
    ap.add_argument("--out", default=os.path.join(ROOT, "reference"))
    ap.add_argument("--only", nargs="*", help="scene names to regenerate (manifest entries of the others kept)")
    ap.add_argument("--oracle", choices=["plugin", "native"], help="only references of this oracle")
    ap.add_argument("--refresh-manifest", action="store_true", help="re-export every reference, render nothing")
    ap.add_argument("--variant", default=None)
    a = ap.parse_args()
    if not os.access(a.rtdiff, os.X_OK):
        sys.exit(f"make_references.py: {a.rtdiff}: not found (cargo build --release first)")
    os.makedirs(a.out, exist_ok=True)
    mi = rm.setup(a.variant)
    manifest_path = os.path.join(a.out, "manifest.json")
    old = {}
    if (a.only or a.oracle or a.refresh_manifest) and os.path.exists(manifest_path):
        with open(manifest_path) as f:
            old = {key(e): e for e in json.load(f)["references"]}
    scenes = sorted(f[:-5] for f in os.listdir(os.path.join(ROOT, "scenes")) if f.endswith(".json"))
    jobs = [Job(name, FEATURES.get(name, []), model, "plugin") for name in scenes if name not in NO_ORACLE
            for model in MODELS]
    jobs += [Job(name, opts.get("features", []), "physical", "native", opts.get("spp"), opts.get("max_depth"),
                 opts.get("scene", name))
             for name, opts in NATIVE.items()]
    entries = []
    for job in jobs:
        k = (job.name, job.model, job.oracle)
        if a.refresh_manifest:
            if k in old:
                entries.append(refresh(a, job, old[k]))
            continue
        if (a.only and job.name not in a.only) or (a.oracle and job.oracle != a.oracle):
            if k in old:
                entries.append(old[k])
            continue
        entries.append(make_one(mi, a, job))
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


class Job:
    """One reference: scene `name` in `model` through `oracle` ("plugin" or "native"), with
    feature switches and, where given, rtdiff's camera samples and recursion depth."""

    def __init__(self, name, features, model, oracle, spp=None, max_depth=None, scene=None):
        self.name, self.features, self.model, self.oracle = name, features, model, oracle
        self.spp, self.max_depth = spp, max_depth
        self.scene = scene or name
        self.width, self.height = SIZES.get(self.scene, (WIDTH, HEIGHT))

    def base(self):
        return f"{self.name}.{self.model}" + (".native" if self.oracle == "native" else "")

    def export(self, a, out_dir):
        """Run rtdiff export for this job into out_dir; returns its rtdiff.json."""
        cmd = [a.rtdiff, "export", os.path.join(ROOT, "scenes", f"{self.scene}.json"), "--to", "mitsuba", "-o",
               out_dir, "--model", self.model, "--oracle", self.oracle, "--width", str(self.width), "--height",
               str(self.height), "--quiet"]
        for f in self.features:
            cmd += ["--feature", f]
        if self.spp is not None:
            cmd += ["--spp", str(self.spp)]
        if self.max_depth is not None:
            cmd += ["--max-depth", str(self.max_depth)]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        return rm.config(out_dir)


def key(e):
    """Manifest key of an entry (entries written before native references are plugin ones)."""
    return (e["name"], e["model"], e.get("oracle", "plugin"))


def describe(job, cfg):
    """What the export says about a reference: the fields --refresh-manifest rewrites."""
    return {
        "traced_sha256": cfg["traced_sha256"],
        "oracle": cfg["oracle"],
        "oracle_reasons": cfg["oracle_reasons"],
        "integrator": cfg["plugins"]["integrator"],
        "emitters": cfg["plugins"]["emitters"],
        "bsdfs": cfg["plugins"]["bsdfs"],
        "export_warnings": cfg["warnings"],
    }


def refresh(a, job, entry):
    """`entry` with the description of a fresh export (no render)."""
    with tempfile.TemporaryDirectory(prefix="rtdiff-ref-") as tmp:
        cfg = job.export(a, tmp)
    new = dict(entry)
    new.update(describe(job, cfg))
    new["spp"], new["max_depth"] = job.spp, job.max_depth
    new["width"], new["height"] = job.width, job.height
    if new["traced_sha256"] != entry["traced_sha256"]:
        print(f"{job.base()}: traced_sha256 {entry['traced_sha256'][:12]} -> {new['traced_sha256'][:12]}",
              file=sys.stderr)
    return new


def make_one(mi, a, job):
    scene_rel = f"scenes/{job.scene}.json"
    scene_path = os.path.join(ROOT, scene_rel)
    with tempfile.TemporaryDirectory(prefix="rtdiff-ref-") as tmp:
        cfg = job.export(a, tmp)
        scene = rm.load(mi, tmp)
        k = 1 if cfg["deterministic"] else SEEDS
        native = cfg["oracle"] == "native"
        spp = max(cfg["recipe"]["spp"], NATIVE_MIN_SPP) if native and k > 1 else None
        imgs, secs = [], []
        for seed in range(k):
            t0 = time.perf_counter()
            imgs.append(rm.render(mi, scene, cfg, seed, spp).astype(np.float64))
            secs.append(time.perf_counter() - t0)
    stack = np.stack(imgs)
    base = job.base()
    mean_file = f"{base}.exr"
    rm.write_exr(os.path.join(a.out, mean_file), stack.mean(axis=0).astype(np.float32))
    entry = {
        "name": job.name,
        "scene": scene_rel,
        "features": job.features,
        "spp": job.spp,
        "max_depth": job.max_depth,
        "width": job.width,
        "height": job.height,
        "scene_sha256": sha256(scene_path),
        "model": job.model,
        "deterministic": cfg["deterministic"],
        "mitsuba_spp": (spp or cfg["recipe"]["spp"]) if native else cfg["mitsuba_spp"],
        "light_samples": cfg["light_samples"] if cfg["plan"]["area_lights"] else None,
        "seeds": list(range(k)),
        "render_seconds": round(sum(secs), 3),
        "image": mean_file,
        "image_sha256": sha256(os.path.join(a.out, mean_file)),
    }
    entry.update(describe(job, cfg))
    if k > 1:
        var_file = f"{base}.var.exr"
        rm.write_exr(os.path.join(a.out, var_file), stack.var(axis=0, ddof=1).astype(np.float32))
        entry["variance"] = var_file
        entry["variance_sha256"] = sha256(os.path.join(a.out, var_file))
    print(f"{base}: {'deterministic' if k == 1 else f'{k} seeds'}, {entry['render_seconds']} s", file=sys.stderr)
    return entry


if __name__ == "__main__":
    main()
