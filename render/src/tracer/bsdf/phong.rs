//! # Phong — the seed's modified Phong BRDF (Lafortune & Willems)
//!
//! Parameters (checked by [`Phong::new`]):
//! - `kd`: diffuse reflectance, linear RGB, each channel in [0, 1];
//! - `ks`: specular reflectance, linear RGB, each channel in [0, 1];
//! - `n`: Phong exponent, dimensionless, ≥ 0 (0: a second diffuse-like lobe; 10⁶: close
//!   to a mirror, still evaluated accurately);
//! - kd + ks ≤ 1 in every channel, so that no energy is created.
//!
//! Model: f = kd/π + ks·(n+2)/(2π)·cosⁿα, where α is the angle between wi and the mirror
//! direction r of wo about the normal, and the lobe is 0 where cos α ≤ 0. The (n+2)/(2π)
//! factor makes the lobe reflect exactly ks at normal incidence and less elsewhere.
//!
//! Sampling (the seed's recipe): with pd = max(kd) and ps = max(ks), u_lobe < pd draws a
//! cosine-weighted direction, pd ≤ u_lobe < pd + ps draws cos α = u^(1/(n+1)) around r
//! (None if that lands below the horizon), anything else terminates (None). pdf(wi) =
//! pd·cos θi/π + ps'·(n+1)/(2π)·cosⁿα, which integrates to at most pd + ps. Here ps' =
//! min(ps, 1 − pd) is the lobe probability the recipe actually realises: coloured kd and
//! ks can have pd + ps > 1 even when kd + ks ≤ 1 per channel.
//!
//! Precision: cos α is never rounded to f32; 1 − cos α = |wi − r|²/2 keeps the lobe exact
//! at n = 10⁶, where cos α within the lobe differs from 1 by only ~10 f32 ulps.
//!
//! Reference: Lafortune & Willems 1994, "Using the Modified Phong Reflectance Model for
//! Physically Based Rendering" (KU Leuven CW 197).

use crate::tracer::sampling::{
    Frame, cosine_hemisphere, cosine_hemisphere_pdf, phong_lobe, pow_1m,
};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Phong {
    kd: Vec3,
    ks: Vec3,
    n: f32,
}

impl Phong {
    pub fn new(kd: Vec3, ks: Vec3, n: f32) -> Result<Phong, String> {
        for (name, v) in [("kd", kd), ("ks", ks)] {
            if !v.is_finite() || v.min_element() < 0.0 {
                return Err(format!("Phong: {name} = {v} must be finite and non-negative"));
            }
        }
        if !(n.is_finite() && n >= 0.0) {
            return Err(format!("Phong: exponent n = {n} must be finite and non-negative"));
        }
        let sum = kd + ks;
        // No tolerance needed: two f32 values rounded from complementary reals (0.7 and
        // 0.3, or 1 − kd computed in f64) always sum to at most 1.0 in f32.
        if let Some(c) = (0..3).find(|&c| sum[c] > 1.0) {
            let channel = ["red", "green", "blue"][c];
            return Err(format!(
                "Phong: kd + ks = {} > 1 in the {channel} channel would create energy",
                sum[c]
            ));
        }
        Ok(Phong { kd, ks, n })
    }

    pub fn kd(&self) -> Vec3 {
        self.kd
    }

    pub fn ks(&self) -> Vec3 {
        self.ks
    }

    pub fn n(&self) -> f32 {
        self.n
    }

    /// Probabilities of the diffuse and lobe branches as the recipe realises them.
    fn branch_probabilities(&self) -> (f32, f32) {
        let pd = self.kd.max_element();
        (pd, self.ks.max_element().min(1.0 - pd))
    }

    /// cosⁿα computed from the chord |wi − r|, r = (−wo.x, −wo.y, wo.z).
    fn lobe(&self, wo: Vec3, wi: Vec3) -> f32 {
        let r = Vec3::new(-wo.x, -wo.y, wo.z);
        pow_1m(0.5 * (wi - r).length_squared(), self.n)
    }

