#!/usr/bin/env python3
"""Render the independent Mitsuba 3 reference of scenes/cornell-box.gltf.

The geometry is NOT read from the .gltf: it is imported from
scenes/generate.py (cornell_box_objects(), CORNELL_MATERIALS, CORNELL_CAMERA),
which is the very data the .gltf is written from, so both renderers see the
same triangles (same float32 vertex values, same winding).

Output: an OpenEXR (float32, ZIP) with channels
    R, G, B                      mean of K independent passes
    variance.R/.G/.B             variance of that mean = sample variance of the
                                 K pass values / K   (per pixel, per channel)

Requirements (not project dependencies):  pip install mitsuba numpy OpenEXR
For the llvm_ad_rgb variant Dr.Jit needs libLLVM, e.g. on Debian 12:
    apt-get install -y libllvm19
    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1

Usage:
    python3 tests/reference/make_cornell_reference.py \
        [--variant llvm_ad_rgb] [--passes 8] [--spp 16384] [--chunk 1024] \
        [--size 128] [--out tests/reference/cornell-box-mitsuba.exr]

Seeds: chunk j of pass k renders with seed = 1000 * k + j, so every
mi.render call uses a distinct seed and the K passes are independent.
"""

from __future__ import annotations

import argparse
import os
import struct
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.normpath(os.path.join(HERE, "..", ".."))
sys.dont_write_bytecode = True  # keep scenes/ free of __pycache__
sys.path.insert(0, os.path.join(REPO, "scenes"))

import generate  # noqa: E402  (scenes/generate.py)


def write_ply(path: str, triangles) -> None:
    """Binary little-endian PLY, one unshared vertex triple per triangle."""
    nv = 3 * len(triangles)
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"element vertex {nv}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(triangles)}\nproperty list uchar int vertex_indices\nend_header\n"
    ).encode("ascii")
    body = bytearray()
    for t in triangles:
        for p in t:
            body += struct.pack("<3f", *p)
    for k in range(len(triangles)):
        body += struct.pack("<B3i", 3, 3 * k, 3 * k + 1, 3 * k + 2)
    with open(path, "wb") as fh:
        fh.write(header + bytes(body))


def build_scene_dict(mi, tmpdir: str, size: int) -> dict:
    cam = generate.CORNELL_CAMERA
    scene = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1},
        "sensor": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": cam["yfov_deg"],
            "to_world": mi.ScalarTransform4f().look_at(
                origin=list(cam["position"]), target=list(cam["target"]), up=list(cam["up"])),
            "sampler": {"type": "independent", "sample_count": 1},
            "film": {
                "type": "hdrfilm",
                "width": size,
                "height": size,
                "rfilter": {"type": "box"},
                "pixel_format": "rgb",
                "component_format": "float32",
            },
        },
    }
    for obj in generate.cornell_box_objects():
        mat = generate.CORNELL_MATERIALS[obj["material"]]
        path = os.path.join(tmpdir, obj["name"] + ".ply")
        write_ply(path, obj["triangles"])
        shape = {
            "type": "ply",
            "filename": path,
            "face_normals": True,  # flat shading == the glTF's per-face NORMALs
            "bsdf": {"type": "diffuse",
                     "reflectance": {"type": "rgb", "value": list(mat["albedo"])}},
        }
        if mat["radiance"] is not None:
            shape["emitter"] = {"type": "area",
                                "radiance": {"type": "rgb", "value": list(mat["radiance"])}}
        scene[obj["name"]] = shape
    return scene


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
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--passes", type=int, default=8, help="K independent passes")
    ap.add_argument("--spp", type=int, default=16384, help="samples per pixel per pass")
    ap.add_argument("--chunk", type=int, default=1024, help="spp per mi.render call")
    ap.add_argument("--size", type=int, default=128)
    ap.add_argument("--out", default=os.path.join(HERE, "cornell-box-mitsuba.exr"))
    args = ap.parse_args()
    assert args.spp % args.chunk == 0, "--spp must be a multiple of --chunk"

    import mitsuba as mi

    mi.set_variant(args.variant)
    print(f"mitsuba {mi.__version__}, variant {mi.variant()}", flush=True)

    with tempfile.TemporaryDirectory() as tmp:
        scene = mi.load_dict(build_scene_dict(mi, tmp, args.size))

    nchunks = args.spp // args.chunk
    passes = []
    t0 = time.time()
    for k in range(args.passes):
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
    comment = (f"Mitsuba {mi.__version__} {mi.variant()} path max_depth=-1; K={args.passes} passes x "
               f"{args.spp} spp (total {args.passes * args.spp} spp); seeds 1000*k+j; "
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
