#!/usr/bin/env python3
"""Generate Tessera's bundled glTF 2.0 test scenes.

Python 3.11, standard library only.  Run from anywhere:

    python3 scenes/generate.py            # writes scenes/*.gltf next to this file
    python3 scenes/generate.py OUT_DIR    # writes them into OUT_DIR

Every file is a self-contained ``.gltf`` (JSON, one buffer embedded as a
base64 data URI).  Conventions (see README.md):

* units are metres, +Y is up, right-handed (glTF);
* flat-shaded geometry: every triangle has its own three vertices and its own
  NORMAL (the geometric normal), so shading normal == geometric normal;
  spheres share vertices and carry smooth (analytic) normals;
* all triangles are counter-clockwise seen from the side their normal points
  to; materials are single-sided unless stated;
* Lambert = pbrMetallicRoughness(metallic 0, roughness 1) +
  KHR_materials_specular.specularFactor 0;
* emitted radiance = emissiveFactor x KHR_materials_emissive_strength, emitted
  only toward the front (normal) side.

The Cornell-box geometry lives in module-level data (``CORNELL_QUADS_MM``,
``cornell_box_objects()``, ``CORNELL_MATERIALS``, ``CORNELL_CAMERA``).
Mitsuba 3's copies of the scenes (``tests/reference/``) are read from the
written glTF by ``tests/reference/gltf_scene.py``, so they see the same
float32 triangles (to within one rounding where a node transform moves them).
"""

from __future__ import annotations

import base64
import json
import math
import os
import struct
import sys

Vec3 = tuple[float, float, float]
Tri = tuple[Vec3, Vec3, Vec3]

# --------------------------------------------------------------------------
# small vector helpers
# --------------------------------------------------------------------------


