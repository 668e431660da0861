//! Case 10: MIS bounds where a Lambert floor touches an emitter.
use super::super::*;
use crate::tracer::chi2::Rng;
use crate::tracer::integrator::tests::{camera_at, quad};
use crate::tracer::material::Material;
use crate::tracer::scene::Mesh;

/// A Lambert floor (ρ = 0.8, y = 0) and a wall light (x = 0, radiance 4, facing −x) standing on it.
fn touching() -> Scene {
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::new(-1.0, 0.0, 0.0), Vec3::X, Vec3::NEG_Z, 0);
    quad(&mut mesh, Vec3::new(0.0, 0.5, 0.0), Vec3::Z, Vec3::Y * 0.5, 1);
    let mut light = Material::lambert("light", Vec3::ZERO);
    light.emission = Vec3::splat(4.0);
    let cam = camera_at(Vec3::new(-1.0, 1.0, 0.0), Vec3::ZERO, 0.5);
    Scene::new(
        mesh,
        vec![Material::lambert("floor", Vec3::splat(0.8)), light],
        vec![],
        vec![cam],
        vec![],
    )
}

/// With the power heuristic a light sample contributes f·L·cos·p_l/(p_l² + p_b²) ≤
/// f·L·cos/(2 p_b) = ρL/2 for a Lambert surface (p_b = cos/π), however close the light. On
/// floor points 1e-1 … 1e-6 from the contact line no light sample exceeds that bound (up to
/// f32 rounding), while the same samples without MIS weights do — by orders of magnitude:
/// the fireflies the bound prevents. Catches the balance heuristic (bound ρL) and unweighted
/// light samples.
#[test]
fn no_light_sample_exceeds_the_power_heuristic_bound_next_to_an_emitter() {
    let scene = touching();
    assert_eq!(scene.face_normals[2], Vec3::NEG_X, "the light must face the floor");
    let integrator = Integrator::new(&scene, Vec3::ZERO, PathSettings::default());
    let bound = 0.5 * 0.8 * 4.0;
    let mut rng = Rng::new(110);
    let (mut lit, mut unweighted_max) = (0, 0.0f32);
    for d in [1e-1f32, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6] {
        let x = Vec3::new(-d, 0.0, 0.3);
        let s = integrator
            .surface::<AllEffects>(&Ray::new(x + Vec3::Y, Vec3::NEG_Y), 0.0)
            .expect("the floor");
        let bsdf = s.bsdf.expect("a Lambert floor");
        for _ in 0..20_000 {
            let u = rng.vec2();
            let c =
                integrator.direct::<AllEffects>(Estimator::Mis, &s, &bsdf, Vec3::ZERO, u, &mut 0);
            assert!(
                c.is_finite() && c.max_element() <= bound * (1.0 + 1e-5),
                "d={d}: {c} > ρL/2 = {bound}"
            );
            lit += (c.x > 0.0) as u32;
            let raw =
                integrator.direct::<AllEffects>(Estimator::Light, &s, &bsdf, Vec3::ZERO, u, &mut 0);
            unweighted_max = unweighted_max.max(raw.x);
        }
    }
    assert!(lit > 50_000, "most light samples should arrive ({lit})");
    assert!(
        unweighted_max > 100.0 * bound,
        "without MIS the same samples must break the bound ({unweighted_max})"
    );
}
