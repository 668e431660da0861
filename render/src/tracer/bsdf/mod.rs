//! # BSDFs
//!
//! A closed set of BSDFs, each documented in its own file: [`Lambert`] (ideal diffuse),
//! [`Phong`] (the seed's modified Phong), [`Pbr`] (glTF 2.0 metallic-roughness with
//! KHR_materials_specular), built on the [`Ggx`] microfacet lobe, and [`Dielectric`] (glass,
//! the only one that transmits).
//!
//! Everything works in the local shading frame: z is the shading normal, `wo` (toward the
//! viewer) and `wi` (toward the light) both point away from the surface, cos θ = w.z.
//! For the reflective BSDFs, unless wo.z > 0 and wi.z > 0, `eval` and `pdf` are 0 and sampling
//! gives None; the integrator flips the frame for double-sided materials. [`Dielectric`] takes
//! wi on either side; its smooth form samples deltas (`BsdfSample::specular`), which `eval` and
//! `pdf` give as 0. `eval` excludes the cosine;
//! the path weight is f·cos θi/pdf. `pdf` is exactly the solid-angle density with which
//! `sample` produces wi, including samplers that sometimes return None (so it may
//! integrate to less than 1); MIS relies on that.

pub mod dielectric;
pub mod ggx;
pub mod ggx_albedo;
pub mod lambert;
pub mod pbr;
pub mod phong;

pub use dielectric::Dielectric;
pub use ggx::Ggx;
pub use lambert::Lambert;
pub use pbr::Pbr;
pub use phong::Phong;

use crate::tracer::sampling::{uniform_hemisphere, uniform_hemisphere_pdf};
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f(wo, wi), without the cosine.
    pub f: Vec3,
    /// Solid-angle density of the whole sampling strategy at wi; finite and > 0. For a
    /// `specular` sample: the probability of choosing that delta lobe.
    pub pdf: f32,
    /// A delta direction (smooth glass): MIS and light sampling do not apply.
    pub specular: bool,
    /// Relative index of refraction η' crossed (1 for reflection and thin glass). `f` divides
    /// transmitted radiance by η'², which is not an energy loss: roulette undoes it.
    pub eta: f32,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    Lambert(Lambert),
    Phong(Phong),
    Pbr(Pbr),
    Dielectric(Dielectric),
}

fn both_above(wo: Vec3, wi: Vec3) -> bool {
    wo.z > 0.0 && wi.z > 0.0
}

impl Bsdf {
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Vec3 {
        if !both_above(wo, wi) && !self.transmits() {
            return Vec3::ZERO;
        }
        match self {
            Bsdf::Lambert(b) => b.eval(),
            Bsdf::Phong(b) => b.eval(wo, wi),
            Bsdf::Pbr(b) => b.eval(wo, wi),
            Bsdf::Dielectric(b) => b.eval(wo, wi),
        }
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if !both_above(wo, wi) && !self.transmits() {
            return 0.0;
        }
        match self {
            Bsdf::Lambert(b) => b.pdf(wi),
            Bsdf::Phong(b) => b.pdf(wo, wi),
            Bsdf::Pbr(b) => b.pdf(wo, wi),
            Bsdf::Dielectric(b) => b.pdf(wo, wi),
        }
    }

    /// Whether wi may lie below the surface (glass).
    pub fn transmits(&self) -> bool {
        matches!(self, Bsdf::Dielectric(_))
    }

    /// Whether sampling only gives delta directions (light sampling is then pointless).
    pub fn is_specular(&self) -> bool {
        match self {
            Bsdf::Dielectric(d) => d.is_smooth(),
            _ => false,
        }
    }

    /// Whether [`Bsdf::sample`] reads `u_lobe` (every BSDF with more than one lobe).
    pub fn chooses_lobes(&self) -> bool {
        !matches!(self, Bsdf::Lambert(_))
    }