def vsub(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def vadd(a: Vec3, b: Vec3) -> Vec3:
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def vscale(a: Vec3, s: float) -> Vec3:
    return (a[0] * s, a[1] * s, a[2] * s)


def vdot(a: Vec3, b: Vec3) -> float:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def vcross(a: Vec3, b: Vec3) -> Vec3:
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def vnorm(a: Vec3) -> Vec3:
    length = math.sqrt(vdot(a, a))
    if length == 0.0:
        raise ValueError("zero-length vector")
    return (a[0] / length, a[1] / length, a[2] / length)


def tri_normal(t: Tri) -> Vec3:
    """Unit geometric normal of a counter-clockwise triangle (right-hand rule)."""
    return vnorm(vcross(vsub(t[1], t[0]), vsub(t[2], t[0])))


def tri_centroid(t: Tri) -> Vec3:
    return vscale(vadd(vadd(t[0], t[1]), t[2]), 1.0 / 3.0)


def quad_to_tris(q: list[Vec3]) -> list[Tri]:
    """Split quad v0 v1 v2 v3 along the v0-v2 diagonal: (v0,v1,v2), (v0,v2,v3)."""
    return [(q[0], q[1], q[2]), (q[0], q[2], q[3])]


def orient(t: Tri, want: Vec3) -> Tri:
    """Return t with its winding flipped if its normal points away from `want`."""
    if vdot(tri_normal(t), want) < 0.0:
        return (t[0], t[2], t[1])
    return t


def look_at_quaternion(eye: Vec3, target: Vec3, up: Vec3 = (0.0, 1.0, 0.0)) -> list[float]:
    """Unit quaternion [x, y, z, w] rotating a glTF camera/light (which looks
    down its local -Z with local +Y up) so it looks from `eye` at `target`."""
    f = vnorm(vsub(target, eye))
    r = vnorm(vcross(f, up))  # local +X (image right)
    u = vcross(r, f)  # local +Y (image up)
    b = vscale(f, -1.0)  # local +Z
    # rotation matrix with columns r, u, b
    m00, m01, m02 = r[0], u[0], b[0]
    m10, m11, m12 = r[1], u[1], b[1]
    m20, m21, m22 = r[2], u[2], b[2]
    tr = m00 + m11 + m22
    if tr > 0.0:
        s = math.sqrt(tr + 1.0) * 2.0
        q = [(m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s, 0.25 * s]
    elif m00 > m11 and m00 > m22:
        s = math.sqrt(1.0 + m00 - m11 - m22) * 2.0
        q = [0.25 * s, (m01 + m10) / s, (m02 + m20) / s, (m21 - m12) / s]
    elif m11 > m22:
        s = math.sqrt(1.0 + m11 - m00 - m22) * 2.0
        q = [(m01 + m10) / s, 0.25 * s, (m12 + m21) / s, (m02 - m20) / s]
    else:
        s = math.sqrt(1.0 + m22 - m00 - m11) * 2.0
        q = [(m02 + m20) / s, (m12 + m21) / s, 0.25 * s, (m10 - m01) / s]
    if q[3] < 0.0:
        q = [-c for c in q]
    n = math.sqrt(sum(c * c for c in q))
    q = [c / n for c in q]
    # clean up -0.0 / 1e-17 noise so simple cases come out exact
    return [0.0 if abs(c) < 1e-12 else round(c, 15) for c in q]


def quat_axis_angle(axis: Vec3, angle: float) -> list[float]:
    a = vnorm(axis)
    s = math.sin(angle / 2.0)
    q = [a[0] * s, a[1] * s, a[2] * s, math.cos(angle / 2.0)]
    return [0.0 if abs(c) < 1e-12 else round(c, 15) for c in q]


def f32(x: float) -> float:
    """Round a Python float to the nearest float32 (as stored in the buffer)."""
    return struct.unpack("<f", struct.pack("<f", x))[0]


# --------------------------------------------------------------------------
# Cornell box data (Cornell Program of Computer Graphics, "Cornell Box Data",
# https://www.graphics.cornell.edu/online/box/data.html), millimetres.
# Left/right are as seen from the camera: the red wall is at x ~ 550 (image
# left), the green wall at x = 0 (image right).
# --------------------------------------------------------------------------

CORNELL_LIGHT_Y_MM = 548.7  # 0.1 mm below the ceiling (548.8)

# (name, material, four corners in mm, orientation rule)
#   ("toward", p): normal points toward point p  (room interior for walls)
#   ("away", p):   normal points away from p      (block centre for blocks)
#   ("dir", v):    normal along v
_ROOM_CENTRE = (278.0, 274.4, 279.6)
_SHORT_CENTRE = (186.0, 82.5, 168.5)
_TALL_CENTRE = (368.5, 165.0, 351.25)

CORNELL_QUADS_MM: list[tuple[str, str, list[Vec3], tuple[str, Vec3]]] = [
    ("floor", "white",
     [(552.8, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 559.2), (549.6, 0.0, 559.2)],
     ("toward", _ROOM_CENTRE)),
    ("ceiling", "white",
     [(556.0, 548.8, 0.0), (556.0, 548.8, 559.2), (0.0, 548.8, 559.2), (0.0, 548.8, 0.0)],
     ("toward", _ROOM_CENTRE)),
    ("back_wall", "white",
     [(549.6, 0.0, 559.2), (0.0, 0.0, 559.2), (0.0, 548.8, 559.2), (556.0, 548.8, 559.2)],
     ("toward", _ROOM_CENTRE)),
    ("right_wall_green", "green",
     [(0.0, 0.0, 559.2), (0.0, 0.0, 0.0), (0.0, 548.8, 0.0), (0.0, 548.8, 559.2)],
     ("toward", _ROOM_CENTRE)),
    ("left_wall_red", "red",
     [(552.8, 0.0, 0.0), (549.6, 0.0, 559.2), (556.0, 548.8, 559.2), (556.0, 548.8, 0.0)],
     ("toward", _ROOM_CENTRE)),
    # short block: top + 4 sides
    ("short_block", "white",
     [(130.0, 165.0, 65.0), (82.0, 165.0, 225.0), (240.0, 165.0, 272.0), (290.0, 165.0, 114.0)],
     ("away", _SHORT_CENTRE)),
    ("short_block", "white",
     [(290.0, 0.0, 114.0), (290.0, 165.0, 114.0), (240.0, 165.0, 272.0), (240.0, 0.0, 272.0)],
     ("away", _SHORT_CENTRE)),
    ("short_block", "white",
     [(130.0, 0.0, 65.0), (130.0, 165.0, 65.0), (290.0, 165.0, 114.0), (290.0, 0.0, 114.0)],
     ("away", _SHORT_CENTRE)),
    ("short_block", "white",
     [(82.0, 0.0, 225.0), (82.0, 165.0, 225.0), (130.0, 165.0, 65.0), (130.0, 0.0, 65.0)],
     ("away", _SHORT_CENTRE)),
    ("short_block", "white",
     [(240.0, 0.0, 272.0), (240.0, 165.0, 272.0), (82.0, 165.0, 225.0), (82.0, 0.0, 225.0)],
     ("away", _SHORT_CENTRE)),
    # tall block: top + 4 sides
    ("tall_block", "white",
     [(423.0, 330.0, 247.0), (265.0, 330.0, 296.0), (314.0, 330.0, 456.0), (472.0, 330.0, 406.0)],
     ("away", _TALL_CENTRE)),
    ("tall_block", "white",
     [(423.0, 0.0, 247.0), (423.0, 330.0, 247.0), (472.0, 330.0, 406.0), (472.0, 0.0, 406.0)],
     ("away", _TALL_CENTRE)),
    ("tall_block", "white",
     [(472.0, 0.0, 406.0), (472.0, 330.0, 406.0), (314.0, 330.0, 456.0), (314.0, 0.0, 456.0)],
     ("away", _TALL_CENTRE)),
    ("tall_block", "white",
     [(314.0, 0.0, 456.0), (314.0, 330.0, 456.0), (265.0, 330.0, 296.0), (265.0, 0.0, 296.0)],
     ("away", _TALL_CENTRE)),
    ("tall_block", "white",
     [(265.0, 0.0, 296.0), (265.0, 330.0, 296.0), (423.0, 330.0, 247.0), (423.0, 0.0, 247.0)],
     ("away", _TALL_CENTRE)),
    # area light, facing down
    ("light", "light",
     [(343.0, CORNELL_LIGHT_Y_MM, 227.0), (343.0, CORNELL_LIGHT_Y_MM, 332.0),
      (213.0, CORNELL_LIGHT_Y_MM, 332.0), (213.0, CORNELL_LIGHT_Y_MM, 227.0)],
     ("dir", (0.0, -1.0, 0.0))),
]

# Mitsuba 3 "cbox" RGB albedos; light: radiance (17, 12, 4) W m^-2 sr^-1.
CORNELL_MATERIALS: dict[str, dict] = {
    "white": {"albedo": (0.885809, 0.698859, 0.666422), "radiance": None},
    "red": {"albedo": (0.570068, 0.0430135, 0.0443706), "radiance": None},
    "green": {"albedo": (0.105421, 0.37798, 0.076425), "radiance": None},
    "light": {"albedo": (0.78, 0.78, 0.78), "radiance": (17.0, 12.0, 4.0)},
}

CORNELL_CAMERA = {
    "name": "Camera",
    "position": (0.278, 0.273, -0.800),
    "target": (0.278, 0.273, 0.0),
    "up": (0.0, 1.0, 0.0),
    "yfov_deg": 39.3077,  # 2 atan(12.5 mm / 35 mm)
    "rotation": [0.0, 1.0, 0.0, 0.0],  # 180 deg about +Y: local -Z -> world +Z
}


def cornell_box_objects() -> list[dict]:
    """The Cornell box in metres: a list of {"name", "material", "triangles"},
    one entry per object (walls, blocks, light), triangles CCW seen from the
    side their normal faces (walls: into the room; blocks: outward; light:
    down).  Order of objects and triangles is the order written to the glTF."""
    objects: dict[str, dict] = {}
    for name, material, quad_mm, (rule, ref) in CORNELL_QUADS_MM:
        quad = [(x / 1000.0, y / 1000.0, z / 1000.0) for (x, y, z) in quad_mm]
        ref_m = vscale(ref, 1.0 / 1000.0)
        obj = objects.setdefault(name, {"name": name, "material": material, "triangles": []})
        assert obj["material"] == material
        for t in quad_to_tris(quad):
            c = tri_centroid(t)
            if rule == "toward":
                want = vsub(ref_m, c)
            elif rule == "away":
                want = vsub(c, ref_m)
            else:
                want = ref
            t = orient(t, want)
            assert vdot(tri_normal(t), vnorm(want)) > 0.5, (name, t)
            obj["triangles"].append(t)
    return list(objects.values())


# --------------------------------------------------------------------------
# Generic geometry
# --------------------------------------------------------------------------


def box_triangles(size: Vec3) -> list[Tri]:
    """Axis-aligned box centred at the origin, 12 triangles, outward normals."""
    hx, hy, hz = size[0] / 2.0, size[1] / 2.0, size[2] / 2.0
    faces = [  # (normal, four corners CCW seen from outside)
        ((1, 0, 0), [(hx, -hy, hz), (hx, -hy, -hz), (hx, hy, -hz), (hx, hy, hz)]),
        ((-1, 0, 0), [(-hx, -hy, -hz), (-hx, -hy, hz), (-hx, hy, hz), (-hx, hy, -hz)]),
        ((0, 1, 0), [(-hx, hy, hz), (hx, hy, hz), (hx, hy, -hz), (-hx, hy, -hz)]),
        ((0, -1, 0), [(-hx, -hy, -hz), (hx, -hy, -hz), (hx, -hy, hz), (-hx, -hy, hz)]),
        ((0, 0, 1), [(-hx, -hy, hz), (hx, -hy, hz), (hx, hy, hz), (-hx, hy, hz)]),
        ((0, 0, -1), [(hx, -hy, -hz), (-hx, -hy, -hz), (-hx, hy, -hz), (hx, hy, -hz)]),
    ]
    tris = []
    for n, q in faces:
        for t in quad_to_tris([tuple(map(float, p)) for p in q]):
            assert vdot(tri_normal(t), n) > 0.999
            tris.append(t)
    return tris


def flip(tris: list[Tri]) -> list[Tri]:
    return [(t[0], t[2], t[1]) for t in tris]


def rect_y(x0: float, x1: float, z0: float, z1: float, y: float, facing_up: bool) -> list[Tri]:
    """Horizontal rectangle at height y, normal +Y (facing_up) or -Y."""
    q = [(x0, y, z0), (x0, y, z1), (x1, y, z1), (x1, y, z0)]  # CCW seen from +Y
    tris = quad_to_tris(q)
    want = (0.0, 1.0, 0.0) if facing_up else (0.0, -1.0, 0.0)
    tris = [orient(t, want) for t in tris]
    for t in tris:
        assert vdot(tri_normal(t), want) > 0.999
    return tris


def uv_sphere(radius: float, segments: int = 32, rings: int = 16):
    """Smooth UV sphere centred at the origin: (positions, normals, indices).
    Seam vertices are duplicated; pole rows use one triangle per segment (no
    degenerate triangles).  Outward normals, CCW seen from outside."""
    positions: list[Vec3] = []
    normals: list[Vec3] = []
    for i in range(rings + 1):
        theta = math.pi * i / rings  # 0 at +Y pole
        st, ct = math.sin(theta), math.cos(theta)
        if i == 0:
            st, ct = 0.0, 1.0
        elif i == rings:
            st, ct = 0.0, -1.0
        for j in range(segments + 1):
            phi = 2.0 * math.pi * (j % segments) / segments
            n = (st * math.sin(phi), ct, st * math.cos(phi))
            normals.append(n)
            positions.append(vscale(n, radius))
    idx: list[int] = []

    def v(i: int, j: int) -> int:
        return i * (segments + 1) + j

    for i in range(rings):
        for j in range(segments):
            a, b = v(i, j), v(i, j + 1)
            c, d = v(i + 1, j), v(i + 1, j + 1)
            # CCW seen from outside (checked below)
            if i != 0:
                idx += [a, c, b]
            if i != rings - 1:
                idx += [b, c, d]
    # verify orientation of every triangle against the outward direction
    for k in range(0, len(idx), 3):
        t = (positions[idx[k]], positions[idx[k + 1]], positions[idx[k + 2]])
        assert vdot(tri_normal(t), tri_centroid(t)) > 0.0
    return positions, normals, idx


# --------------------------------------------------------------------------
# glTF writer
# --------------------------------------------------------------------------

FLOAT = 5126
UNSIGNED_INT = 5125
ARRAY_BUFFER = 34962
ELEMENT_ARRAY_BUFFER = 34963


class Gltf:
    def __init__(self, generator_note: str):
        self.buf = bytearray()
        self.doc: dict = {
            "asset": {"version": "2.0", "generator": "Tessera scenes/generate.py",
                      "copyright": "CC0 / public domain test data"},
            "scene": 0,
            "scenes": [{"name": generator_note, "nodes": []}],
            "nodes": [],
            "meshes": [],
            "materials": [],
            "accessors": [],
            "bufferViews": [],
            "buffers": [],
        }
        self.lights: list[dict] = []

    # ---- raw data ------------------------------------------------------
    def _view(self, data: bytes, target: int | None, stride: int | None = None) -> int:
        while len(self.buf) % 4:
            self.buf.append(0)
        view = {"buffer": 0, "byteOffset": len(self.buf), "byteLength": len(data)}
        if stride is not None:
            view["byteStride"] = stride
        if target is not None:
            view["target"] = target
        self.buf += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def vec3_accessor(self, vecs: list[Vec3], with_bounds: bool) -> int:
        flat = [f32(c) for v in vecs for c in v]
        data = struct.pack("<%df" % len(flat), *flat)
        view = self._view(data, ARRAY_BUFFER)
        acc = {"bufferView": view, "byteOffset": 0, "componentType": FLOAT,
               "count": len(vecs), "type": "VEC3"}
        if with_bounds:
            acc["min"] = [min(flat[k::3]) for k in range(3)]
            acc["max"] = [max(flat[k::3]) for k in range(3)]
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def index_accessor(self, idx: list[int]) -> int:
        data = struct.pack("<%dI" % len(idx), *idx)
        view = self._view(data, ELEMENT_ARRAY_BUFFER)
        self.doc["accessors"].append({"bufferView": view, "byteOffset": 0,
                                      "componentType": UNSIGNED_INT, "count": len(idx),
                                      "type": "SCALAR", "min": [min(idx)], "max": [max(idx)]})
        return len(self.doc["accessors"]) - 1

    # ---- materials -----------------------------------------------------
    def material(self, mat: dict) -> int:
        self.doc["materials"].append(mat)
        return len(self.doc["materials"]) - 1

    # ---- meshes --------------------------------------------------------
    def flat_mesh(self, name: str, tris: list[Tri], material: int) -> int:
        """Each triangle gets its own 3 vertices and its geometric normal."""
        pos: list[Vec3] = []
        nrm: list[Vec3] = []
        for t in tris:
            n = tri_normal(t)
            pos += list(t)
            nrm += [n, n, n]
        return self.mesh(name, pos, nrm, list(range(len(pos))), material)

    def mesh(self, name: str, pos: list[Vec3], nrm: list[Vec3], idx: list[int], material: int) -> int:
        a_pos = self.vec3_accessor(pos, with_bounds=True)
        a_nrm = self.vec3_accessor(nrm, with_bounds=False)
        a_idx = self.index_accessor(idx)
        return self.mesh_from_accessors(name, a_pos, a_nrm, a_idx, material)

    def mesh_from_accessors(self, name: str, a_pos: int, a_nrm: int, a_idx: int, material: int) -> int:
        self.doc["meshes"].append({"name": name, "primitives": [{
            "attributes": {"POSITION": a_pos, "NORMAL": a_nrm},
            "indices": a_idx, "material": material, "mode": 4}]})
        return len(self.doc["meshes"]) - 1

    # ---- nodes ---------------------------------------------------------
    def node(self, name: str, translation: Vec3 | None = None, rotation: list[float] | None = None,
             **extra) -> int:
        n: dict = {"name": name}
        if translation is not None and any(translation):
            n["translation"] = [float(c) for c in translation]
        if rotation is not None and rotation != [0.0, 0.0, 0.0, 1.0]:
            n["rotation"] = [float(c) for c in rotation]
        n.update(extra)
        self.doc["nodes"].append(n)
        idx = len(self.doc["nodes"]) - 1
        self.doc["scenes"][0]["nodes"].append(idx)
        return idx

    def camera(self, name: str, yfov: float, eye: Vec3, target: Vec3 | None = None,
               rotation: list[float] | None = None, znear: float = 0.01) -> int:
        cams = self.doc.setdefault("cameras", [])
        cams.append({"name": name, "type": "perspective",
                     "perspective": {"yfov": yfov, "znear": znear}})
        if rotation is None:
            rotation = look_at_quaternion(eye, target) if target is not None else [0.0, 0.0, 0.0, 1.0]
        return self.node(name, translation=eye, rotation=rotation, camera=len(cams) - 1)

    def light(self, node_name: str, light: dict, eye: Vec3, target: Vec3 | None = None) -> int:
        self.lights.append(light)
        rot = look_at_quaternion(eye, target) if target is not None else None
        return self.node(node_name, translation=eye, rotation=rot,
                         extensions={"KHR_lights_punctual": {"light": len(self.lights) - 1}})

    # ---- output --------------------------------------------------------
    def finish(self) -> dict:
        while len(self.buf) % 4:
            self.buf.append(0)
        doc = self.doc
        doc["buffers"] = [{"byteLength": len(self.buf),
                           "uri": "data:application/octet-stream;base64,"
                                  + base64.b64encode(bytes(self.buf)).decode("ascii")}]
        if self.lights:
            doc.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": self.lights}
        used: set[str] = set()

        def walk(o):
            if isinstance(o, dict):
                for k, v in o.items():
                    if k == "extensions" and isinstance(v, dict):
                        used.update(v.keys())
                    walk(v)
            elif isinstance(o, list):
                for v in o:
                    walk(v)

        walk(doc)
        if used:
            doc["extensionsUsed"] = sorted(used)
        for key in ("materials", "meshes", "accessors", "bufferViews"):
            if not doc[key]:
                del doc[key]
        return doc


def lambert(name: str, rgb: Vec3, emissive: Vec3 | None = None, strength: float | None = None) -> dict:
    m = {
        "name": name,
        "pbrMetallicRoughness": {"baseColorFactor": [float(c) for c in rgb] + [1.0],
                                 "metallicFactor": 0.0, "roughnessFactor": 1.0},
        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}},
    }
    add_emission(m, emissive, strength)
    return m


