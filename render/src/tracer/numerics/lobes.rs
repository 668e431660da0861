//! Case 7: peaked lobes. The pdf-versus-f64 checks at these extremes live beside the code
//! (`phong::tests::exponent_1e6_is_accurate`, `ggx::tests::stable_at_tiny_alpha_and_grazing_incidence`);
//! here the sampling itself is χ²-tested at the extremes, binned around the lobe's axis.
use crate::tracer::bsdf::check::{self, Domain, dir};
use crate::tracer::bsdf::{Bsdf, Pbr, Phong};
use crate::tracer::chi2::{self, Grid, Rng};
use glam::{DVec3, Vec3};

/// Phong lobes of exponent 1e4 and 1e6 (1e-2 and 1e-3 rad wide) at incidence up to 89°,
/// binned on a sphere grid around the mirror direction. Catches cosⁿα evaluated as
/// powf(cos α) on an f32 cosine: within 1e-3 rad of the axis cos α takes ~10 distinct
/// values, so the pdf is a staircase the samples do not follow.
#[test]
fn chi2_phong_exponents_up_to_1e6_at_grazing_incidence() {
    let mut rng = Rng::new(107);
    for (n, deg) in [(1e4f32, 0.0f32), (1e4, 89.0), (1e6, 30.0), (1e6, 89.0)] {
        let b = Bsdf::Phong(Phong::new(Vec3::ZERO, Vec3::ONE, n).unwrap());
        let wo = dir(deg);
        let mirror = DVec3::new(-wo.x as f64, -wo.y as f64, wo.z as f64);
        let grid = Grid::sphere(mirror, 1.0 / (n as f64).sqrt());
        let mut sample = || b.sample(wo, rng.f32(), rng.vec2()).map(|s| s.wi);
        let pdf = |d: DVec3| b.pdf(wo, d.as_vec3()) as f64;
        chi2::assert_chi2(&format!("phong n={n} θ={deg}"), &grid, 500_000, &mut sample, &pdf);
    }
}

/// GGX at α = 1e-3 (a white metal of roughness √1e-3) up to 89°, binned by half vector.
/// Catches D written with tan²θ = (1 − cos²θ)/cos²θ: at α = 1e-3 the half vectors lie within
/// ~1e-3 rad of the normal, where 1 − cos²θ is pure f32 rounding.
#[test]
fn chi2_ggx_alpha_1e_minus3_at_grazing_incidence() {
    let mut rng = Rng::new(108);
    let roughness = 1e-3f32.sqrt();
    let b = Bsdf::Pbr(Pbr::new(Vec3::ONE, 1.0, roughness));
    for deg in [0.0, 60.0, 89.0] {
        check::chi2(&format!("ggx α=1e-3 θ={deg}"), &b, dir(deg), Domain::Half(1e-3), &mut rng);
    }
}