    /// `u_lobe` picks a lobe, `u` places the direction within it.
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if wo.z <= 0.0 && !self.transmits() {
            return None;
        }
        let wi = match self {
            // The commonest surface: its f and pdf straight from the lobe, as eval/pdf give them.
            Bsdf::Lambert(b) => {
                return b.sample_with_values(u).map(|(wi, f, pdf)| BsdfSample {
                    wi,
                    f,
                    pdf,
                    specular: false,
                    eta: 1.0,
                });
            }
            Bsdf::Phong(b) => b.sample(wo, u_lobe, u),
            Bsdf::Pbr(b) => b.sample(wo, u_lobe, u),
            // The glass lobes carry their own f and pdf (deltas cannot be re-evaluated).
            Bsdf::Dielectric(b) => {
                let l = b.sample(wo, u_lobe, u)?;
                return Some(BsdfSample {
                    wi: l.wi,
                    f: l.f,
                    pdf: l.pdf,
                    specular: l.specular,
                    eta: l.eta,
                });
            }
        }?;
        // Re-evaluating instead of carrying values out of the lobe samplers makes the
        // sample agree exactly with eval/pdf, mixture terms included.
        let (f, pdf) = (self.eval(wo, wi), self.pdf(wo, wi));
        (pdf > 0.0 && pdf.is_finite() && f.is_finite()).then_some(BsdfSample {
            wi,
            f,
            pdf,
            specular: false,
            eta: 1.0,
        })
    }

    /// Uniform hemisphere sampling, for the seed's naive estimator.
    pub fn sample_uniform(&self, wo: Vec3, u: Vec2) -> Option<BsdfSample> {
        let wi = uniform_hemisphere(u);
        let f = self.eval(wo, wi);
        (both_above(wo, wi) && f.is_finite()).then_some(BsdfSample {
            wi,
            f,
            pdf: uniform_hemisphere_pdf(),
            specular: false,
            eta: 1.0,
        })
    }

    /// Reflects nothing for any pair of directions: the integrator can end the path.
    pub fn is_black(&self) -> bool {
        match self {
            Bsdf::Lambert(b) => b.is_black(),
            Bsdf::Phong(b) => b.is_black(),
            Bsdf::Pbr(b) => b.is_black(),
            Bsdf::Dielectric(b) => b.is_black(),
        }
    }
}

/// Checks shared by the BSDF tests.
#[cfg(test)]
pub(crate) mod check {
    use super::*;
    use crate::tracer::chi2::{self, Grid, Rng, U_MAX, edge_inputs};
    use glam::DVec3;

    pub const INCIDENCE_DEG: [f32; 5] = [0.0, 30.0, 60.0, 80.0, 89.0];

    /// Unit direction at `deg` from the normal, in the xz-plane.
    pub fn dir(deg: f32) -> Vec3 {
        let (s, c) = deg.to_radians().sin_cos();
        Vec3::new(s, 0.0, c)
    }

    /// `sample` returns unit directions above the horizon whose f and pdf equal eval/pdf.
    pub fn consistency(b: &Bsdf, rng: &mut Rng) {
        for wo in INCIDENCE_DEG.map(dir) {
            for _ in 0..5000 {
                let Some(s) = b.sample(wo, rng.f32(), rng.vec2()) else {
                    continue;
                };
                assert!(s.wi.z > 0.0 && (s.wi.length() - 1.0).abs() < 1e-5, "{b:?}: {s:?}");
                let (f, pdf) = (b.eval(wo, s.wi), b.pdf(wo, s.wi));
                let f_err = (s.f - f).abs().max_element();
                assert!(f_err <= 1e-4 * f.max_element(), "{b:?}: f {s:?} vs {f}");
                assert!((s.pdf - pdf).abs() <= 1e-4 * pdf, "{b:?}: pdf {s:?} vs {pdf}");
            }
        }
    }

    /// Random numbers at 0 and 1 − 2⁻²⁴ in every input, and degenerate wo, give a clean
    /// None or a finite sample.
    pub fn boundary(b: &Bsdf) {
        for wo in [dir(0.0), dir(45.0), dir(89.999), Vec3::X, -Vec3::Z] {
            for (ul, u) in [0.0, 0.5, U_MAX].into_iter().flat_map(|l| edge_inputs().map(|u| (l, u)))
            {
                for s in [b.sample(wo, ul, u), b.sample_uniform(wo, u)].into_iter().flatten() {
                    assert!(s.wi.is_finite() && s.f.is_finite(), "{b:?} {wo} {u}: {s:?}");
                    assert!(s.pdf.is_finite() && s.pdf > 0.0, "{b:?} {wo} {u}: {s:?}");
                    assert!(b.eval(wo, s.wi).is_finite() && b.pdf(wo, s.wi).is_finite());
                }
            }
        }
    }

    /// Where directions are binned or integrated: by wi on a uniform hemisphere grid, or by
    /// half vector on a grid of the given scale (needed for narrow microfacet lobes, whose
    /// wi lobe is thin across the plane of incidence).
    #[derive(Clone, Copy)]
    pub enum Domain {
        Wi,
        Half(f64),
    }

    impl Domain {
        fn grid(self) -> Grid {
            match self {
                Domain::Wi => Grid::hemisphere(DVec3::Z, 1.0),
                Domain::Half(scale) => Grid::hemisphere(DVec3::Z, scale),
            }
        }

        fn of(self, wo: Vec3, wi: Vec3) -> Vec3 {
            match self {
                Domain::Wi => wi,
                Domain::Half(_) => (wo + wi).normalize(),
            }
        }

