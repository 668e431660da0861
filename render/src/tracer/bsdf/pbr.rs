//! # Pbr — glTF 2.0 metallic-roughness BRDF with KHR_materials_specular
//!
//! Parameters (glTF names in brackets; all colours linear RGB):
//! - `base_color` \[baseColorFactor\]: diffuse colour of a dielectric, F0 of a metal; [0, 1];
//! - `metallic` \[metallicFactor\]: 0 = dielectric, 1 = metal, blends linearly in between;
//! - `roughness` \[roughnessFactor\]: perceptual roughness in [0, 1]; the GGX width is
//!   α = roughness² (clamped to ggx::MIN_ALPHA, so 0 is a near-mirror);
//! - `specular` \[KHR_materials_specular specularFactor, default 1\]: strength of the
//!   dielectric's specular layer; 0 leaves a purely Lambertian base_color/π;
//! - `specular_color` \[specularColorFactor, default 1\]: tints the dielectric's F0, may
//!   exceed 1 (the product with the IOR's F0 is clamped to 1);
//! - `ior` \[KHR_materials_ior, default 1.5\]: sets the dielectric F0 = ((ior−1)/(ior+1))².
//!
//! Model (glTF 2.0 Appendix B with the fresnel_mix of KHR_materials_specular, made
//! energy-conserving), with spec = D·G2/(4 wo.z wi.z) from [`Ggx`] and fw = (1 − |wo·h|)⁵:
//! - dielectric_f0 = min(((ior−1)/(ior+1))²·specular_color, 1)·specular,
//!   dielectric_f90 = specular, F_d = f0 + (f90 − f0)·fw;
//! - E_s(μo) = max_channel(f0·E(μo) + (f90 − f0)·E_fw(μo)): the directional albedo of the
//!   specular layer F_d·spec seen from wo, from the tabulated GGX albedos of
//!   [`ggx_albedo`];
//! - dielectric = F_d·spec + (1 − E_s(μo))·base_color/π;
//! - metal = (base_color + (1 − base_color)·fw)·spec (Schlick conductor Fresnel);
//! - f = mix(dielectric, metal, metallic).
//!
//! Why E_s(μo) and not the specification's 1 − max F_d(wo·h): the specification weights the
//! base per direction pair, but the specular layer seen at a grazing wo reflects nearly
//! all light, so a white dielectric reflected up to 1.7× what it received at 89°. With the
//! base weighted by what the layer leaves, the albedo is E_s + (1 − E_s)·base_color ≤ 1 at
//! every angle, and exactly 1 (up to the table's ~1e-3) for a white base. Head-on the two
//! agree to within a few per cent (E_s ≈ f0 ≈ 0.04 for ior 1.5), so the look of a material
//! facing the camera barely changes; towards grazing angles the base darkens as the
//! highlight brightens. The weight depends on wo only (Kulla & Conty 2017's simple form),
//! so f is not reciprocal; the estimators here never swap wo and wi, so nothing relies on it.
//!
//! Single scattering only: rough surfaces lose the energy of light bouncing between
//! microfacets (the tabulated E says how much); transmission, clearcoat, sheen and
//! textures are outside this type.
//!
//! Sampling picks the GGX lobe (visible normals) with probability S/(S + D), where S =
//! (1 − metallic)·E_s(μo) + metallic and D = (1 − metallic)·(1 − E_s(μo))·
//! max_channel(base_color), otherwise a cosine-weighted direction.
//! The probability is exactly 0 with no specular term (the result is then bit for bit
//! [`Lambert`](super::Lambert)) and exactly 1 for a pure metal; pdf is the mixture.
//!
//! References: Khronos glTF 2.0 specification, Appendix B; KHR_materials_specular and
//! KHR_materials_ior extension specifications; Kulla & Conty 2017, "Revisiting Physically
//! Based Shading at Imageworks" (albedo scaling of layers).

use super::ggx::Ggx;
use super::ggx_albedo;
use crate::tracer::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pbr {
    pub base_color: Vec3,
    pub metallic: f32,
    pub roughness: f32,
    pub specular: f32,
    pub specular_color: Vec3,
    pub ior: f32,
}

impl Pbr {
    /// Core glTF parameters with the KHR_materials_specular / _ior defaults.
    pub fn new(base_color: Vec3, metallic: f32, roughness: f32) -> Pbr {
        Pbr { base_color, metallic, roughness, specular: 1.0, specular_color: Vec3::ONE, ior: 1.5 }
    }

    fn ggx(&self) -> Ggx {
        Ggx::new(self.roughness * self.roughness)
    }

    /// Dielectric F0 per channel.
    fn dielectric_f0(&self) -> Vec3 {
        let r = (self.ior - 1.0) / (self.ior + 1.0);
        (r * r * self.specular_color).min(Vec3::ONE) * self.specular
    }

    /// Dielectric Fresnel F_d at weight fw = (1 − cos)⁵.
    fn dielectric_fresnel(&self, fw: f32) -> Vec3 {
        let f0 = self.dielectric_f0();
        f0 + (Vec3::splat(self.specular) - f0) * fw
    }

    /// E_s(μo): the largest channel of the specular layer's directional albedo. That
    /// albedo, f0·E + (f90 − f0)·E_fw, grows with f0 (E_fw ≤ E), so it is the max-f0 channel's.
    fn specular_albedo(&self, cos_o: f32) -> f32 {
        let (e, e_fw) = ggx_albedo::lookup(cos_o, self.roughness);
        let f0 = self.dielectric_f0().max_element();
        (f0 * e + (self.specular - f0) * e_fw).clamp(0.0, 1.0)
    }

    fn has_specular(&self) -> bool {
        self.metallic > 0.0 || self.specular > 0.0
    }

    /// Probability of sampling the GGX lobe; see the module doc.
    fn specular_probability(&self, cos_o: f32) -> f32 {
        if !self.has_specular() {
            return 0.0;
        }
        let m = self.metallic;
        let es = self.specular_albedo(cos_o);
        let s = (1.0 - m) * es + m;
        let d = (1.0 - m) * (1.0 - es) * self.base_color.max_element();
        if d <= 0.0 { 1.0 } else { s / (s + d) }
    }

    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let diffuse = self.base_color * FRAC_1_PI;
        if !self.has_specular() {
            return diffuse;
        }
        let fw = schlick_weight(wo.dot((wo + wi).normalize()).abs());
        let spec = self.ggx().eval_reflect(wo, wi);
        let fd = self.dielectric_fresnel(fw);
        let dielectric = fd * spec + (1.0 - self.specular_albedo(wo.z)) * diffuse;
        let metal = (self.base_color + (Vec3::ONE - self.base_color) * fw) * spec;
        dielectric.lerp(metal, self.metallic)
    }

    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let p = self.specular_probability(wo.z);
        let diffuse = cosine_hemisphere_pdf(wi.z);
        if p == 0.0 {
            return diffuse;
        }
        let spec = self.ggx().pdf_reflect(wo, wi);
        if p == 1.0 { spec } else { p * spec + (1.0 - p) * diffuse }
    }

    pub(super) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        if u_lobe < self.specular_probability(wo.z) {
            self.ggx().sample_reflect(wo, u)
        } else {
            Some(cosine_hemisphere(u))
        }
    }

    pub(super) fn is_black(&self) -> bool {
        !self.has_specular() && self.base_color.max_element() <= 0.0
    }
}

/// Schlick's (1 − cos)⁵.
fn schlick_weight(cos: f32) -> f32 {
    (1.0 - cos).clamp(0.0, 1.0).powi(5)
}

#[cfg(test)]
mod tests;
