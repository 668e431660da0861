#!/usr/bin/env python3
"""Where the light tree starts to pay: two light choices on two families of scenes.

Whether a scene chooses a light sample's triangle through the light tree instead of by power
depends on its lights (`LightTree::MIN_LIGHTS` and `LightTree::suits`, render/src/tracer/light/tree/). This
script measures both choices on scenes that differ in the count and the spread of their lights:

- `lamps-N`: the bundled `many-lights` scene with a grid of G × G lamps instead of 16 × 16
  (N = 2G² triangles, the same 0.75 m pitch, room and occluders; even G only, so the occluders
  stay between lamps);
- `sphere-N`: the Cornell box lit by an emissive UV sphere of N triangles (6 cm radius, 15 cm
  below the ceiling, the box light's power) instead of its quad: one compact light whose
  facets face every way;
- `panel-N`: the Cornell box with its own light quad cut into N triangles: one flat light;
- the bundled scenes with 4–24 emissive triangles (`textured`, `furnace`, `emitters-only`).

Each scene renders twice per round with the same binary, `--light-sampler power` and
`--light-sampler tree` (the job setting that overrides the threshold):

    cargo build --release --bin tessera
    python3 docs/tools/light_tree_study.py [--tessera target/release/tessera] [--rounds 2]

Each scene renders at 256×256, 64 spp, with the independent sampler (whose per-pixel variance
gives an unbiased estimate of the image's relMSE, printed by `tessera render`), on all cores,
`--rounds` times per choice, alternated; the time is the fastest round, the relMSE the same
every round (same seed). The fourth column is the tree's relMSE·s over power's: below 1 the tree
reaches a given quality sooner. The last says what the default, `--light-sampler auto`, chooses
for the scene (the `light_tree` effect; below 32 emissive triangles, `LightTree::suits` judges
how the lights differ: render/src/tracer/light/tree/auto.rs).
"""
import argparse
import math
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "scenes"))
import generate as G  # noqa: E402


def cornell_sphere_light(segments: int, rings: int) -> dict:
    g = G.Gltf("Cornell box lit by an emissive sphere")
    mats = G.cornell_materials(g)
    for obj in G.cornell_box_objects():
        if obj["name"] != "light":
            g.node(obj["name"], mesh=g.flat_mesh(obj["name"], obj["triangles"], mats[obj["material"]]))
    radius = 0.06
    pos, nrm, idx = G.uv_sphere(radius, segments, rings)
    # The box light (130 × 105 mm, one-sided) and a sphere of radius r emit the same power at
    # radiance L and L · (0.130 · 0.105) / (4 r²).
    scale = (0.130 * 0.105) / (4.0 * radius ** 2)
    e, s = G.radiance_to_emissive(tuple(c * scale for c in G.CORNELL_MATERIALS["light"]["radiance"]))
    m = g.material(G.lambert("sphere_light", (0.78, 0.78, 0.78), e, s))
    g.node("sphere_light", translation=(0.278, 0.40, 0.28), mesh=g.mesh("sphere_light", pos, nrm, idx, m))
    c = G.CORNELL_CAMERA
    g.camera(c["name"], math.radians(c["yfov_deg"]), c["position"], rotation=c["rotation"])
    return g.finish()


def subdivide(tri, k: int) -> list:
    """The triangle cut into k² triangles of the same orientation."""
    a, b, c = tri
    at = lambda i, j: tuple(a[n] + (b[n] - a[n]) * i / k + (c[n] - a[n]) * j / k for n in range(3))
    out = []
    for i in range(k):
        for j in range(k - i):
            out.append((at(i, j), at(i + 1, j), at(i, j + 1)))
            if i + j < k - 1:
                out.append((at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)))
    return out


def cornell_panel_light(k: int) -> dict:
    """The Cornell box with its light quad cut into 2k² triangles: one flat light."""
    g = G.Gltf("Cornell box, its light cut into %d triangles" % (2 * k * k))
    mats = G.cornell_materials(g)
    for obj in G.cornell_box_objects():
        tris = obj["triangles"] if obj["name"] != "light" else [t for tri in obj["triangles"] for t in subdivide(tri, k)]
        g.node(obj["name"], mesh=g.flat_mesh(obj["name"], tris, mats[obj["material"]]))
    c = G.CORNELL_CAMERA
    g.camera(c["name"], math.radians(c["yfov_deg"]), c["position"], rotation=c["rotation"])
    return g.finish()


def lamp_grid(grid: int) -> dict:
    saved = G.MANY_LIGHTS_GRID
    G.MANY_LIGHTS_GRID = grid
    try:
        return G.scene_many_lights()
    finally:
        G.MANY_LIGHTS_GRID = saved


def scenes(out: str) -> list[str]:
    paths = []
    for segments, rings in [(4, 3), (6, 3), (8, 3), (8, 5), (16, 5), (32, 9)]:
        path = os.path.join(out, "sphere-%d.gltf" % (segments * (2 * rings - 2)))
        G.write(cornell_sphere_light(segments, rings), path)
        paths.append(path)
    for k in [2, 3]:
        path = os.path.join(out, "panel-%d.gltf" % (2 * k * k))
        G.write(cornell_panel_light(k), path)
        paths.append(path)
    for grid in [2, 4, 6, 8, 10, 12, 16]:
        path = os.path.join(out, "lamps-%d.gltf" % (2 * grid * grid))
        G.write(lamp_grid(grid), path)
        paths.append(path)
    return paths + [os.path.join(ROOT, "scenes", s + ".gltf") for s in ("textured", "furnace", "emitters-only")]


def render(binary: str, light_sampler: str, scene: str, out: str) -> tuple[float, float]:
    cmd = [binary, "render", scene, "--spp", "64", "--sampler", "independent", "--light-sampler", light_sampler,
           "-o", os.path.join(out, "study.exr")]
    text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    m = re.search(r"in ([0-9.]+) s .*estimated relMSE ([0-9.e+-]+)", text)
    if not m:
        sys.exit("no time or relMSE in the output of %s:\n%s" % (" ".join(cmd), text))
    return float(m.group(1)), float(m.group(2))


def auto_chooses(binary: str, scene: str, out: str) -> str:
    """What `--light-sampler auto` does for the scene: the effects `tessera render` prints."""
    cmd = [binary, "render", scene, "--spp", "1", "--width", "8", "--height", "8", "-o", os.path.join(out, "auto.exr")]
    text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    return "tree" if re.search(r"effects: [^;]*light_tree", text) else "power"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tessera", default=os.path.join(ROOT, "target", "release", "tessera"), help="the tessera binary")
    ap.add_argument("--rounds", type=int, default=2)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as out:
        print("| scene | power: s, relMSE | tree: s, relMSE | tree relMSE·s ÷ power's | `auto` chooses |")
        print("|---|---:|---:|---:|---|")
        for scene in scenes(out):
            best = {}
            for _ in range(args.rounds):
                for name in ("power", "tree"):
                    t, e = render(args.tessera, name, scene, out)
                    best[name] = (min(t, best.get(name, (t, e))[0]), e)
            (tp, ep), (tt, et) = best["power"], best["tree"]
            name = os.path.basename(scene).removesuffix(".gltf")
            auto = auto_chooses(args.tessera, scene, out)
            print("| %s | %.2f, %.3e | %.2f, %.3e | **%.2f** | %s |" % (name, tp, ep, tt, et, (tt * et) / (tp * ep), auto), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
