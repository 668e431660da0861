//! Cases 5 and 6: tiny, distant and grazing lights. (Case 10, MIS bounds, needs the
//! integrator's internals: `integrator/tests/mis.rs`.)
use crate::tracer::RenderOptions;
use crate::tracer::chi2::Rng;
use crate::tracer::integrator::tests::{
    camera_at, polygon_irradiance, pooled, quad, render, settings,
};
use crate::tracer::integrator::{Estimator, Roulette};
use crate::tracer::light::{Light, LightSet};
use crate::tracer::material::Material;
use crate::tracer::scene::{Mesh, Scene};
use glam::{DVec3, Vec3};

/// Irradiance at `p` (normal `n`) estimated by light sampling alone, ignoring visibility:
/// (mean, standard error), and whether every sample was finite.
fn irradiance(set: &LightSet, p: Vec3, n: Vec3, samples: usize, rng: &mut Rng) -> (f64, f64) {
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..samples {
        let v = set.sample(p, n, rng.vec2()).map_or(0.0, |ls| {
            let v = ls.li.x * n.dot(ls.wi).max(0.0) / ls.pdf;
            assert!(v.is_finite() && ls.pdf.is_finite(), "non-finite light sample {ls:?}");
            v as f64
        });
        (s, s2) = (s + v, s2 + v * v);
    }
    let mean = s / samples as f64;
    (mean, ((s2 / samples as f64 - mean * mean).max(0.0) / samples as f64).sqrt())
}

/// A light triangle of area 1e-12 at the origin, facing +Y.
fn speck(radiance: f32) -> ([Vec3; 3], Light) {
    let s = (2e-12f32).sqrt();
    let v = [Vec3::ZERO, Vec3::new(s, 0.0, 0.0), Vec3::new(0.0, 0.0, -s)];
    (v, Light::triangle(0, &v, Vec3::splat(radiance), false).expect("a real light"))
}

/// Case 5. An emitter of area 1e-12 seen from 1e4 away (pdf ~1e20 per steradian) gives
/// E = L·A·cos·cos/d² within 0.5 %, through the light sampler and through a full MIS render.
/// Catches the textbook power heuristic f²/(f² + g²), whose f² overflows to ∞/∞ = NaN, and
/// areas or normals computed from f32 cross products that underflow.
#[test]
fn speck_of_light_1e4_away_gives_closed_form_irradiance() {
    let (v, light) = speck(3.0);
    let lights = [light];
    let set = LightSet::new(&lights, Vec3::ZERO, 1e4);
    let mut rng = Rng::new(105);
    let area = 1e-12f64;
    for p in [Vec3::new(0.0, 1e4, 0.0), Vec3::new(3e3, 8e3, -2e3)] {
        let n = -p.normalize();
        let c = (v[0] + v[1] + v[2]).as_dvec3() / 3.0;
        let d = p.as_dvec3() - c;
        let expected =
            3.0 * area * d.normalize().y * n.as_dvec3().dot(-d.normalize()) / d.length_squared();
        let (got, _) = irradiance(&set, p, n, 1000, &mut rng);
        assert!((got / expected - 1.0).abs() < 5e-3, "at {p}: {got:e} vs {expected:e}");
    }
    // Rendered: a Lambert ceiling 1e4 above the speck, seen from just below it.
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::new(0.0, 1e4, 0.0), Vec3::X * 10.0, Vec3::Z * 10.0, 0);
    mesh.push_flat(v, 1);
    let mut emitter = Material::lambert("speck", Vec3::ZERO);
    emitter.emission = Vec3::splat(3.0);
    let cam = camera_at(Vec3::new(0.0, 1e4 - 1.0, 0.0), Vec3::new(0.0, 1e4, 0.0), 1e-3);
    let scene = Scene::new(
        mesh,
        vec![Material::lambert("ceiling", Vec3::splat(0.8)), emitter],
        vec![],
        vec![cam],
        vec![],
    );
    let expected = 0.8 / std::f64::consts::PI * 3.0 * area / 1e8;
    for est in [Estimator::Mis, Estimator::Light] {
        let s = settings(est, Roulette::default(), 2, Vec3::ZERO);
        let sums = crate::tracer::render::render_tile(
            &scene,
            &s,
            s.full_frame(),
            0..64,
            &RenderOptions::default(),
        )
        .unwrap();
        assert_eq!(sums.dropped, 0, "{est:?}: non-finite samples");
        let (mean, _) = pooled(&sums.pixels);
        assert!((mean / expected - 1.0).abs() < 5e-3, "{est:?}: {mean:e} vs {expected:e}");
    }
}

