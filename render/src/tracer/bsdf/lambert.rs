//! # Lambert — ideal diffuse reflection
//!
//! Parameter: `albedo` — linear RGB directional-hemispherical reflectance, in [0, 1] per
//! channel: the fraction of light arriving from any direction that is reflected.
//!
//! Models a matte surface that scatters equally in all directions: f = albedo/π,
//! constant over the hemisphere. Sampling is cosine weighted (pdf = cos θi/π), so every
//! sample carries the weight f·cos θi/pdf = albedo exactly.
//!
//! Reference: Lambert 1760, "Photometria"; Pharr, Jakob & Humphreys, "Physically Based
//! Rendering" 4th ed., §9.2.

use crate::tracer::sampling::{cosine_hemisphere, cosine_hemisphere_pdf};
use glam::{Vec2, Vec3};
use std::f32::consts::FRAC_1_PI;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambert {
    pub albedo: Vec3,
}

impl Lambert {
    pub(super) fn eval(&self) -> Vec3 {
        self.albedo * FRAC_1_PI
    }

    pub(super) fn pdf(&self, wi: Vec3) -> f32 {
        cosine_hemisphere_pdf(wi.z)
    }

    /// A direction with the f and pdf that `Bsdf::eval` and `Bsdf::pdf` give it (None where
    /// the pdf is 0: a direction in the horizon, where eval gives 0 too).
    pub(super) fn sample_with_values(&self, u: Vec2) -> Option<(Vec3, Vec3, f32)> {
        let wi = cosine_hemisphere(u);
        let (f, pdf) = (self.eval(), self.pdf(wi));
        (pdf > 0.0 && pdf.is_finite() && f.is_finite()).then_some((wi, f, pdf))
    }

    pub(super) fn is_black(&self) -> bool {
        self.albedo.max_element() <= 0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::bsdf::Bsdf;
    use crate::tracer::bsdf::check::{self, Domain, dir};
    use crate::tracer::chi2::Rng;

    fn lambert(albedo: Vec3) -> Bsdf {
        Bsdf::Lambert(Lambert { albedo })
    }

    #[test]
    fn chi2_and_pdf_mass() {
        let mut rng = Rng::new(20);
        let b = lambert(Vec3::new(0.8, 0.5, 0.2));
        check::chi2("lambert", &b, dir(40.0), Domain::Wi, &mut rng);
        check::pdf_mass_is_success_rate("lambert mass", &b, dir(70.0), Domain::Wi, &mut rng);
    }

    #[test]
    fn every_sample_weighs_exactly_the_albedo() {
        let mut rng = Rng::new(21);
        let albedo = Vec3::new(0.8, 0.5, 0.2);
        let b = lambert(albedo);
        for wo in check::INCIDENCE_DEG.map(dir) {
            let stats = check::albedo(&b, wo, 10_000, &mut rng);
            for (c, s) in stats.iter().enumerate() {
                // Only f32 rounding separates f·cos/pdf from the albedo.
                assert!(
                    (s.mean() - albedo[c] as f64).abs() < 1e-6 && s.std_error() < 1e-6,
                    "channel {c}"
                );
            }
        }
    }

    #[test]
    fn consistency_boundaries_and_black() {
        let mut rng = Rng::new(22);
        let b = lambert(Vec3::splat(0.5));
        check::consistency(&b, &mut rng);
        check::boundary(&b);
        assert!(lambert(Vec3::ZERO).is_black() && !b.is_black());
        assert_eq!(b.eval(dir(10.0), dir(-20.0)), Vec3::splat(0.5) * FRAC_1_PI);
        assert_eq!(b.eval(dir(10.0), -Vec3::Z), Vec3::ZERO);
        assert_eq!(b.pdf(-Vec3::Z, dir(10.0)), 0.0);
    }
}
