#!/usr/bin/env python3
"""Render a bundled scene with Mitsuba 3 and time it: the other side of
`tessera-bench mitsuba` (the time-to-quality comparison).

The scene is read from its glTF by gltf_scene.py (the same float32 triangles,
normals, materials and camera Tessera loads; `path` integrator, or `volpath`
for absorbing glass, with max_depth = -1, box filter). A scene it cannot
translate faithfully exits with status 2 and one line on stderr saying what.
The scene is loaded and one render is run first, so the LLVM kernels are
compiled before the clock starts; then each requested render is timed from
the call to the pixels being in host memory.

Output: one OpenEXR per render (R, G, B float32), and one line per render on
stdout, which tessera-bench parses:

    render sampler=multijitter spp=64 seconds=1.234567 out=/path.exr

Requirements (tools, not project dependencies):
    pip install mitsuba numpy OpenEXR
    apt-get install -y libllvm19
    export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1

Usage:
    python3 tests/reference/mitsuba_render.py --scene cornell-box --size 256 --spp 64 \
        --samplers independent,multijitter --seed 1 --out-dir /tmp/mi
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time

import numpy as np

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from gltf_scene import Unsupported, build_scene_dict, scene_path  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="cornell-box", help="a bundled scene's name or a .gltf path")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--samplers", default="independent,multijitter",
                    help="comma-separated Mitsuba sampler plugins")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeats", type=int, default=1, help="timed renders per sampler, seeds seed, seed+1, …")
    ap.add_argument("--out-dir", required=True)
    args = ap.parse_args()

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    print(f"mitsuba {mi.__version__}, variant {mi.variant()}, threads {dr.thread_count()}", flush=True)
    os.makedirs(args.out_dir, exist_ok=True)
    for name in args.samplers.split(","):
        with tempfile.TemporaryDirectory() as tmp:
            try:
                desc = build_scene_dict(mi, scene_path(args.scene), tmp, args.size)
            except Unsupported as e:
                print(f"Mitsuba cannot render {args.scene} as Tessera does: {e}", file=sys.stderr)
                return 2
            desc["sensor"]["sampler"] = {"type": name, "sample_count": args.spp}
            scene = mi.load_dict(desc)
        # Warm-up: compiles (or loads from Dr.Jit's cache) the kernels this render needs.
        np.array(mi.render(scene, seed=args.seed + 7919, spp=args.spp))
        for r in range(args.repeats):
            t0 = time.perf_counter()
            img = np.array(mi.render(scene, seed=args.seed + r, spp=args.spp), dtype=np.float32)
            elapsed = time.perf_counter() - t0
            out = os.path.join(args.out_dir, f"mitsuba-{name}-{args.spp}spp-r{r}.exr")
            mi.Bitmap(np.ascontiguousarray(img[:, :, :3])).write(out)
            print(f"render sampler={name} spp={args.spp} seconds={elapsed:.6f} out={out}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
