#!/usr/bin/env python3
"""Independent side of rtdiff's image-metric cross-check (tests/image_crosscheck.rs).

For each REF TEST pair of linear EXRs, prints (JSON, one object per pair):
  oiio:   OpenImageIO ImageBufAlgo.compare(ref, test, threshold, threshold): meanerror, rms_error,
          PSNR, maxerror, maxx, maxy, maxc, nfail
  flip:   flip-evaluator on the float images: LDR (linear clamped to [0, 1], inputsRGB=False) and HDR
          (linear) means, and HDR's exposure parameters
  flip_q: flip-evaluator on the 8-bit sRGB-quantised inputs rtdiff gives NVIDIA's kernel through the
          nv-flip crate: LDR, and HDR built from LDR runs at the same exposures (ACES, clamp, sRGB, 8 bit)
Images are loaded with OIIO (flip-evaluator's own EXR reader mis-decodes PIZ, see
../shared/notes/mitsuba.md) and passed as HxWx3 float32 arrays.

  .venv/bin/python scripts/mitsuba/crosscheck_metrics.py [--threshold T] [--no-flip] REF TEST [REF TEST ...]
  .venv/bin/python scripts/mitsuba/crosscheck_metrics.py --mitsuba-pair DIR   # two Mitsuba EXRs (spp 4, 16)
"""
import argparse
import json
import os
import sys

import numpy as np


def load(path):
    import OpenImageIO as oiio

    buf = oiio.ImageBuf(path)
    if buf.has_error:
        sys.exit(f"{path}: {buf.geterror()}")
    spec = buf.spec()
    names = list(spec.channelnames)
    idx = [names.index(c) for c in "RGB"]
    px = buf.get_pixels(oiio.FLOAT)
    return buf, np.ascontiguousarray(px[:, :, idx]).astype(np.float32)


def srgb8(x):
    """Clamp, sRGB-encode and quantise to 8 bits, as rtdiff feeds nv-flip; returned as float in [0, 1]."""
    x = np.clip(x, 0.0, 1.0).astype(np.float32)
    s = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1.0 / 2.4) - 0.055).astype(np.float32)
    return (np.floor(s * 255.0 + 0.5) / 255.0).astype(np.float32)


ACES = [0.6 * 0.6 * 2.51, 0.6 * 0.03, 0.0, 0.6 * 0.6 * 2.43, 0.6 * 0.59, 0.14]


def aces(x):
    return (x * x * ACES[0] + x * ACES[1] + ACES[2]) / (x * x * ACES[3] + x * ACES[4] + ACES[5])


def pair(ref_path, test_path, threshold, with_flip=True):
    import OpenImageIO as oiio
    import flip_evaluator as fe

    ref_buf, ref = load(ref_path)
    test_buf, test = load(test_path)
    # Compare only R, G, B (Mitsuba's EXRs may carry A).
    rgb = lambda b: oiio.ImageBufAlgo.channels(b, ("R", "G", "B"))
    c = oiio.ImageBufAlgo.compare(rgb(ref_buf), rgb(test_buf), threshold, threshold)
    out = {
        "reference": ref_path,
        "test": test_path,
        "oiio": {
            "meanerror": c.meanerror,
            "rms_error": c.rms_error,
            "PSNR": c.PSNR,
            "maxerror": c.maxerror,
            "maxx": c.maxx,
            "maxy": c.maxy,
            "maxc": c.maxc,
            "nfail": c.nfail,
        },
    }
    if not with_flip:
        return out
    _, ldr, _ = fe.evaluate(np.clip(ref, 0, 1), np.clip(test, 0, 1), "LDR", inputsRGB=False, applyMagma=False)
    _, hdr, params = fe.evaluate(ref, test, "HDR", applyMagma=False)
    out["flip"] = {"ldr": float(ldr), "hdr": float(hdr), "hdr_params": {k: float(v) for k, v in params.items()
                                                                         if k != "tonemapper"}}
    q_ldr, _, _ = fe.evaluate(srgb8(ref), srgb8(test), "LDR", inputsRGB=True, applyMagma=False)
    start, stop, n = params["startExposure"], params["stopExposure"], int(params["numExposures"])
    step = (stop - start) / (n - 1) if n > 1 else 0.0
    q_hdr = None
    for i in range(n):
        k = np.float32(2.0 ** (start + i * step))
        m, _, _ = fe.evaluate(srgb8(aces(ref * k)), srgb8(aces(test * k)), "LDR", inputsRGB=True, applyMagma=False)
        q_hdr = m if q_hdr is None else np.maximum(q_hdr, m)
    out["flip_q"] = {"ldr": float(q_ldr.astype(np.float64).mean()), "hdr": float(q_hdr.astype(np.float64).mean())}
    return out


def mitsuba_pair(outdir):
    """Render Mitsuba's built-in Cornell box (128x128) at 4 and 16 spp to DIR/mitsuba_4.exr, DIR/mitsuba_16.exr."""
    import mitsuba as mi

    variant = "llvm_ad_rgb" if os.path.exists("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1") else "scalar_rgb"
    if variant == "llvm_ad_rgb":
        os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
    mi.set_variant(variant)
    d = mi.cornell_box()
    d["sensor"]["film"]["width"] = 128
    d["sensor"]["film"]["height"] = 128
    d["sensor"]["film"]["pixel_format"] = "rgb"
    scene = mi.load_dict(d)
    os.makedirs(outdir, exist_ok=True)
    paths = []
    for spp, seed in [(4, 1), (16, 2)]:
        mi.render(scene, spp=spp, seed=seed)
        p = os.path.join(outdir, f"mitsuba_{spp}.exr")
        scene.sensors()[0].film().bitmap().write(p)
        paths.append(p)
    print(json.dumps({"variant": variant, "images": paths}))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--threshold", type=float, default=1e-3)
    ap.add_argument("--mitsuba-pair", metavar="DIR")
    ap.add_argument("--no-flip", action="store_true", help="OpenImageIO's compare only")
    ap.add_argument("images", nargs="*")
    a = ap.parse_args()
    if a.mitsuba_pair:
        mitsuba_pair(a.mitsuba_pair)
        return
    if len(a.images) == 0 or len(a.images) % 2:
        ap.error("give REF TEST pairs")
    res = [pair(a.images[i], a.images[i + 1], a.threshold, not a.no_flip) for i in range(0, len(a.images), 2)]
    print(json.dumps(res, indent=1))


if __name__ == "__main__":
    main()
