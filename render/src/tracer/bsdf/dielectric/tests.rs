use super::*;
use crate::tracer::bsdf::check::dir;
use crate::tracer::chi2::Rng;

#[test]
fn fresnel_at_normal_incidence_is_the_textbook_value_and_total_reflection_happens() {
    for eta in [1.33f32, 1.5, 2.4] {
        let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
        assert!((fresnel(1.0, eta) - r0).abs() < 1e-6);
        assert!((fresnel(-1.0, eta) - r0).abs() < 1e-6, "same from inside");
    }
    // Inside glass (1.5) beyond the critical angle asin(1/1.5) ≈ 41.8°.
    assert_eq!(fresnel(-(50f32.to_radians().cos()), 1.5), 1.0);
}

#[test]
fn smooth_glass_splits_head_on_light_into_r_and_t() {
    let d = Dielectric { eta: 1.5, alpha: 0.0, tint: Vec3::ONE, thin: false };
    let r0 = fresnel(1.0, 1.5);
    let refl = d.sample(Vec3::Z, 0.0, Vec2::ZERO).unwrap();
    assert!(refl.specular && (refl.wi - Vec3::Z).length() < 1e-6 && (refl.pdf - r0).abs() < 1e-6);
    let tr = d.sample(Vec3::Z, 0.99, Vec2::ZERO).unwrap();
    assert!((tr.wi + Vec3::Z).length() < 1e-6, "straight through at normal incidence");
    // Path weight f·|cos|/pdf = 1/η² (radiance is compressed entering the denser medium).
    let w = tr.f * tr.wi.z.abs() / tr.pdf;
    assert!((w - Vec3::splat(1.0 / 2.25)).abs().max_element() < 1e-5, "{w}");
}

#[test]
fn thin_glass_passes_straight_through_with_the_slab_transmittance() {
    let d = Dielectric { eta: 1.5, alpha: 0.0, tint: Vec3::ONE, thin: true };
    let wo = dir(30.0);
    let r = fresnel(1.0, 1.5);
    let head_on = d.sample(Vec3::Z, 0.99, Vec2::ZERO).unwrap();
    assert!(((1.0 - head_on.pdf) - 2.0 * r / (1.0 + r)).abs() < 1e-6, "R' = 2R/(1+R)");
    let t = d.sample(wo, 0.999, Vec2::ZERO).unwrap();
    assert!((t.wi + wo).length() < 1e-6);
}

#[test]
fn rough_glass_samples_agree_with_eval_and_pdf_on_both_sides() {
    let mut rng = Rng::new(5);
    for (eta, alpha) in [(1.5, 0.3), (1.0 / 1.5, 0.3), (1.5, 0.05)] {
        let d = Dielectric { eta, alpha, tint: Vec3::ONE, thin: false };
        let mut transmitted = 0;
        for deg in [0.0, 30.0, 60.0, 85.0] {
            for _ in 0..4000 {
                let wo = dir(deg);
                let Some(s) = d.sample(wo, rng.f32(), rng.vec2()) else { continue };
                transmitted += (s.wi.z < 0.0) as u32;
                let (f, pdf) = (d.eval(wo, s.wi), d.pdf(wo, s.wi));
                assert!(
                    (s.f - f).abs().max_element() <= 1e-3 * f.max_element().max(1e-3),
                    "{s:?} vs {f}"
                );
                assert!((s.pdf - pdf).abs() <= 1e-3 * pdf.max(1e-3), "{s:?} vs {pdf}");
            }
        }
        assert!(transmitted > 1000, "η {eta}: {transmitted} transmissions");
    }
}

#[test]
fn rough_glass_conserves_energy_counting_transmitted_flux() {
    // ∫ f |cos| over both hemispheres, with transmitted radiance scaled back by η² to flux,
    // is ≤ 1 (single scattering loses a little at high roughness) and close to 1 when smooth-ish.
    let mut rng = Rng::new(9);
    let d = Dielectric { eta: 1.5, alpha: 0.1, tint: Vec3::ONE, thin: false };
    for deg in [0.0, 45.0] {
        let n = 100_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            if let Some(s) = d.sample(dir(deg), rng.f32(), rng.vec2()) {
                let flux = if s.wi.z < 0.0 { 2.25 } else { 1.0 };
                sum += (s.f.x * s.wi.z.abs() / s.pdf * flux) as f64;
            }
        }
        let albedo = sum / n as f64;
        assert!(albedo > 0.95 && albedo < 1.01, "{deg}°: {albedo}");
    }
}