        fn pdf(self, b: &Bsdf, wo: Vec3, x: DVec3) -> f64 {
            match self {
                Domain::Wi => b.pdf(wo, x.as_vec3()) as f64,
                Domain::Half(_) => chi2::half_vector_density(wo, x, |wi| b.pdf(wo, wi)),
            }
        }
    }

    pub fn chi2(name: &str, b: &Bsdf, wo: Vec3, domain: Domain, rng: &mut Rng) {
        let mut sample = || b.sample(wo, rng.f32(), rng.vec2()).map(|s| domain.of(wo, s.wi));
        let pdf = |x: DVec3| domain.pdf(b, wo, x);
        chi2::assert_chi2(name, &domain.grid(), 500_000, &mut sample, &pdf);
    }

    /// ∫ pdf dωi by quadrature is ≤ 1 and equals the fraction of `sample` calls that succeed.
    pub fn pdf_mass_is_success_rate(name: &str, b: &Bsdf, wo: Vec3, domain: Domain, rng: &mut Rng) {
        let (mass, err) = chi2::integrate_sphere(&domain.grid(), &|x| domain.pdf(b, wo, x));
        assert!(mass <= 1.0 + err, "{name}: pdf integrates to {mass} > 1");
        let n = 200_000;
        let hits = (0..n).filter(|_| b.sample(wo, rng.f32(), rng.vec2()).is_some()).count();
        let rate = hits as f64 / n as f64;
        let sigma = (mass * (1.0 - mass) / n as f64).sqrt().max(f64::MIN_POSITIVE);
        let z = ((rate - mass).abs() - err).max(0.0) / sigma;
        let detail = format!("∫pdf = {mass:.5} ± {err:.1e}, success rate {rate:.5}");
        chi2::assert_p(name, chi2::normal_p(z), &detail);
    }

    /// Mean and standard error of a stream of values (Welford).
    #[derive(Default)]
    pub struct Stats {
        n: f64,
        mean: f64,
        m2: f64,
    }

    impl Stats {
        pub fn push(&mut self, x: f64) {
            self.n += 1.0;
            let d = x - self.mean;
            self.mean += d / self.n;
            self.m2 += d * (x - self.mean);
        }

        pub fn mean(&self) -> f64 {
            self.mean
        }

        pub fn std_error(&self) -> f64 {
            (self.m2 / (self.n - 1.0) / self.n).sqrt()
        }
    }

    /// Monte Carlo estimate of ∫ f cos θi dωi per channel, importance sampled.
    pub fn albedo(b: &Bsdf, wo: Vec3, n: usize, rng: &mut Rng) -> [Stats; 3] {
        let mut stats: [Stats; 3] = Default::default();
        for _ in 0..n {
            let s = b.sample(wo, rng.f32(), rng.vec2());
            let w = s.map_or(Vec3::ZERO, |s| s.f * s.wi.z / s.pdf);
            (0..3).for_each(|c| stats[c].push(w[c] as f64));
        }
        stats
    }

    /// Two independent uniform directions in the upper hemisphere.
    pub fn random_pair(rng: &mut Rng) -> (Vec3, Vec3) {
        (uniform_hemisphere(rng.vec2()), uniform_hemisphere(rng.vec2()))
    }

    /// Tests that the Monte Carlo albedo (green channel) at `wo` equals a quadrature
    /// `reference` known to within `err`.
    pub fn albedo_is(name: &str, b: &Bsdf, wo: Vec3, (reference, err): (f64, f64), rng: &mut Rng) {
        let s = &albedo(b, wo, 200_000, rng)[1];
        let z = ((s.mean() - reference).abs() - err).max(0.0) / s.std_error();
        let detail =
            format!("MC {:.5} ± {:.5}, quadrature {reference:.5}", s.mean(), s.std_error());
        chi2::assert_p(name, chi2::normal_p(z), &detail);
    }

    /// Tests "albedo ≤ 1" in every channel (Bonferroni over the three) at each angle.
    pub fn albedo_at_most_one(name: &str, b: &Bsdf, angles: &[f32], rng: &mut Rng) {
        for &deg in angles {
            let stats = albedo(b, dir(deg), 100_000, rng);
            let p_at_most_one = |s: &Stats| chi2::mean_at_most_p(s.mean(), s.std_error(), 1.0);
            let p = stats.iter().map(p_at_most_one).fold(1.0, f64::min);
            let means = stats.map(|s| s.mean());
            let name = format!("{name} albedo at {deg}°");
            chi2::assert_p(&name, (3.0 * p).min(1.0), &format!("{means:.4?}"));
        }
    }
}