    pub(super) fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        let lobe = (self.n + 2.0) * 0.5 * FRAC_1_PI * self.lobe(wo, wi);
        self.kd * FRAC_1_PI + self.ks * lobe
    }

    pub(super) fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (pd, ps) = self.branch_probabilities();
        let lobe = (self.n + 1.0) * 0.5 * FRAC_1_PI * self.lobe(wo, wi);
        pd * cosine_hemisphere_pdf(wi.z) + ps * lobe
    }

    pub(super) fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        let (pd, ps) = self.branch_probabilities();
        if u_lobe < pd {
            Some(cosine_hemisphere(u))
        } else if u_lobe < pd + ps {
            let mirror = Frame::from_normal(Vec3::new(-wo.x, -wo.y, wo.z));
            Some(mirror.to_world(phong_lobe(u, self.n)).normalize())
        } else {
            None
        }
    }

    pub(super) fn is_black(&self) -> bool {
        self.kd.max_element() <= 0.0 && self.ks.max_element() <= 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::bsdf::Bsdf;
    use crate::tracer::bsdf::check::{self, Domain, dir};
    use crate::tracer::chi2::Rng;
    use glam::DVec3;
    use std::f64::consts::{PI, TAU};

    fn phong(kd: Vec3, ks: Vec3, n: f32) -> Bsdf {
        Bsdf::Phong(Phong::new(kd, ks, n).unwrap())
    }

    /// kd + ks = 1 per channel with pd + ps = 1.2 (the clamped branch), and kd + ks < 1;
    /// each at a near-normal and an oblique wo.
    fn cases() -> [(String, Bsdf, Vec3); 4] {
        let sum1 = phong(Vec3::new(0.5, 0.4, 0.3), Vec3::new(0.5, 0.6, 0.7), 20.0);
        let below = phong(Vec3::splat(0.2), Vec3::splat(0.3), 150.0);
        let case = |name: &str, b: Bsdf, deg: f32| (format!("phong {name} θ={deg}"), b, dir(deg));
        [
            case("sum=1", sum1, 10.0),
            case("sum=1", sum1, 70.0),
            case("sum<1", below, 10.0),
            case("sum<1", below, 70.0),
        ]
    }

    #[test]
    fn constructor_refuses_invalid_parameters() {
        let err = |kd, ks, n| Phong::new(kd, ks, n).unwrap_err();
        assert!(err(Vec3::new(0.5, 0.7, 0.1), Vec3::splat(0.4), 10.0).contains("green"));
        assert!(err(Vec3::new(-0.1, 0.0, 0.0), Vec3::ZERO, 10.0).contains("kd"));
        assert!(err(Vec3::ZERO, Vec3::new(0.0, f32::NAN, 0.0), 10.0).contains("ks"));
        assert!(err(Vec3::ZERO, Vec3::ONE, -1.0).contains("exponent"));
        assert!(Phong::new(Vec3::splat(0.7), Vec3::splat(0.3), 0.0).is_ok());
    }

    #[test]
    fn chi2_sampling() {
        let mut rng = Rng::new(30);
        for (name, b, wo) in cases() {
            check::chi2(&name, &b, wo, Domain::Wi, &mut rng);
        }
    }

    #[test]
    fn pdf_mass_is_the_success_rate() {
        let mut rng = Rng::new(31);
        for (name, b, wo) in cases() {
            check::pdf_mass_is_success_rate(&format!("{name} mass"), &b, wo, Domain::Wi, &mut rng);
        }
    }

    #[test]
    fn albedo_at_most_one() {
        let angles = [0.0, 45.0, 75.0, 89.0];
        let mut rng = Rng::new(32);
        let white = phong(Vec3::ZERO, Vec3::ONE, 1.0);
        for (name, b, _) in [cases()[0].clone(), cases()[2].clone()] {
            check::albedo_at_most_one(&name, &b, &angles, &mut rng);
        }
        check::albedo_at_most_one("phong white n=1", &white, &angles, &mut rng);
    }

    /// At n = 10⁶ the lobe is ~10⁻³ rad wide: sampled directions must give finite values,
    /// and pdf and f must match the f64 formulas at the same (f32) directions.
    #[test]
    fn exponent_1e6_is_accurate() {
        let n = 1e6;
        let b = phong(Vec3::splat(0.2), Vec3::splat(0.7), n as f32);
        let mut rng = Rng::new(33);
        for deg in [0.0, 30.0, 80.0, 89.9] {
            let wo = dir(deg);
            let r = DVec3::new(-wo.x as f64, -wo.y as f64, wo.z as f64).normalize();
            for _ in 0..20_000 {
                let Some(s) = b.sample(wo, rng.f32(), rng.vec2()) else {
                    continue;
                };
                let wi = s.wi.as_dvec3().normalize();
                let lobe = 0.7 / TAU * wi.dot(r).max(0.0).powf(n);
                let (pdf, f) = (0.2 * wi.z / PI + (n + 1.0) * lobe, 0.2 / PI + (n + 2.0) * lobe);
                let (got_pdf, got_f) = (s.pdf as f64, s.f.x as f64);
                assert!((got_pdf - pdf).abs() <= 1e-3 * pdf, "θ={deg}: {got_pdf} vs {pdf}");
                assert!((got_f - f).abs() <= 1e-3 * f, "θ={deg}: {got_f} vs {f}");
            }
        }
    }

    #[test]
    fn consistency_boundaries_and_black() {
        let mut rng = Rng::new(34);
        for (_, b, _) in cases() {
            check::consistency(&b, &mut rng);
            check::boundary(&b);
        }
        check::boundary(&phong(Vec3::ZERO, Vec3::ONE, 1e6));
        check::boundary(&phong(Vec3::ZERO, Vec3::ONE, 0.0));
        assert!(phong(Vec3::ZERO, Vec3::ZERO, 5.0).is_black() && !cases()[0].1.is_black());
    }
}