def add_emission(m: dict, emissive: Vec3 | None, strength: float | None) -> None:
    if emissive is None:
        return
    assert all(0.0 <= c <= 1.0 for c in emissive)
    m["emissiveFactor"] = [float(c) for c in emissive]
    if strength is not None and strength != 1.0:
        m.setdefault("extensions", {})["KHR_materials_emissive_strength"] = {
            "emissiveStrength": float(strength)}


def radiance_to_emissive(radiance: Vec3) -> tuple[Vec3, float]:
    """Split a radiance into (emissiveFactor with max channel 1, strength)."""
    s = max(radiance)
    return (tuple(c / s for c in radiance), s)


def write(doc: dict, path: str) -> None:
    with open(path, "w", newline="\n") as fh:
        json.dump(doc, fh, indent=1)
        fh.write("\n")


# --------------------------------------------------------------------------
# Scenes
# --------------------------------------------------------------------------


def cornell_materials(g: "Gltf", light_scale: float = 1.0) -> dict:
    """The Cornell box's materials (the light's radiance times `light_scale`), by name."""
    mats = {}
    for name, m in CORNELL_MATERIALS.items():
        if m["radiance"] is None:
            mats[name] = g.material(lambert(name, m["albedo"]))
        else:
            e, s = radiance_to_emissive(tuple(c * light_scale for c in m["radiance"]))
            mats[name] = g.material(lambert(name, m["albedo"], e, s))
    return mats


