#!/usr/bin/python3
"""Relative MSE of one replay's composites against another's on the virtual objects' pixels.

    scripts/compare_composites.py TRUTH_OUT CANDIDATE_OUT MASK_OUT RECORDING

TRUTH_OUT, CANDIDATE_OUT: `lightskin replay` output folders of the same recording (frames/NNNNNN.png, sRGB).
MASK_OUT: a replay of the same recording and objects with `--differential off`: the pixels where its composite
differs from the recording's colour image by more than 2 steps are the virtual objects' (the differential would
also change real pixels around them). Prints per frame and the median over frames: the relative MSE in linear
light, sum (C - T)^2 / sum T^2 over those pixels, and the ratio of the mean linear levels C / T. Used for
docs/ROOMLIGHT.md "Against the true lights" (the estimated room light against the synthetic room's own).
"""
import glob
import os
import sys

import numpy as np
from PIL import Image


def linear(path):
    srgb = np.asarray(Image.open(path).convert("RGB"), dtype=np.float64) / 255.0
    return np.where(srgb <= 0.04045, srgb / 12.92, ((srgb + 0.055) / 1.055) ** 2.4)


def main(truth, candidate, mask_out, recording):
    errors, ratios = [], []
    for path in sorted(glob.glob(os.path.join(truth, "frames", "*.png"))):
        name = os.path.basename(path)
        camera = np.asarray(Image.open(os.path.join(recording, "colour", name)).convert("RGB"), dtype=np.int32)
        plain = np.asarray(Image.open(os.path.join(mask_out, "frames", name)).convert("RGB"), dtype=np.int32)
        mask = np.any(np.abs(plain - camera) > 2, axis=2)
        if mask.sum() == 0:
            continue
        t = linear(path)[mask]
        c = linear(os.path.join(candidate, "frames", name))[mask]
        errors.append(float(np.sum((c - t) ** 2) / np.sum(t ** 2)))
        ratios.append(float(c.mean() / t.mean()))
        print(f"{name}: {mask.sum()} px, relative MSE {errors[-1]:.4f}, level ratio {ratios[-1]:.3f}")
    if not errors:
        sys.exit("compare_composites.py: no frame with virtual pixels")
    print(f"median over {len(errors)} frames: relative MSE {np.median(errors):.4f}, level ratio {np.median(ratios):.3f}")


if __name__ == "__main__":
    if len(sys.argv) != 5:
        sys.exit(__doc__)
    main(*sys.argv[1:])
