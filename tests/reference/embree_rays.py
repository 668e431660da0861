#!/usr/bin/env python3
"""Trace a Tessera render's own rays through Mitsuba 3's ray tracing (Embree) and time it.

`tessera-bench bvh --scene NAME --save-rays FILE` writes every ray its one-core render traced
(camera, bounce and shadow rays, as 8 little-endian float32 each: origin, direction, t_max,
kind 0 = closest hit / 1 = shadow). This script loads the same scene from its glTF with
gltf_scene.py, hands the rays to Mitsuba in one wavefront, and times:

* closest-hit rays: `Scene.ray_intersect_preliminary` (distance, primitive and shape only,
  no surface record, as Tessera's traversal returns);
* shadow rays: `Scene.ray_test` up to t_max.

Mitsuba's CPU variants trace through Embree (the PyPI wheels ship libembree3; its JIT variants
call Embree's packet kernels as wide as the CPU's vectors), so this is the traversal behind
`tessera-bench mitsuba`'s figures, on the rays Tessera traced. One thread by default
(`--threads`), as `tessera-bench bvh` times ours. The rays are in device memory and the kernels
compiled before the clock starts; each round is timed from launch to results.

Materials are irrelevant here, so a scene with materials gltf_scene.py refuses is loaded with
every surface matte (`--any-material`).

Usage:
    target/release/tessera-bench bvh --scene cornell-box --save-rays /tmp/rays.bin
    python3 tests/reference/embree_rays.py --scene cornell-box --rays /tmp/rays.bin
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

import gltf_scene  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="cornell-box", help="a bundled scene's name or a .gltf path")
    ap.add_argument("--rays", required=True, help="the file of `tessera-bench bvh --save-rays`")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--any-material", action="store_true", help="load every surface as matte")
    args = ap.parse_args()

    raw = np.fromfile(args.rays, dtype="<f4")
    if raw.size == 0 or raw.size % 8:
        print(f"{args.rays}: not a ray file ({raw.size} floats, expected a multiple of 8)", file=sys.stderr)
        return 1
    rays = raw.reshape(-1, 8)

    import drjit as dr
    import mitsuba as mi

    mi.set_variant(args.variant)
    dr.set_thread_count(args.threads)
    if args.any_material:
        gltf_scene.bsdf_of = lambda mat, name: ({"type": "diffuse"}, None)
    with tempfile.TemporaryDirectory() as tmp:
        try:
            scene = mi.load_dict(gltf_scene.build_scene_dict(mi, gltf_scene.scene_path(args.scene), tmp, 16))
        except gltf_scene.Unsupported as e:
            print(f"cannot load {args.scene}: {e} (--any-material loads every surface as matte)", file=sys.stderr)
            return 2

    results = {}
    for kind, name in ((0.0, "closest-hit"), (1.0, "shadow")):
        sel = rays[rays[:, 7] == kind]
        if len(sel) == 0:
            continue
        cols = [mi.Float(np.ascontiguousarray(sel[:, i])) for i in range(7)]
        ray = mi.Ray3f(mi.Point3f(*cols[0:3]), mi.Vector3f(*cols[3:6]))
        ray.maxt = cols[6]
        dr.eval(ray)
        times = []
        for _ in range(args.rounds + 1):  # the first compiles the kernel (or loads it from the cache)
            t0 = time.perf_counter()
            if kind == 0.0:
                pi = scene.ray_intersect_preliminary(ray, coherent=False)
                hit = pi.is_valid()
                dr.eval(pi.t, pi.prim_index, pi.shape_index, hit)
            else:
                hit = scene.ray_test(ray)
                dr.eval(hit)
            dr.sync_thread()
            times.append(time.perf_counter() - t0)
        secs = sorted(times[1:])[len(times[1:]) // 2]
        hits = int(np.count_nonzero(np.array(hit)))
        results[name] = (len(sel), hits, secs)
        print(f"{name}: {len(sel)} rays, {hits} hit, {len(sel) / secs / 1e6:.2f} M rays/s "
              f"(median of {args.rounds} rounds, {args.threads} thread{'s' if args.threads > 1 else ''})")
    n = sum(r[0] for r in results.values())
    secs = sum(r[2] for r in results.values())
    hits = sum(r[1] for r in results.values())
    print(f"mitsuba {mi.__version__} {mi.variant()} (Embree: {mi.MI_ENABLE_EMBREE}): all {n} rays, "
          f"{hits} hit, {n / secs / 1e6:.2f} M rays/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
