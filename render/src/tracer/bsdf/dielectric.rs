//! # Dielectric — glass: smooth or rough (GGX) reflection and refraction, or a thin sheet
//!
//! The model is pbrt-v4's `DielectricBxDF` (and `ThinDielectricBxDF` for thin-walled glass):
//! - `eta` = n(below) / n(above): the index on the −z side over the index on the +z side
//!   (the integrator orients the frame towards wo and passes 1/ior when leaving the glass);
//! - `alpha` = GGX width; below [`SMOOTH_ALPHA`] the interface is a perfect mirror/refractor and
//!   sampling returns delta samples (`specular`), which `eval`/`pdf` give as 0;
//! - `tint` multiplies transmitted light (glTF: the base colour tints the specular BTDF);
//! - `thin`: a sheet with no interior (glTF without `KHR_materials_volume`): light passes
//!   straight through with the total transmittance of both faces and every internal reflection,
//!   T' = 1 − R' with R' = R + T²R/(1 − R²) — at normal incidence T' = (1 − R)/(1 + R).
//!
//! Radiance transport: transmitted radiance is divided by eta'² (the relative index of the
//! crossing), as light squeezes into a narrower cone entering a denser medium.
//!
//! Reference: Pharr, Jakob, Humphreys, *PBR 4th ed.*, §9.5 (dielectric BSDF), §9.7 (rough).
use super::ggx::Ggx;
use glam::{Vec2, Vec3};

/// GGX widths below this are treated as perfectly smooth.
pub const SMOOTH_ALPHA: f32 = 1e-3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    pub eta: f32,
    pub alpha: f32,
    pub tint: Vec3,
    pub thin: bool,
}

/// A sampled direction: `f` excludes the cosine; for `specular` samples `f` and `pdf` are the
/// delta's weight and choice probability (f·|cos|/pdf is the path weight either way).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lobe {
    pub wi: Vec3,
    pub f: Vec3,
    pub pdf: f32,
    pub specular: bool,
    /// Relative index η' of a refraction (1 for reflection and thin sheets): f carries 1/η'².
    pub eta: f32,
}

/// Unpolarised Fresnel reflectance of a dielectric interface; `cos_i` of the incident direction
/// on the side the normal points to (negative: from the other side).
pub fn fresnel(cos_i: f32, eta: f32) -> f32 {
    let (mut cos_i, mut eta) = (cos_i.clamp(-1.0, 1.0), eta);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// `wi` refracted through the interface with normal `n` (on wi's side); None at total internal
/// reflection. `eta` = n(other side) / n(wi's side).
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = n.dot(wi);
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    Some(-wi / eta + (cos_i / eta - cos_t) * n)
}

/// Mirrors z so that wo lies above; the interface then has index ratio 1/eta.
fn oriented(d: &Dielectric, wo: Vec3) -> (f32, f32) {
    if wo.z < 0.0 { (-1.0, 1.0 / d.eta) } else { (1.0, d.eta) }
}

fn flip(w: Vec3, s: f32) -> Vec3 {
    Vec3::new(w.x, w.y, w.z * s)
}

impl Dielectric {
    pub fn is_smooth(&self) -> bool {
        self.thin || self.alpha < SMOOTH_ALPHA || self.eta == 1.0
    }

