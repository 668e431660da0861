"""A Mitsuba 3 BSDF for Tessera's `TESSERA_materials_phong` extension, written in Python.

The modified Phong BRDF of the seed (Lafortune & Willems 1994), as Tessera's `Phong` defines it:

    f(wi, wo) = kd/π + ks·(n + 2)/(2π)·cosⁿα,   α = angle between wo and the mirror of wi

with the lobe 0 where cos α ≤ 0. Reflection only, one-sided. Mitsuba has no such plugin. Its
sampling here is its own, not Tessera's recipe: the cosine-weighted hemisphere with probability
pd/(pd + ps), else cos α = u^(1/(n+1)) about the mirror direction, with pd = max(kd) and
ps = max(ks), and the mixture's pdf; the image it converges to is the same.

Parameters (scene dict): `type: "tessera_phong"`, `kd`, `ks` (RGB lists), `n` (float).
Register with `register()` before `mi.load_dict`; it needs a JIT variant (`llvm_ad_rgb`).
"""

from __future__ import annotations

import reflection_bsdf


def register() -> None:
    """Makes `tessera_phong` known to Mitsuba (once per process)."""
    reflection_bsdf.register("tessera_phong", _define)


def _define(Base, mi, dr):
    class TesseraPhong(Base):
        def __init__(self, props):
            flags = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide
            super().__init__(props, flags)
            kd, ks = list(props["kd"]), list(props["ks"])
            self.kd, self.ks, self.n = mi.Color3f(kd), mi.Color3f(ks), float(props["n"])
            pd, ps = max(kd), max(ks)
            self.p_lobe = ps / (pd + ps) if pd + ps > 0.0 else 0.0

        def _f_cos(self, wi, wo):
            """f · cosθo, and the sampling density of wo, for local directions."""
            ci, co = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
            valid = (ci > 0.0) & (co > 0.0)
            mirror = mi.Vector3f(-wi.x, -wi.y, wi.z)
            cos_a = dr.maximum(dr.dot(wo, mirror), 0.0)
            lobe = dr.power(cos_a, self.n)
            value = (self.kd * dr.inv_pi + self.ks * ((self.n + 2.0) * 0.5 * dr.inv_pi) * lobe) * co
            pdf = (1.0 - self.p_lobe) * co * dr.inv_pi + self.p_lobe * (self.n + 1.0) * 0.5 * dr.inv_pi * lobe
            return dr.select(valid, value, 0.0), dr.select(valid, pdf, 0.0)

        def _direction(self, wi, sample1, sample2):
            mirror = mi.Vector3f(-wi.x, -wi.y, wi.z)
            cos_a = dr.power(sample2.x, 1.0 / (self.n + 1.0))
            sin_a = dr.safe_sqrt(1.0 - cos_a * cos_a)
            phi = 2.0 * dr.pi * sample2.y
            around = mi.Frame3f(mirror).to_world(mi.Vector3f(sin_a * dr.cos(phi), sin_a * dr.sin(phi), cos_a))
            return dr.select(sample1 < self.p_lobe, around, mi.warp.square_to_cosine_hemisphere(sample2))

        def to_string(self):
            return f"TesseraPhong[kd={self.kd}, ks={self.ks}, n={self.n}]"

    return TesseraPhong