def scene_cornell_box() -> dict:
    g = Gltf("Cornell box")
    mats = cornell_materials(g)
    for obj in cornell_box_objects():
        mesh = g.flat_mesh(obj["name"], obj["triangles"], mats[obj["material"]])
        g.node(obj["name"], mesh=mesh)
    c = CORNELL_CAMERA
    assert look_at_quaternion(c["position"], c["target"], c["up"]) == c["rotation"]
    g.camera(c["name"], math.radians(c["yfov_deg"]), c["position"], rotation=c["rotation"])
    return g.finish()


# The small-light Cornell box: the same room with the light shrunk to 3 cm x 3 cm at the
# centre of the original one; its radiance grows by the area ratio so the light's power (and
# the image's brightness) stays the same. Light sampling finds it; BSDF sampling rarely does.
CORNELL_SMALL_LIGHT_HALF_MM = 15.0


def scene_cornell_small_light() -> dict:
    g = Gltf("Cornell box with a 3 cm light")
    big = [(343.0, 227.0), (213.0, 332.0)]  # (x, z) corners of the original light, mm
    cx, cz = (big[0][0] + big[1][0]) / 2.0, (big[0][1] + big[1][1]) / 2.0
    h = CORNELL_SMALL_LIGHT_HALF_MM
    area_ratio = (130.0 * 105.0) / (2.0 * h) ** 2
    mats = cornell_materials(g, area_ratio)
    for obj in cornell_box_objects():
        tris = obj["triangles"]
        if obj["name"] == "light":
            y = CORNELL_LIGHT_Y_MM / 1000.0
            tris = rect_y((cx - h) / 1000.0, (cx + h) / 1000.0, (cz - h) / 1000.0, (cz + h) / 1000.0, y, False)
        g.node(obj["name"], mesh=g.flat_mesh(obj["name"], tris, mats[obj["material"]]))
    c = CORNELL_CAMERA
    g.camera(c["name"], math.radians(c["yfov_deg"]), c["position"], rotation=c["rotation"])
    return g.finish()


def scene_furnace() -> dict:
    g = Gltf("White furnace")
    m = g.material(lambert("furnace_grey", (0.8, 0.8, 0.8), emissive=(0.1, 0.1, 0.1)))
    tris = flip(box_triangles((2.0, 2.0, 2.0)))  # inward-facing
    for t in tris:
        assert vdot(tri_normal(t), tri_centroid(t)) < 0.0
    g.node("furnace_box", mesh=g.flat_mesh("furnace_box", tris, m))
    g.camera("Camera", 1.0, (0.0, 0.0, 0.0))
    return g.finish()


def _sphere_accessors(g: Gltf, radius: float) -> tuple[int, int, int]:
    pos, nrm, idx = uv_sphere(radius, 32, 16)
    return (g.vec3_accessor(pos, with_bounds=True), g.vec3_accessor(nrm, with_bounds=False),
            g.index_accessor(idx))


