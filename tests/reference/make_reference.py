#!/usr/bin/env python3
"""Render an independent Mitsuba 3 reference of a bundled scene.

The scene is read from its .gltf by gltf_scene.py (the same float32 vertex
values, normals, winding, materials and camera Tessera loads); a scene using
anything it cannot translate faithfully is refused.

Output: an OpenEXR (float32, ZIP) with channels
    R, G, B                      mean of K independent passes
    variance.R/.G/.B             variance of that mean = sample variance of the
                                 K pass values / K   (per pixel, per channel)

Requirements (not project dependencies):  pip install mitsuba numpy OpenEXR
For the llvm_ad_rgb variant Dr.Jit needs libLLVM, e.g. on Debian 12:
    apt-get install -y libllvm19
    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1

Usage:
    python3 tests/reference/make_reference.py [--scene cornell-box] [--flat-shading] \
        [--variant llvm_ad_rgb] [--passes 8] [--spp 16384] [--chunk 1024] \
        [--size 128] [--first-pass 0] [--out tests/reference/SCENE-mitsuba.exr]

Seeds: chunk j of pass k renders with seed = 1000 * k + j, so every
mi.render call uses a distinct seed and the K passes are independent. Passes
are numbered from --first-pass, so a second reference with --first-pass 8 shares
no seed with the default's passes 0..7 (to check a reference against another).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.dont_write_bytecode = True  # keep the repository free of __pycache__
sys.path.insert(0, HERE)

from gltf_scene import build_scene_dict, scene_path  # noqa: E402


def write_exr(path: str, mean: np.ndarray, var: np.ndarray, comment: str) -> None:
    chans = {}
    for i, c in enumerate("RGB"):
        chans[c] = np.ascontiguousarray(mean[:, :, i], dtype=np.float32)
        chans["variance." + c] = np.ascontiguousarray(var[:, :, i], dtype=np.float32)
    try:
        import OpenEXR

        header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage,
                  "comments": comment}
        with OpenEXR.File(header, chans) as f:
            f.write(path)
    except ImportError:  # fall back to Mitsuba's own writer (compression: its default)
        import mitsuba as mi

        names = list(chans)
        data = np.stack([chans[n] for n in names], axis=-1)
        bmp = mi.Bitmap(data, pixel_format=mi.Bitmap.PixelFormat.MultiChannel, channel_names=names)
        bmp.write(path)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="cornell-box", help="a bundled scene's name or a .gltf path")
    ap.add_argument("--flat-shading", action="store_true",
                    help="ignore vertex normals (see gltf_scene.build_scene_dict); output SCENE-flat-mitsuba.exr")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--passes", type=int, default=8, help="K independent passes")
    ap.add_argument("--spp", type=int, default=16384, help="samples per pixel per pass")
    ap.add_argument("--chunk", type=int, default=1024, help="spp per mi.render call")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--first-pass", type=int, default=0, help="number of the first pass (seeds 1000 * pass + chunk)")
    ap.add_argument("--out", help="default: tests/reference/SCENE-mitsuba.exr")
    args = ap.parse_args()
    assert args.spp % args.chunk == 0, "--spp must be a multiple of --chunk"
    name = os.path.splitext(os.path.basename(args.scene))[0] + ("-flat" if args.flat_shading else "")
    args.out = args.out or os.path.join(HERE, f"{name}-mitsuba.exr")

    import mitsuba as mi

    mi.set_variant(args.variant)
    print(f"mitsuba {mi.__version__}, variant {mi.variant()}", flush=True)

    with tempfile.TemporaryDirectory() as tmp:
        desc = build_scene_dict(mi, scene_path(args.scene), tmp, args.size, flat=args.flat_shading)
        scene = mi.load_dict(desc)

    nchunks = args.spp // args.chunk
    passes = []
    t0 = time.time()
    for k in range(args.first_pass, args.first_pass + args.passes):
        acc = np.zeros((args.size, args.size, 3), dtype=np.float64)
        for j in range(nchunks):
            seed = 1000 * k + j
            img = mi.render(scene, seed=seed, spp=args.chunk)
            acc += np.array(img, dtype=np.float64)
        passes.append(acc / nchunks)
        m = passes[-1].mean(axis=(0, 1))
        print(f"pass {k}: seeds {1000 * k}..{1000 * k + nchunks - 1}, mean "
              f"({m[0]:.6f}, {m[1]:.6f}, {m[2]:.6f}), elapsed {time.time() - t0:.1f} s", flush=True)
    wall = time.time() - t0

    stack = np.stack(passes)  # K x H x W x 3
    mean = stack.mean(axis=0)
    var_of_mean = stack.var(axis=0, ddof=1) / args.passes
    comment = (f"{name}: Mitsuba {mi.__version__} {mi.variant()} {desc['integrator']['type']} max_depth=-1; "
               f"K={args.passes} passes x "
               f"{args.spp} spp (total {args.passes * args.spp} spp); seeds 1000*k+j, k from {args.first_pass}; "
               f"RGB = mean, variance.* = sample variance of passes / K")
    write_exr(args.out, mean, var_of_mean, comment)

    m = mean.mean(axis=(0, 1))
    print(f"wrote {args.out}")
    print(f"total {args.passes * args.spp} spp in {wall:.1f} s")
    print(f"image mean  R {m[0]:.6f}  G {m[1]:.6f}  B {m[2]:.6f}")
    print(f"mean of per-pixel std.err.  R {np.sqrt(var_of_mean[..., 0]).mean():.6f}  "
          f"G {np.sqrt(var_of_mean[..., 1]).mean():.6f}  B {np.sqrt(var_of_mean[..., 2]).mean():.6f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
