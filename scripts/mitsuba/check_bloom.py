#!/usr/bin/env python3
"""Bloom against OpenImageIO: apply the reports' bloom to rtdiff's image before bloom with OIIO's own
operators (../shared/notes/mitsuba.md, "Bloom oracle") and compare with rtdiff's bloomed image. `straddling_pixels` counts the pixels within 1% above the
threshold (the ones a 1% higher threshold would leave out: the check's power against a moved threshold).

  .venv/bin/python scripts/mitsuba/check_bloom.py BEFORE.exr AFTER.exr THRESHOLD KERNEL_SIZE SCALE

bloom = img + scale * Gauss(img * [Y >= threshold]), Y = 0.2126 R + 0.7152 G + 0.0722 B; OIIO:
channel_sum for Y, contrast_remap(black = white = threshold) as the step, make_kernel('gaussian', w, w)
and convolve (edge-clamped). Prints one JSON line; exits 1 when the largest difference exceeds 1e-5
(float32 sums of up to w^2 terms of size <= 1: a few ulps of the largest value, measured 1.5e-5 at
values up to 4 in the note; here the images stay below 1.5).
"""
import json
import sys

import numpy as np
import OpenImageIO as oiio
from OpenImageIO import ImageBufAlgo as iba

TOL = 1e-5


def main():
    before, after, t, w, s = sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5])
    img = oiio.ImageBuf(before)
    ref_after = oiio.ImageBuf(after).get_pixels(oiio.FLOAT)[:, :, :3]
    rgb = iba.channels(img, (0, 1, 2))
    y = iba.channel_sum(rgb, (0.2126, 0.7152, 0.0722))
    step = iba.contrast_remap(y, black=t, white=t)
    mask = step.get_pixels(oiio.FLOAT)[:, :, :1]
    bright = oiio.ImageBuf(np.ascontiguousarray(rgb.get_pixels(oiio.FLOAT) * mask))
    kernel = iba.make_kernel("gaussian", w, w)
    blurred = iba.convolve(bright, kernel)
    ours = rgb.get_pixels(oiio.FLOAT) + s * blurred.get_pixels(oiio.FLOAT)
    diff = np.abs(ours - ref_after)
    worst = np.unravel_index(int(np.argmax(diff)), diff.shape)
    bright_px = int((mask[:, :, 0] > 0).sum())
    # Pixels within 1% above the threshold: those a 1% higher threshold would drop.
    lum = y.get_pixels(oiio.FLOAT)[:, :, 0]
    straddling = int(((lum >= t) & (lum < 1.01 * t)).sum())
    out = {"max_abs_diff": float(diff.max()), "pixel": [int(worst[1]), int(worst[0])], "bright_pixels": bright_px,
           "straddling_pixels": straddling,
           "changed_pixels": int((np.abs(ref_after - rgb.get_pixels(oiio.FLOAT)) > 1e-6).any(axis=2).sum()),
           "tolerance": TOL}
    print(json.dumps(out))
    sys.exit(0 if diff.max() <= TOL and bright_px > 0 else 1)


if __name__ == "__main__":
    main()