/// Case 5, the seed's case: a small quad light that BSDF sampling rarely hits, lighting a
/// floor, renders the polygon formula's radiance within 0.5 % (MIS, 4σ < 0.5 %).
#[test]
fn small_light_rarely_hit_renders_within_half_a_percent() {
    let (rho, le) = (0.8f32, 5.0f32);
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::ZERO, Vec3::X * 10.0, Vec3::NEG_Z * 10.0, 0);
    let (c, lu, lv) = (Vec3::new(0.3, 1.0, -0.2), Vec3::X * 0.1, Vec3::Z * 0.1);
    quad(&mut mesh, c, lu, lv, 1);
    let mut light = Material::lambert("light", Vec3::ZERO);
    light.emission = Vec3::splat(le);
    let cam = camera_at(Vec3::new(0.0, 0.5, 0.0), Vec3::ZERO, 1e-3);
    let scene = Scene::new(
        mesh,
        vec![Material::lambert("floor", Vec3::splat(rho)), light],
        vec![],
        vec![cam],
        vec![],
    );
    let poly = [c - lu - lv, c + lu - lv, c + lu + lv, c - lu + lv];
    let expected = rho as f64 / std::f64::consts::PI
        * polygon_irradiance(Vec3::ZERO, Vec3::Y, &poly, le as f64);
    let (mean, sigma) = pooled(&render(
        &scene,
        &settings(Estimator::Mis, Roulette::default(), 4, Vec3::ZERO),
        4096,
    ));
    assert!(4.0 * sigma < 5e-3 * expected, "too noisy to decide: σ {sigma:e}");
    assert!((mean / expected - 1.0).abs() < 5e-3, "{mean} vs {expected} (σ {sigma:e})");
}

/// Case 6. A one-sided quad light (facing +Y, in the plane y = 0.3) and a receiver beside
/// it facing the light, at heights 1e-1 … 1e-5 above the light's plane: light sampling
/// matches the polygon formula within 4σ; exactly in the plane every sample is exactly 0.
/// Catches the cosine at the light taken from the sampled point (−n·wi): rounding of that
/// point (~3e-8 at y = 0.3) gives in-plane receivers light and near-plane ones a wrong sign.
#[test]
fn grazing_receivers_match_polygon_irradiance_and_in_plane_is_exactly_zero() {
    let y = 0.3f32;
    let (c, u, v) = (Vec3::new(0.0, y, 0.0), Vec3::X * 0.5, Vec3::NEG_Z * 0.5);
    let poly = [c - u - v, c + u - v, c + u + v, c - u + v];
    let lights: Vec<Light> = [[poly[0], poly[1], poly[2]], [poly[0], poly[2], poly[3]]]
        .iter()
        .map(|t| Light::triangle(0, t, Vec3::ONE, false).expect("light"))
        .collect();
    assert!(matches!(lights[0], Light::Triangle { n, .. } if n == Vec3::Y));
    let set = LightSet::new(&lights, Vec3::ZERO, 1.0);
    let mut rng = Rng::new(106);
    let n = Vec3::NEG_X;
    for h in [1e-1f32, 1e-2, 1e-3, 1e-4, 1e-5] {
        let p = Vec3::new(0.7, y + h, 0.1);
        let expected = polygon_irradiance(p, n, &poly, 1.0);
        let (got, sigma) = irradiance(&set, p, n, 400_000, &mut rng);
        assert!(expected > 0.0 && sigma > 0.0);
        assert!(
            (got - expected).abs() <= 4.0 * sigma,
            "h={h}: {got:e} vs {expected:e} (σ {sigma:e})"
        );
    }
    for p in [Vec3::new(0.7, y, 0.1), Vec3::new(0.500_001, y, -0.3), Vec3::new(3.0, y, 2.0)] {
        for _ in 0..100_000 {
            if let Some(ls) = set.sample(p, n, rng.vec2()) {
                panic!("receiver in the light's plane at {p} got a sample {ls:?}");
            }
        }
    }
}

#[test]
fn polygon_formula_is_linear_in_height_near_the_plane() {
    // A sanity check of the reference itself at the heights used above.
    let poly = [
        DVec3::new(-0.5, 0.0, -0.5),
        DVec3::new(0.5, 0.0, -0.5),
        DVec3::new(0.5, 0.0, 0.5),
        DVec3::new(-0.5, 0.0, 0.5),
    ]
    .map(|d| d.as_vec3());
    let e = |h: f32| polygon_irradiance(Vec3::new(0.7, h, 0.0), Vec3::NEG_X, &poly, 1.0);
    let (a, b) = (e(1e-4), e(1e-5));
    assert!((a / b / 10.0 - 1.0).abs() < 1e-3, "{a:e} {b:e}");
}