    pub fn is_black(&self) -> bool {
        false
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if self.is_smooth() {
            return Vec3::ZERO;
        }
        let (s, eta) = oriented(self, wo);
        self.rough(flip(wo, s), flip(wi, s), eta).map_or(Vec3::ZERO, |(f, _)| f)
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.is_smooth() {
            return 0.0;
        }
        let (s, eta) = oriented(self, wo);
        self.rough(flip(wo, s), flip(wi, s), eta).map_or(0.0, |(_, p)| p)
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Lobe> {
        if wo.z == 0.0 {
            return None;
        }
        let (s, eta) = oriented(self, wo);
        let wo = flip(wo, s);
        let mut lobe = if self.is_smooth() {
            self.sample_smooth(wo, eta, u_lobe)?
        } else {
            self.sample_rough(wo, eta, u_lobe, u)?
        };
        lobe.wi = flip(lobe.wi, s);
        (lobe.pdf > 0.0 && lobe.f.is_finite() && lobe.wi.is_finite()).then_some(lobe)
    }

    /// Delta reflection or transmission, chosen in proportion to R and T (wo.z > 0).
    fn sample_smooth(&self, wo: Vec3, eta: f32, u_lobe: f32) -> Option<Lobe> {
        let mut r = fresnel(wo.z, eta);
        if self.thin && r < 1.0 {
            r += (1.0 - r) * (1.0 - r) * r / (1.0 - r * r);
        }
        let t = 1.0 - r;
        let reflected = Vec3::new(-wo.x, -wo.y, wo.z);
        if u_lobe < r || t <= 0.0 {
            return Some(Lobe {
                wi: reflected,
                f: Vec3::splat(r / wo.z),
                pdf: r,
                specular: true,
                eta: 1.0,
            });
        }
        let (wi, etap) = if self.thin { (-wo, 1.0) } else { (refract(wo, Vec3::Z, eta)?, eta) };
        let f = self.tint * (t / (etap * etap) / wi.z.abs());
        Some(Lobe { wi, f, pdf: t, specular: true, eta: etap })
    }

    fn sample_rough(&self, wo: Vec3, eta: f32, u_lobe: f32, u: Vec2) -> Option<Lobe> {
        let ggx = Ggx::new(self.alpha);
        let wm = ggx.sample_visible_normal(wo, u);
        let r = fresnel(wo.dot(wm), eta);
        let reflected = u_lobe < r;
        let wi = if reflected { wo.reflect_about(wm) } else { refract(wo, wm, eta)? };
        // A reflection must stay above and a refraction go below, else the sample is lost.
        if (wi.z > 0.0) != reflected || wi.z == 0.0 {
            return None;
        }
        let (f, pdf) = self.rough(wo, wi, eta)?;
        Some(Lobe { wi, f, pdf, specular: false, eta: if reflected { 1.0 } else { eta } })
    }

    /// f and pdf of the rough interface for wo.z > 0 (pbrt-v4 `DielectricBxDF::f`/`PDF`).
    fn rough(&self, wo: Vec3, wi: Vec3, eta: f32) -> Option<(Vec3, f32)> {
        let (cos_o, cos_i) = (wo.z, wi.z);
        if cos_o <= 0.0 || cos_i == 0.0 {
            return None;
        }
        let reflect = cos_i > 0.0;
        let etap = if reflect { 1.0 } else { eta };
        let wm = wi * etap + wo;
        if wm.length_squared() == 0.0 {
            return None;
        }
        let wm = if wm.z < 0.0 { -wm.normalize() } else { wm.normalize() };
        // Microfacets facing away from either direction contribute nothing.
        if wm.dot(wi) * cos_i < 0.0 || wm.dot(wo) <= 0.0 {
            return None;
        }
        let ggx = Ggx::new(self.alpha);
        let r = fresnel(wo.dot(wm), eta);
        let d = ggx.d(wm);
        let wi_up = Vec3::new(wi.x, wi.y, wi.z.abs());
        let g = 1.0 / (1.0 + ggx.lambda(wo) + ggx.lambda(wi_up));
        // Density of visible normals: G1(wo)·max(0, wo·wm)·D(wm)/wo.z.
        let d_vis = ggx.g1(wo) * wo.dot(wm) * d / cos_o;
        if reflect {
            let f = d * g * r / (4.0 * cos_i * cos_o);
            let pdf = d_vis / (4.0 * wo.dot(wm)) * r;
            return Some((Vec3::splat(f), pdf));
        }
        let denom = (wi.dot(wm) + wo.dot(wm) / etap).powi(2);
        let ft = d * (1.0 - r) * g * (wi.dot(wm) * wo.dot(wm) / (denom * cos_i * cos_o)).abs()
            / (etap * etap);
        let pdf = d_vis * wi.dot(wm).abs() / denom * (1.0 - r);
        Some((self.tint * ft, pdf))
    }
}

trait Reflect {
    fn reflect_about(self, n: Vec3) -> Vec3;
}

impl Reflect for Vec3 {
    fn reflect_about(self, n: Vec3) -> Vec3 {
        2.0 * self.dot(n) * n - self
    }
}

#[cfg(test)]
mod tests;
