#!/usr/bin/env python3
"""A bundled glTF scene as a Mitsuba 3 scene dict: the independent renderer's view of
the triangles, normals, materials and camera Tessera loads. Vertices are the glTF's float32
values; where a node transform moves them it is applied in double precision and rounded to
float32 once, so they agree with Tessera's to within that rounding.

What it translates (everything the bundled scenes it is used for need), and what it refuses:

* Meshes: triangle primitives (mode 4) with POSITION, optional NORMAL (smooth shading from the
  vertex normals; without them, or with `flat`, flat) and uint8/16/32 indices; node trees with translation,
  rotation, scale or matrix. Each primitive becomes a binary PLY in `tmpdir`.
* Materials:
  - matte: metallic 0, `KHR_materials_specular.specularFactor` 0, no textures, no transmission
    -> `diffuse` with the base colour;
  - smooth glass: `KHR_materials_transmission` 1 with roughness 0 and metallic 0 -> `dielectric`
    (`KHR_materials_ior`, default 1.5; a base colour other than white becomes its
    `specular_transmittance`). With `KHR_materials_volume` the mesh is a closed solid whose
    inside absorbs by Beer-Lambert: sigma_t = -ln(attenuationColor) / attenuationDistance with
    albedo 0, a `homogeneous` interior medium (the scene then needs `volpath`, which
    `build_scene_dict` chooses). Without it, thin glass (`thindielectric`).
  - pure metal: metallic 1, no textures, no transmission -> `gltf_metal` (gltf_metal.py: glTF's
    Schlick-GGX metal with height-correlated Smith shadowing, which no Mitsuba built-in has),
    F0 = the base colour, alpha = roughness squared;
  - Tessera's Phong (`TESSERA_materials_phong`: kd, ks, n) -> `tessera_phong` (tessera_phong.py);
  - emission: `emissiveFactor` x `KHR_materials_emissive_strength` -> a one-sided `area`
    emitter (two-sided materials are refused: Mitsuba's area lights emit on one side).
  Anything else (textures, rough glass, partly metallic surfaces, punctual lights, a thin lens) raises
  `Unsupported` naming the scene element, so a comparison is never made against a different
  scene.
* Camera: the first perspective camera node; glTF looks down -Z with +Y up, Mitsuba's
  `look_at` is given that eye, direction and up. `yfov` in radians becomes `fov` in degrees
  on the y axis.

The film is `hdrfilm` size x size with a box filter (one jittered ray per sample, as
Tessera), the integrator unbounded in depth.

Usage (a check that a scene translates; prints its shapes):
    python3 tests/reference/gltf_scene.py scenes/absorption.gltf
"""

from __future__ import annotations

import base64
import json
import math
import os
import sys

import numpy as np

sys.dont_write_bytecode = True
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import gltf_metal  # noqa: E402
import tessera_phong  # noqa: E402


class Unsupported(ValueError):
    """The scene uses something this translation would get wrong."""


_COMPONENTS = {5121: ("B", 1), 5123: ("H", 2), 5125: ("I", 4), 5126: ("f", 4)}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


class Gltf:
    def __init__(self, path: str):
        with open(path, encoding="utf-8") as fh:
            self.doc = json.load(fh)
        self.dir = os.path.dirname(os.path.abspath(path))
        self.buffers = [self._buffer(b) for b in self.doc.get("buffers", [])]

    def _buffer(self, b: dict) -> bytes:
        uri = b.get("uri")
        if uri is None:
            raise Unsupported("a GLB binary chunk (only .gltf with data: or file URIs)")
        if uri.startswith("data:"):
            return base64.b64decode(uri.split(",", 1)[1])
        with open(os.path.join(self.dir, uri), "rb") as fh:
            return fh.read()

    def accessor(self, index: int) -> np.ndarray:
        a = self.doc["accessors"][index]
        view = self.doc["bufferViews"][a["bufferView"]]
        if "sparse" in a:
            raise Unsupported(f"sparse accessor {index}")
        code, size = _COMPONENTS[a["componentType"]]
        width = _WIDTH[a["type"]]
        stride = view.get("byteStride", size * width)
        base = view.get("byteOffset", 0) + a.get("byteOffset", 0)
        rows = np.ndarray((a["count"], width), np.dtype("<" + code), buffer=self.buffers[view["buffer"]],
                          offset=base, strides=(stride, size))
        return rows.astype(np.float64 if code == "f" else np.int64)


def node_matrix(node: dict) -> np.ndarray:
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # glTF is column-major
    t = np.eye(4)
    t[:3, 3] = node.get("translation", [0.0, 0.0, 0.0])
    x, y, z, w = node.get("rotation", [0.0, 0.0, 0.0, 1.0])
    r = np.eye(4)
    r[:3, :3] = [
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ]
    s = np.diag(list(node.get("scale", [1.0, 1.0, 1.0])) + [1.0])
    return t @ r @ s