def scene_glossy() -> dict:
    g = Gltf("GGX metal spheres")
    _lit_floor(g, light_rect=(-1.0, 1.0, -0.05, 0.45))
    sphere = _sphere_accessors(g, 0.25)
    for k, r in enumerate((0.05, 0.2, 0.5, 1.0)):
        name = "gold_roughness_%g" % r
        m = g.material({"name": name, "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 0.766, 0.336, 1.0], "metallicFactor": 1.0, "roughnessFactor": r}})
        mesh = g.mesh_from_accessors(name, *sphere, m)
        g.node(name, translation=(-0.825 + 0.55 * k, 0.25, 0.0), mesh=mesh)
    g.camera("Camera", 0.75, (0.0, 1.2, 3.0), (0.0, 0.25, 0.0))
    return g.finish()


def phong_fallback_roughness(n: float) -> float:
    """Beckmann-equivalent alpha = sqrt(2/(n+2)); glTF roughness = sqrt(alpha)."""
    return math.sqrt(math.sqrt(2.0 / (n + 2.0)))


def scene_phong() -> dict:
    g = Gltf("Phong spheres")
    _lit_floor(g, light_rect=(-0.8, 0.8, -0.05, 0.45))
    sphere = _sphere_accessors(g, 0.25)
    kd = [0.5, 0.45, 0.4]
    ks = [0.5, 0.5, 0.5]
    for k, n in enumerate((10, 100, 1000)):
        assert all(a + b <= 1.0 for a, b in zip(kd, ks))
        name = "phong_n%d" % n
        m = g.material({
            "name": name,
            "pbrMetallicRoughness": {"baseColorFactor": kd + [1.0], "metallicFactor": 0.0,
                                     "roughnessFactor": round(phong_fallback_roughness(n), 4)},
            "extensions": {"TESSERA_materials_phong": {"kd": kd, "ks": ks, "n": float(n)}},
        })
        mesh = g.mesh_from_accessors(name, *sphere, m)
        g.node(name, translation=(-0.6 + 0.6 * k, 0.25, 0.0), mesh=mesh)
    g.camera("Camera", 0.6, (0.0, 1.0, 2.8), (0.0, 0.25, 0.0))
    return g.finish()


def scene_punctual() -> dict:
    g = Gltf("Punctual lights")
    floor_m = g.material(lambert("floor_grey", (0.7, 0.7, 0.7)))
    box_m = g.material(lambert("box_red", (0.7, 0.3, 0.2)))
    sph_m = g.material(lambert("sphere_blue", (0.2, 0.3, 0.7)))
    g.node("floor", mesh=g.flat_mesh("floor", rect_y(-3.0, 3.0, -3.0, 3.0, 0.0, True), floor_m))
    g.node("box", translation=(-0.6, 0.25, 0.0),
           rotation=quat_axis_angle((0.0, 1.0, 0.0), math.radians(30.0)),
           mesh=g.flat_mesh("box", box_triangles((0.5, 0.5, 0.5)), box_m))
    pos, nrm, idx = uv_sphere(0.3, 32, 16)
    g.node("sphere", translation=(0.6, 0.3, 0.1), mesh=g.mesh("sphere", pos, nrm, idx, sph_m))
    g.light("point_light", {"name": "point_light", "type": "point",
                            "color": [1.0, 0.85, 0.7], "intensity": 4.0}, (-1.2, 1.4, 0.8))
    g.light("spot_light", {"name": "spot_light", "type": "spot", "color": [1.0, 1.0, 1.0],
                           "intensity": 15.0,
                           "spot": {"innerConeAngle": 0.25, "outerConeAngle": 0.4}},
            (1.2, 2.0, 0.8), (0.6, 0.3, 0.1))
    g.light("sun", {"name": "sun", "type": "directional", "color": [0.7, 0.8, 1.0],
                    "intensity": 0.5}, (0.0, 3.0, 0.0), (0.4, 2.0, -0.3))
    g.camera("Camera", 0.8, (0.0, 1.5, 3.0), (0.0, 0.3, 0.0))
    return g.finish()


def glass_material(name: str, roughness: float, volume: dict | None = None,
                   tint: Vec3 = (1.0, 1.0, 1.0)) -> dict:
    """KHR_materials_transmission glass (ior 1.5); thin-walled unless `volume` is given."""
    ext: dict = {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                 "KHR_materials_ior": {"ior": 1.5}}
    if volume is not None:
        ext["KHR_materials_volume"] = volume
    return {"name": name, "pbrMetallicRoughness": {"baseColorFactor": list(tint) + [1.0],
            "metallicFactor": 0.0, "roughnessFactor": roughness}, "extensions": ext}


def _lit_floor(g: Gltf, light_radiance: float = 10.0,
               light_rect: tuple[float, float, float, float] = (-0.8, 0.8, -0.6, 0.2)) -> None:
    """A grey floor and a rectangular area light 1.8 m above it, x0..x1 × z0..z1 of
    `light_rect` (shared by the effect scenes and the sphere rows of glossy and phong)."""
    floor_m = g.material(lambert("floor_grey", (0.5, 0.5, 0.5)))
    e, s = radiance_to_emissive((light_radiance,) * 3)
    light_m = g.material(lambert("light", (0.78, 0.78, 0.78), e, s))
    g.node("floor", mesh=g.flat_mesh("floor", rect_y(-3.0, 3.0, -3.0, 3.0, 0.0, True), floor_m))
    g.node("light", mesh=g.flat_mesh("light", rect_y(*light_rect, 1.8, False), light_m))


def scene_glass() -> dict:
    g = Gltf("Glass: a smooth solid sphere and a rough thin pane")
    _lit_floor(g)
    sphere_m = g.material(glass_material("glass_smooth", 0.0, {"thicknessFactor": 0.5}))
    pane_m = g.material(glass_material("glass_rough_thin", 0.3))
    g.node("sphere", translation=(-0.35, 0.3, 0.0),
           mesh=g.mesh_from_accessors("sphere", *_sphere_accessors(g, 0.3), sphere_m))
    pane = [((0.1, 0.0, 0.2), (0.8, 0.0, 0.2), (0.8, 0.7, 0.2)), ((0.1, 0.0, 0.2), (0.8, 0.7, 0.2), (0.1, 0.7, 0.2))]
    g.node("pane", mesh=g.flat_mesh("pane", pane, pane_m))
    red = g.material(lambert("red", (0.7, 0.15, 0.1)))
    g.node("box", translation=(0.45, 0.15, -0.4), mesh=g.flat_mesh("box", box_triangles((0.3, 0.3, 0.3)), red))
    g.camera("Camera", 0.7, (0.0, 0.9, 2.6), (0.0, 0.3, 0.0))
    return g.finish()


def scene_absorption() -> dict:
    g = Gltf("Absorbing glass: green glass sphere and slab (Beer-Lambert)")
    _lit_floor(g)
    vol = {"thicknessFactor": 0.5, "attenuationDistance": 0.3, "attenuationColor": [0.4, 0.9, 0.5]}
    m = g.material(glass_material("green_glass", 0.0, vol))
    g.node("sphere", translation=(-0.4, 0.3, 0.0),
           mesh=g.mesh_from_accessors("sphere", *_sphere_accessors(g, 0.3), m))
    # 1 mm above the floor: a glass face coplanar with the floor is a tie no renderer resolves alike.
    g.node("slab", translation=(0.45, 0.301, 0.0), mesh=g.flat_mesh("slab", box_triangles((0.5, 0.6, 0.15)), m))
    g.camera("Camera", 0.7, (0.0, 0.9, 2.6), (0.0, 0.3, 0.0))
    return g.finish()


def scene_depth_of_field() -> dict:
    g = Gltf("Depth of field: boxes at 3 depths, thin lens focused on the middle one")
    _lit_floor(g)
    colours = [(0.7, 0.15, 0.1), (0.15, 0.6, 0.15), (0.1, 0.2, 0.7)]
    for k, (c, z) in enumerate(zip(colours, (1.0, 0.0, -1.5))):
        m = g.material(lambert("box%d" % k, c))
        g.node("box%d" % k, translation=(-0.6 + 0.6 * k, 0.15, z),
               mesh=g.flat_mesh("box%d" % k, box_triangles((0.3, 0.3, 0.3)), m))
    eye, target = (0.0, 0.8, 3.0), (0.0, 0.15, 0.0)
    g.camera("Camera", 0.7, eye, target)
    focus = math.sqrt(sum((a - b) ** 2 for a, b in zip(eye, target)))
    g.doc["cameras"][-1]["extras"] = {"aperture_radius": 0.05, "focus_distance": round(focus, 6)}
    return g.finish()


def png_rgba(width: int, height: int, pixel) -> bytes:
    """A minimal RGBA8 PNG (stdlib zlib); pixel(x, y) -> (r, g, b, a) in 0..255."""
    import zlib
    rows = b"".join(b"\x00" + bytes(c for x in range(width) for c in pixel(x, y)) for y in range(height))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b"")


def scene_alpha_mask() -> dict:
    g = Gltf("Alpha mask: a card with a cut-out checker (texture alpha) and a half-cut card (factor)")
    _lit_floor(g)
    png = png_rgba(8, 8, lambda x, y: (230, 200, 60, 255 if (x + y) % 2 == 0 else 0))
    view = g._view(png, None)
    g.doc["images"] = [{"bufferView": view, "mimeType": "image/png"}]
    g.doc["samplers"] = [{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}]
    g.doc["textures"] = [{"source": 0, "sampler": 0}]
    card = g.material({"name": "checker_card", "alphaMode": "MASK", "alphaCutoff": 0.5, "doubleSided": True,
                       "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0,
                                                "roughnessFactor": 1.0, "baseColorTexture": {"index": 0}},
                       "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}})
    pos = [(-0.9, 0.05, 0.0), (-0.1, 0.05, 0.0), (-0.1, 0.85, 0.0), (-0.9, 0.85, 0.0)]
    uv = [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]
    a_pos = g.vec3_accessor(pos, with_bounds=True)
    a_nrm = g.vec3_accessor([(0.0, 0.0, 1.0)] * 4, with_bounds=False)
    flat = [f32(c) for t in uv for c in t]
    uv_view = g._view(struct.pack("<%df" % len(flat), *flat), ARRAY_BUFFER)
    g.doc["accessors"].append({"bufferView": uv_view, "byteOffset": 0, "componentType": FLOAT,
                               "count": 4, "type": "VEC2"})
    a_uv = len(g.doc["accessors"]) - 1
    a_idx = g.index_accessor([0, 1, 2, 0, 2, 3])
    g.doc["meshes"].append({"name": "card", "primitives": [{
        "attributes": {"POSITION": a_pos, "NORMAL": a_nrm, "TEXCOORD_0": a_uv},
        "indices": a_idx, "material": card, "mode": 4}]})
    g.node("card", mesh=len(g.doc["meshes"]) - 1)
    faint = g.material({"name": "faint_card", "alphaMode": "MASK", "alphaCutoff": 0.5,
                        "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.8, 0.3], "metallicFactor": 0.0,
                                                 "roughnessFactor": 1.0},
                        "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}})
    quad = [((0.1, 0.05, 0.0), (0.9, 0.05, 0.0), (0.9, 0.85, 0.0)), ((0.1, 0.05, 0.0), (0.9, 0.85, 0.0), (0.1, 0.85, 0.0))]
    g.node("faint_card", mesh=g.flat_mesh("faint_card", quad, faint))
    g.camera("Camera", 0.7, (0.0, 0.9, 2.6), (0.0, 0.4, 0.0))
    return g.finish()


def _float_accessor(g: Gltf, values: list[float], kind: str, bounds: bool = False) -> int:
    """An f32 accessor of SCALAR / VEC3 / VEC4 elements given flat."""
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[kind]
    flat = [f32(c) for c in values]
    view = g._view(struct.pack("<%df" % len(flat), *flat), None)
    acc = {"bufferView": view, "byteOffset": 0, "componentType": FLOAT, "count": len(flat) // width, "type": kind}
    if bounds:  # glTF requires min/max on animation inputs
        acc["min"] = [min(flat[k::width]) for k in range(width)]
        acc["max"] = [max(flat[k::width]) for k in range(width)]
    g.doc["accessors"].append(acc)
    return len(g.doc["accessors"]) - 1


ROLL_RADIUS = 0.05
ROLL_FROM_X, ROLL_TO_X, ROLL_Z, ROLL_SECONDS = 0.50, 0.36, 0.15, 0.5


def scene_cornell_animated() -> dict:
    """The Cornell box with a two-coloured ball rolling (without slipping) along -x in front of
    the tall block, and a camera dolly forward; one animation "roll", 1 s long."""
    g = Gltf("Cornell box, animated")
    mats = cornell_materials(g)
    for obj in cornell_box_objects():
        g.node(obj["name"], mesh=g.flat_mesh(obj["name"], obj["triangles"], mats[obj["material"]]))
    # The ball: a UV sphere split into two halves of different colours, so its rotation shows.
    pos, nrm, idx = uv_sphere(ROLL_RADIUS, 32, 16)
    halves = ([], [])
    for k in range(0, len(idx), 3):
        tri = idx[k:k + 3]
        halves[sum(pos[i][0] for i in tri) > 0.0].extend(tri)
    a_pos, a_nrm = g.vec3_accessor(pos, with_bounds=True), g.vec3_accessor(nrm, with_bounds=False)
    ball_mats = (g.material(lambert("ball_blue", (0.1, 0.2, 0.8))), g.material(lambert("ball_yellow", (0.85, 0.75, 0.1))))
    g.doc["meshes"].append({"name": "ball", "primitives": [
        {"attributes": {"POSITION": a_pos, "NORMAL": a_nrm}, "indices": g.index_accessor(h), "material": m, "mode": 4}
        for h, m in zip(halves, ball_mats)]})
    ball = g.node("ball", translation=(ROLL_FROM_X, ROLL_RADIUS, ROLL_Z), mesh=len(g.doc["meshes"]) - 1)
    c = CORNELL_CAMERA
    cam = g.camera(c["name"], math.radians(c["yfov_deg"]), c["position"], rotation=c["rotation"])

    # Translation: LINEAR over ROLL_SECONDS, then at rest. Rotation: rolling without slipping
    # about +z (velocity -x, up +y: omega = up x v / r), keyed every 1/8 s so consecutive keys
    # are less than pi apart (slerp takes the shorter arc).
    keys = [k * ROLL_SECONDS / 4 for k in range(5)] + [1.0]
    xs = [ROLL_FROM_X + (ROLL_TO_X - ROLL_FROM_X) * min(t / ROLL_SECONDS, 1.0) for t in keys]
    t_keys = _float_accessor(g, keys, "SCALAR", bounds=True)
    trans = _float_accessor(g, [v for x in xs for v in (x, ROLL_RADIUS, ROLL_Z)], "VEC3")
    rot = _float_accessor(g, [v for x in xs for v in quat_axis_angle((0.0, 0.0, 1.0), (ROLL_FROM_X - x) / ROLL_RADIUS)], "VEC4")
    # Camera dolly: CUBICSPLINE, (in-tangent, value, out-tangent) per key, tangents in m/s.
    cam_keys = [0.0, 0.5, 1.0]
    cam_z = [(0.15, c["position"][2], 0.15), (0.2, -0.72, 0.2), (0.25, -0.60, 0.0)]
    cam_t = _float_accessor(g, cam_keys, "SCALAR", bounds=True)
    cam_v = _float_accessor(g, [v for (a, z, b) in cam_z for v in (0.0, 0.0, a, c["position"][0], c["position"][1], z, 0.0, 0.0, b)], "VEC3")
    g.doc["animations"] = [{
        "name": "roll",
        "samplers": [{"input": t_keys, "output": trans, "interpolation": "LINEAR"},
                     {"input": t_keys, "output": rot, "interpolation": "LINEAR"},
                     {"input": cam_t, "output": cam_v, "interpolation": "CUBICSPLINE"}],
        "channels": [{"sampler": 0, "target": {"node": ball, "path": "translation"}},
                     {"sampler": 1, "target": {"node": ball, "path": "rotation"}},
                     {"sampler": 2, "target": {"node": cam, "path": "translation"}}],
    }]
    return g.finish()

def _vec2_accessor(g: Gltf, uvs: list[tuple[float, float]]) -> int:
    flat = [f32(c) for t in uvs for c in t]
    view = g._view(struct.pack("<%df" % len(flat), *flat), ARRAY_BUFFER)
    g.doc["accessors"].append({"bufferView": view, "byteOffset": 0, "componentType": FLOAT,
                               "count": len(uvs), "type": "VEC2"})
    return len(g.doc["accessors"]) - 1


def _textured_quad(g: Gltf, name: str, pos: list[Vec3], material: int) -> None:
    """A quad (4 corners, counter-clockwise from the front) with UVs (0,1) (1,1) (1,0) (0,0):
    u to the right, v down the image, so the image appears upright."""
    n = tri_normal((pos[0], pos[1], pos[2]))
    a_pos = g.vec3_accessor(pos, with_bounds=True)
    a_nrm = g.vec3_accessor([n] * 4, with_bounds=False)
    a_uv = _vec2_accessor(g, [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)])
    g.doc["meshes"].append({"name": name, "primitives": [{
        "attributes": {"POSITION": a_pos, "NORMAL": a_nrm, "TEXCOORD_0": a_uv},
        "indices": g.index_accessor([0, 1, 2, 0, 2, 3]), "material": material, "mode": 4}]})
    g.node(name, mesh=len(g.doc["meshes"]) - 1)


def _texture(g: Gltf, png: bytes) -> int:
    """Embeds a PNG as image + texture (repeat wrapping, so transforms tile); its index."""
    g.doc.setdefault("images", []).append({"bufferView": g._view(png, None), "mimeType": "image/png"})
    g.doc.setdefault("samplers", [{"wrapS": 10497, "wrapT": 10497}])
    g.doc.setdefault("textures", []).append({"source": len(g.doc["images"]) - 1, "sampler": 0})
    return len(g.doc["textures"]) - 1


def _normal_texel(x: int, y: int) -> tuple[int, int, int, int]:
    """Ridges along u: the normal tilts ±30° towards ±tangent in a sine across 8 texels."""
    tilt = math.radians(30.0) * math.sin(2.0 * math.pi * (x + 0.5) / 8.0)
    n = (math.sin(tilt), 0.0, math.cos(tilt))
    return tuple(round((c + 1.0) * 0.5 * 255.0) for c in n) + (255,)


def scene_textured() -> dict:
    g = Gltf("Textures: base colour, metallic-roughness, normal and emissive maps, texture transforms")
    _lit_floor(g)
    checker = _texture(g, png_rgba(8, 8, lambda x, y: (200, 60, 40, 255) if (x // 2 + y // 2) % 2 else (230, 220, 200, 255)))
    # G = roughness, B = metallic: metal with smooth and rough columns on the left half.
    mr = _texture(g, png_rgba(8, 8, lambda x, y: (0, 60 if x % 4 < 2 else 230, 255 if x < 4 else 0, 255)))
    ridges = _texture(g, png_rgba(8, 8, _normal_texel))
    glow = _texture(g, png_rgba(8, 8, lambda x, y: (255, 180, 60, 255) if (x + y) % 4 == 0 else (20, 40, 120, 255)))
    tile = {"name": "textured_tile",
            "pbrMetallicRoughness": {
                "baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 1.0, "roughnessFactor": 1.0,
                "baseColorTexture": {"index": checker, "extensions": {"KHR_texture_transform": {"scale": [2.0, 2.0]}}},
                "metallicRoughnessTexture": {"index": mr}},
            "normalTexture": {"index": ridges, "scale": 1.0,
                              "extensions": {"KHR_texture_transform": {"scale": [3.0, 1.0]}}}}
    _textured_quad(g, "tile", [(-0.9, 0.05, 0.0), (-0.05, 0.05, 0.0), (-0.05, 0.9, 0.0), (-0.9, 0.9, 0.0)], g.material(tile))
    sign = lambert("glowing_sign", (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 3.0)
    sign["emissiveTexture"] = {"index": glow, "extensions": {"KHR_texture_transform": {
        "offset": [0.25, 0.0], "rotation": round(math.radians(30.0), 6)}}}
    _textured_quad(g, "sign", [(0.1, 0.05, 0.0), (0.9, 0.05, 0.0), (0.9, 0.85, 0.0), (0.1, 0.85, 0.0)], g.material(sign))
    g.camera("Camera", 0.7, (0.0, 0.9, 2.6), (0.0, 0.4, 0.0))
    return g.finish()


def scene_emitters_only() -> dict:
    g = Gltf("Emitters and black surfaces: nothing scatters, so paths end at their first hit")
    black = g.material(lambert("black", (0.0, 0.0, 0.0)))
    g.node("floor", mesh=g.flat_mesh("floor", rect_y(-3.0, 3.0, -3.0, 3.0, 0.0, True), black))
    g.node("box", translation=(-0.5, 0.25, 0.0), mesh=g.flat_mesh("box", box_triangles((0.5, 0.5, 0.5)), black))
    for k, (c, x) in enumerate((((1.0, 0.3, 0.1), 0.0), ((0.2, 0.5, 1.0), 0.7))):
        m = g.material(lambert("lamp%d" % k, (0.0, 0.0, 0.0), c, 2.0))
        g.node("lamp%d" % k, translation=(x, 0.3, 0.0), mesh=g.flat_mesh("lamp%d" % k, box_triangles((0.3, 0.6, 0.3)), m))
    g.camera("Camera", 0.7, (0.0, 0.9, 2.6), (0.0, 0.3, 0.0))
    return g.finish()


class Lcg:
    """Knuth's MMIX 64-bit LCG: the same numbers on every Python (unlike `random`'s helpers)."""

    def __init__(self, seed: int):
        self.state = seed & 0xFFFFFFFFFFFFFFFF

    def uniform(self, lo: float = 0.0, hi: float = 1.0) -> float:
        self.state = (self.state * 6364136223846793005 + 1442695040888963407) & 0xFFFFFFFFFFFFFFFF
        return lo + (hi - lo) * (self.state >> 11) / float(1 << 53)

    def below(self, n: int) -> int:
        return min(int(self.uniform() * n), n - 1)


# many-lights: a 16 x 16 grid of small down-facing lamps, 0.75 m apart over a 12 m floor.
MANY_LIGHTS_GRID, MANY_LIGHTS_PITCH, MANY_LIGHTS_JITTER = 16, 0.75, 0.12
# Lamp colours (emissiveFactor, max channel 1); each is scaled to the same luminance before a
# strength level multiplies it, so no colour outshines the others.
MANY_LIGHTS_COLOURS = [
    ("warm", (1.0, 0.8, 0.6)), ("cool", (0.7, 0.85, 1.0)), ("orange", (1.0, 0.45, 0.2)),
    ("amber", (1.0, 0.7, 0.25)), ("green", (0.4, 1.0, 0.45)), ("blue", (0.35, 0.5, 1.0)),
    ("magenta", (1.0, 0.4, 0.8)), ("cyan", (0.4, 1.0, 0.95)),
]
MANY_LIGHTS_LEVELS = (0.6, 1.0, 1.6)
MANY_LIGHTS_LUMINANCE = 50.0  # luminance of the radiance at level 1


def scene_many_lights() -> dict:
    """Hundreds of small lights: 256 lamps (8-10 cm squares, 0.25-0.4 m up, facing down) in a
    jittered grid over a 12 m floor with a back wall, pillars and low walls (placed in the gaps
    between lamps). From any shading point nearly all lamps are far away or hidden, so choosing
    a lamp by its power wastes most shadow rays. Matte surfaces and one-sided area lights only,
    so tests/reference/gltf_scene.py gives Mitsuba the same scene."""
    g = Gltf("Many lights: 256 small down-facing lamps over a floor with occluders")
    rng = Lcg(20261204)
    floor_m = g.material(lambert("floor_grey", (0.5, 0.5, 0.5)))
    g.node("floor", mesh=g.flat_mesh("floor", rect_y(-6.0, 6.0, -6.0, 6.0, 0.0, True), floor_m))
    wall = [(-6.0, 0.0, -6.0), (6.0, 0.0, -6.0), (6.0, 3.0, -6.0), (-6.0, 3.0, -6.0)]
    wall_tris = [orient(t, (0.0, 0.0, 1.0)) for t in quad_to_tris(wall)]
    g.node("back_wall", mesh=g.flat_mesh("back_wall", wall_tris, floor_m))

    # Occluders, centred on the lines between lamp rows and columns (multiples of the pitch):
    # (name, albedo, centre x, centre z, size x, y, z).
    albedos = {"red": (0.7, 0.15, 0.1), "green": (0.15, 0.6, 0.15), "blue": (0.1, 0.2, 0.7),
               "yellow": (0.75, 0.65, 0.15), "white": (0.75, 0.75, 0.7)}
    p = MANY_LIGHTS_PITCH
    boxes = [
        ("pillar_red", "red", -3.0 * p, -2.0 * p, 0.3, 1.0, 0.3),
        ("pillar_blue", "blue", 2.0 * p, 1.0 * p, 0.3, 1.4, 0.3),
        ("pillar_yellow", "yellow", -5.0 * p, -5.0 * p, 0.35, 0.9, 0.35),
        ("pillar_white", "white", 0.0, 5.0 * p, 0.3, 0.5, 0.3),
        ("pillar_green", "green", 5.0 * p, 4.0 * p, 0.3, 0.8, 0.3),
        ("wall_white", "white", -2.5 * p, 3.0 * p, 3.0 * p, 0.7, 0.12),
        ("wall_green", "green", 4.0 * p, -3.5 * p, 0.12, 0.6, 3.0 * p),
        ("wall_blue", "blue", 3.0 * p, -6.0 * p, 4.0 * p, 0.8, 0.12),
        ("wall_red", "red", -1.0 * p, -1.5 * p, 0.12, 0.5, 3.0 * p),
    ]
    box_mats = {}
    for name, colour, cx, cz, sx, sy, sz in boxes:
        if colour not in box_mats:
            box_mats[colour] = g.material(lambert("box_" + colour, albedos[colour]))
        g.node(name, translation=(cx, sy / 2.0, cz), mesh=g.flat_mesh(name, box_triangles((sx, sy, sz)), box_mats[colour]))

    # Lamps: per grid cell a jittered centre, a width, a height, a colour and a strength level.
    half = (MANY_LIGHTS_GRID - 1) / 2.0
    groups: dict[tuple[int, int], list[Tri]] = {}
    for i in range(MANY_LIGHTS_GRID):
        for j in range(MANY_LIGHTS_GRID):
            cx = (i - half) * p + rng.uniform(-MANY_LIGHTS_JITTER, MANY_LIGHTS_JITTER)
            cz = (j - half) * p + rng.uniform(-MANY_LIGHTS_JITTER, MANY_LIGHTS_JITTER)
            w = rng.uniform(0.08, 0.10) / 2.0
            y = rng.uniform(0.25, 0.40)
            key = (rng.below(len(MANY_LIGHTS_COLOURS)), rng.below(len(MANY_LIGHTS_LEVELS)))
            cx, cz, w, y = (round(v, 4) for v in (cx, cz, w, y))
            # Clear of every box by 2 cm (sideways, or above its top).
            for name, _, bx, bz, sx, sy, sz in boxes:
                apart = abs(cx - bx) > w + sx / 2.0 + 0.02 or abs(cz - bz) > w + sz / 2.0 + 0.02
                assert apart or y > sy + 0.02, (name, i, j)
            groups.setdefault(key, []).extend(rect_y(cx - w, cx + w, cz - w, cz + w, y, False))
    assert sum(len(t) for t in groups.values()) == 2 * MANY_LIGHTS_GRID ** 2
    primitives = []
    for (c, lv) in sorted(groups):
        cname, rgb = MANY_LIGHTS_COLOURS[c]
        luminance = 0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
        strength = round(MANY_LIGHTS_LUMINANCE * MANY_LIGHTS_LEVELS[lv] / luminance, 3)
        m = g.material(lambert("lamp_%s_%g" % (cname, MANY_LIGHTS_LEVELS[lv]), (0.78, 0.78, 0.78), rgb, strength))
        tris = groups[(c, lv)]
        pos = [v for t in tris for v in t]
        nrm = [tri_normal(t) for t in tris for _ in range(3)]
        primitives.append({"attributes": {"POSITION": g.vec3_accessor(pos, with_bounds=True),
                                          "NORMAL": g.vec3_accessor(nrm, with_bounds=False)},
                           "indices": g.index_accessor(list(range(len(pos)))), "material": m, "mode": 4})
    g.doc["meshes"].append({"name": "lamps", "primitives": primitives})
    g.node("lamps", mesh=len(g.doc["meshes"]) - 1)
    g.camera("Camera", 0.8, (0.0, 4.0, 7.5), (0.0, 0.0, -0.5))
    return g.finish()


SCENES = {
    "absorption.gltf": scene_absorption,
    "alpha-mask.gltf": scene_alpha_mask,
    "depth-of-field.gltf": scene_depth_of_field,
    "emitters-only.gltf": scene_emitters_only,
    "glass.gltf": scene_glass,
    "cornell-box.gltf": scene_cornell_box,
    "cornell-animated.gltf": scene_cornell_animated,
    "cornell-small-light.gltf": scene_cornell_small_light,
    "furnace.gltf": scene_furnace,
    "glossy.gltf": scene_glossy,
    "many-lights.gltf": scene_many_lights,
    "phong.gltf": scene_phong,
    "punctual.gltf": scene_punctual,
    "textured.gltf": scene_textured,
}


def main(argv: list[str]) -> int:
    out_dir = argv[1] if len(argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    os.makedirs(out_dir, exist_ok=True)
    for fname, fn in SCENES.items():
        doc = fn()
        path = os.path.join(out_dir, fname)
        write(doc, path)
        ntri = sum(doc["accessors"][p["indices"]]["count"] // 3
                   for n in doc["nodes"] if "mesh" in n
                   for p in doc["meshes"][n["mesh"]]["primitives"])
        print("%-18s %6d triangles  %7d bytes" % (fname, ntri, os.path.getsize(path)))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
