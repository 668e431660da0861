"""A Mitsuba 3 BSDF for a glTF 2.0 pure metal (`metallicFactor` 1), written in Python.

Mitsuba 3 has no built-in with glTF's metal: `roughconductor` takes a complex index of
refraction, not an F0 colour, and `principled` (metallic 1) and `roughconductor` both use the
separable Smith shadowing-masking G1(wi)·G1(wo), where glTF's Appendix B (and Tessera's
`Pbr`) uses the height-correlated form. This plugin is the specification's model:

    f(wi, wo) = F(|wi·h|) · D(h) · G2(wi, wo) / (4 cosθi cosθo),   h = normalize(wi + wo)
    F(c)      = F0 + (1 − F0)·(1 − c)⁵,       F0 = baseColorFactor (Schlick)
    D         = GGX (Trowbridge–Reitz) of width α = max(roughnessFactor², 1e-4)
    G2        = 1 / (1 + Λ(wi) + Λ(wo)),       Λ(w) = (√(1 + α² tan²θ) − 1) / 2

Reflection only, one-sided (zero unless both directions are above the surface), as glTF's
single-sided materials are. Directions are sampled from the visible normals with Mitsuba's own
`MicrofacetDistribution` (a different sampling routine from Tessera's spherical caps, the same
density), so an image that agrees with Tessera's checks Tessera's sampling, pdf and MIS for
metals end to end, not one piece of code against itself.

Parameters (scene dict): `type: "gltf_metal"`, `base_color` (RGB list, F0), `alpha` (float).
Register with `register()` before `mi.load_dict`; it needs a JIT variant (`llvm_ad_rgb`),
where the Python code is traced once into the render's compiled kernels.
"""

from __future__ import annotations

import reflection_bsdf

MIN_ALPHA = 1e-4  # Tessera's ggx::MIN_ALPHA


def register() -> None:
    """Makes `gltf_metal` known to Mitsuba (once per process)."""
    reflection_bsdf.register("gltf_metal", _define)


def _define(Base, mi, dr):
    class GltfMetal(Base):
        def __init__(self, props):
            super().__init__(props, mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide)
            self.base_color = mi.Color3f(props["base_color"])
            self.alpha = max(float(props["alpha"]), MIN_ALPHA)
            self.distr = mi.MicrofacetDistribution(mi.MicrofacetType.GGX, self.alpha, True)

        def _lambda(self, cos_theta):
            c2 = cos_theta * cos_theta
            tan2 = dr.maximum(1.0 - c2, 0.0) / c2
            return (dr.sqrt(1.0 + self.alpha * self.alpha * tan2) - 1.0) * 0.5

        def _f_cos(self, wi, wo):
            """f · cosθo, and the sampling density of wo, for local directions."""
            ci, co = mi.Frame3f.cos_theta(wi), mi.Frame3f.cos_theta(wo)
            valid = (ci > 0.0) & (co > 0.0)
            h = dr.normalize(wi + wo)
            c = dr.abs(dr.dot(wi, h))
            fresnel = self.base_color + (1.0 - self.base_color) * dr.power(1.0 - c, 5.0)
            d = self.distr.eval(h)
            g2 = 1.0 / (1.0 + self._lambda(ci) + self._lambda(co))
            value = fresnel * (d * g2 / (4.0 * ci))
            # Visible normals: D_wi(h) = G1(wi)·(wi·h)·D(h)/cosθi, mapped to wo by 1/(4 wo·h).
            pdf = self.distr.smith_g1(wi, h) * d / (4.0 * ci)
            return dr.select(valid, value, 0.0), dr.select(valid, pdf, 0.0)

        def _direction(self, wi, sample1, sample2):
            m, _ = self.distr.sample(wi, sample2)
            return mi.reflect(wi, m)

        def to_string(self):
            return f"GltfMetal[base_color={self.base_color}, alpha={self.alpha}]"

    return GltfMetal