def walk(g: Gltf):
    """(node, world matrix) for every node of the default scene, depth first."""
    scene = g.doc["scenes"][g.doc.get("scene", 0)]
    stack = [(i, np.eye(4)) for i in reversed(scene["nodes"])]
    while stack:
        i, parent = stack.pop()
        node = g.doc["nodes"][i]
        m = parent @ node_matrix(node)
        yield node, m
        stack.extend((c, m) for c in reversed(node.get("children", [])))


def write_ply(path: str, pos: np.ndarray, nrm: np.ndarray | None, idx: np.ndarray) -> None:
    """Binary little-endian PLY; float32 positions (and normals), int32 triangles."""
    props = "property float x\nproperty float y\nproperty float z\n"
    if nrm is not None:
        props += "property float nx\nproperty float ny\nproperty float nz\n"
    header = (f"ply\nformat binary_little_endian 1.0\nelement vertex {len(pos)}\n{props}"
              f"element face {len(idx) // 3}\nproperty list uchar int vertex_indices\nend_header\n")
    verts = pos if nrm is None else np.hstack([pos, nrm])
    faces = np.zeros(len(idx) // 3, dtype=[("n", "u1"), ("v", "<i4", 3)])
    faces["n"], faces["v"] = 3, idx.reshape(-1, 3)
    with open(path, "wb") as fh:
        fh.write(header.encode("ascii") + verts.astype("<f4").tobytes() + faces.tobytes())


def bsdf_of(mat: dict, name: str) -> tuple[dict, dict | None]:
    """The Mitsuba BSDF of a glTF material and, for glass with a volume, its interior medium."""
    pbr = mat.get("pbrMetallicRoughness", {})
    ext = mat.get("extensions", {})
    base = pbr.get("baseColorFactor", [1.0, 1.0, 1.0, 1.0])[:3]
    if "baseColorTexture" in pbr or "normalTexture" in mat or "emissiveTexture" in mat:
        raise Unsupported(f"material {name!r}: textures")
    if "TESSERA_materials_phong" in ext:
        phong = ext["TESSERA_materials_phong"]
        return {"type": "tessera_phong", "kd": phong["kd"], "ks": phong["ks"], "n": float(phong["n"])}, None
    transmission = ext.get("KHR_materials_transmission", {}).get("transmissionFactor", 0.0)
    metallic = pbr.get("metallicFactor", 1.0)
    if metallic == 1.0 and transmission == 0.0 and "metallicRoughnessTexture" not in pbr:
        return {"type": "gltf_metal", "base_color": base, "alpha": pbr.get("roughnessFactor", 1.0) ** 2}, None
    if metallic != 0.0:
        raise Unsupported(f"material {name!r}: metallic {metallic} (only 0 and 1 translate)")
    if transmission == 0.0:
        if ext.get("KHR_materials_specular", {}).get("specularFactor", 1.0) != 0.0:
            raise Unsupported(f"material {name!r}: a specular layer (only matte surfaces translate)")
        return {"type": "diffuse", "reflectance": {"type": "rgb", "value": base}}, None
    if transmission != 1.0 or pbr.get("roughnessFactor", 1.0) != 0.0:
        raise Unsupported(f"material {name!r}: rough or partly transmissive glass")
    bsdf = {"int_ior": ext.get("KHR_materials_ior", {}).get("ior", 1.5), "ext_ior": 1.0}
    if base != [1.0, 1.0, 1.0]:
        bsdf["specular_transmittance"] = {"type": "rgb", "value": base}
    volume = ext.get("KHR_materials_volume")
    if volume is None:
        return {"type": "thindielectric", **bsdf}, None
    colour = volume.get("attenuationColor", [1.0, 1.0, 1.0])
    distance = volume.get("attenuationDistance", math.inf)
    sigma = [-math.log(c) / distance if c < 1.0 else 0.0 for c in colour]
    # Mitsuba reads an RGB as a reflectance in [0, 1]: the colour is sigma / max, `scale` the max.
    top = max(max(sigma), 1e-30)
    medium = {"type": "homogeneous", "albedo": {"type": "rgb", "value": [0.0, 0.0, 0.0]},
              "sigma_t": {"type": "rgb", "value": [c / top for c in sigma]}, "scale": top}
    return {"type": "dielectric", **bsdf}, medium


def emitter_of(mat: dict, name: str) -> dict | None:
    factor = mat.get("emissiveFactor", [0.0, 0.0, 0.0])
    strength = mat.get("extensions", {}).get("KHR_materials_emissive_strength", {}).get("emissiveStrength", 1.0)
    radiance = [c * strength for c in factor]
    if max(radiance) == 0.0:
        return None
    if mat.get("doubleSided", False):
        raise Unsupported(f"material {name!r}: a two-sided emitter")
    return {"type": "area", "radiance": {"type": "rgb", "value": radiance}}


def shapes(g: Gltf, tmpdir: str, flat: bool) -> dict:
    out: dict = {}
    for node, m in walk(g):
        if "mesh" not in node:
            continue
        mesh = g.doc["meshes"][node["mesh"]]
        normal_m = np.linalg.inv(m[:3, :3]).T
        for k, prim in enumerate(mesh["primitives"]):
            if prim.get("mode", 4) != 4:
                raise Unsupported(f"mesh {mesh.get('name')!r}: primitive mode {prim.get('mode')}")
            attrs = prim["attributes"]
            pos = g.accessor(attrs["POSITION"]) @ m[:3, :3].T + m[:3, 3]
            nrm = None
            if "NORMAL" in attrs and not flat:
                nrm = g.accessor(attrs["NORMAL"]) @ normal_m.T
                nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
            idx = g.accessor(prim["indices"]).ravel() if "indices" in prim else np.arange(len(pos))
            mat_index = prim.get("material")
            if mat_index is None:
                raise Unsupported(f"mesh {mesh.get('name')!r}: no material")
            mat = g.doc["materials"][mat_index]
            name = mat.get("name", str(mat_index))
            bsdf, medium = bsdf_of(mat, name)
            key = f"{node.get('name', 'node')}_{k}".replace(".", "_")  # Mitsuba reserves "."
            path = os.path.join(tmpdir, key + ".ply")
            write_ply(path, pos, nrm, idx)
            shape = {"type": "ply", "filename": path, "bsdf": bsdf, "face_normals": nrm is None}
            if medium is not None:
                shape["interior"] = medium
            emitter = emitter_of(mat, name)
            if emitter is not None:
                shape["emitter"] = emitter
            out[key] = shape
    return out


def sensor(g: Gltf, mi, size: int) -> dict:
    for node, m in walk(g):
        if "camera" not in node:
            continue
        cam = g.doc["cameras"][node["camera"]]
        if cam.get("type") != "perspective":
            raise Unsupported(f"camera {cam.get('name')!r}: {cam.get('type')}")
        if cam.get("extras", {}).get("aperture_radius", 0.0) > 0.0:
            raise Unsupported(f"camera {cam.get('name')!r}: a thin lens")
        eye = m[:3, 3]
        forward = m[:3, :3] @ [0.0, 0.0, -1.0]
        up = m[:3, :3] @ [0.0, 1.0, 0.0]
        return {
            "type": "perspective",
            "fov_axis": "y",
            "fov": math.degrees(cam["perspective"]["yfov"]),
            "to_world": mi.ScalarTransform4f().look_at(
                origin=eye.tolist(), target=(eye + forward).tolist(), up=up.tolist()),
            "sampler": {"type": "independent", "sample_count": 1},
            "film": {"type": "hdrfilm", "width": size, "height": size, "rfilter": {"type": "box"},
                     "pixel_format": "rgb", "component_format": "float32"},
        }
    raise Unsupported("no camera")


def build_scene_dict(mi, gltf_path: str, tmpdir: str, size: int, flat: bool = False) -> dict:
    """The scene of `gltf_path` for `mi.load_dict`; PLY files are written to `tmpdir`.

    `flat` ignores vertex normals (every face shaded by its own normal, as glTF prescribes for
    a mesh without NORMAL). Renderers differ by convention in how an interpolated normal that
    disagrees with the face bends a refraction, so an independent check of glass is made on
    flat-shaded meshes, where there is one right answer."""
    g = Gltf(gltf_path)
    if g.doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights"):
        raise Unsupported("punctual lights")
    body = shapes(g, tmpdir, flat)
    kinds = {s["bsdf"]["type"] for s in body.values()}
    if "gltf_metal" in kinds:
        gltf_metal.register()
    if "tessera_phong" in kinds:
        tessera_phong.register()
    media = any("interior" in s for s in body.values())
    integrator = {"type": "volpath" if media else "path", "max_depth": -1}
    return {"type": "scene", "integrator": integrator, "sensor": sensor(g, mi, size), **body}


def scene_path(name: str) -> str:
    """A bundled scene's name (`absorption`) or a path to a .gltf."""
    if name.endswith(".gltf"):
        return name
    here = os.path.dirname(os.path.abspath(__file__))
    return os.path.normpath(os.path.join(here, "..", "..", "scenes", name + ".gltf"))


def main() -> int:
    import tempfile

    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    with tempfile.TemporaryDirectory() as tmp:
        try:
            desc = build_scene_dict(mi, scene_path(sys.argv[1]), tmp, 64)
        except Unsupported as e:
            print(f"cannot translate {sys.argv[1]}: {e}", file=sys.stderr)
            return 2
        print(f"integrator {desc['integrator']['type']}")
        for key, shape in desc.items():
            if isinstance(shape, dict) and shape.get("type") == "ply":
                extra = " + interior medium" if "interior" in shape else ""
                extra += " + area emitter" if "emitter" in shape else ""
                print(f"{key}: {shape['bsdf']['type']}{extra}")
        mi.load_dict(desc)
    return 0


if __name__ == "__main__":
    sys.exit(main())
