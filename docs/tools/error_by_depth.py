#!/usr/bin/env python3
"""Where an image's estimated error comes from, by path depth, and what adaptive sampling could buy.

Usage: error_by_depth.py FULL.exr [CAPPED.exr ...]

FULL is a render with unbounded depth; each CAPPED the same render (same spp, seed) with
`--max-depth N`. Every Tessera EXR has a per-pixel `variance` layer (the variance of the pixel's
mean). The relMSE estimate used here is mean over pixels and channels of Var(mean) / (m + 0.01)^2,
with m the FULL image's pixel mean for every file, so the figures add up: a capped render's share
is the error of the light paths up to that depth.

The allocation bound: spreading the same number of samples over pixels (or tiles) in proportion
to sqrt(per-sample relative variance) minimises the relMSE; its gain over uniform spp is
mean(r) / mean(sqrt(r))^2. The per-pixel variances are estimates, whose noise inflates this
bound, so it is an upper bound on what pixel-adaptive sampling could gain on this image.
Needs numpy and OpenEXR (pip install numpy OpenEXR).
"""
import sys

import numpy as np
import OpenEXR


def layers(path):
    ch = OpenEXR.File(path).channels()
    return ch["RGB"].pixels.astype(np.float64), ch["variance"].pixels.astype(np.float64)


def main(paths):
    mean, var = layers(paths[0])
    den = (mean + 0.01) ** 2
    full = (var / den).mean()
    print(f"{paths[0]}: relMSE estimate {full:.4e} (100 %)")
    for p in paths[1:]:
        v = layers(p)[1]
        share = (v / den).mean()
        print(f"{p}: {share:.4e} ({100 * share / full:.1f} % of the full render's)")
    r = (var / den).mean(axis=2)
    h, w = r.shape
    print(f"bound on the relMSE gain of sample allocation at equal samples: per pixel {r.mean() / np.sqrt(r).mean() ** 2:.3f}", end="")
    for t in (8, 16, 64):
        if h % t == 0 and w % t == 0:
            rt = r.reshape(h // t, t, w // t, t).mean(axis=(1, 3))
            print(f", per {t}x{t} tile {rt.mean() / np.sqrt(rt).mean() ** 2:.3f}", end="")
    print()


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
