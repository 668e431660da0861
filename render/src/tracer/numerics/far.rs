//! Case 2, tracer side: error-bound offsets alone keep a closed box built in f32 at 1e4 and
//! 1e5 from the origin energy-conserving. (Beyond that, hit points round by more than the
//! box's corners can absorb: the loader moves far scenes to the origin in f64 first, tested
//! with bundled scenes at 1e4 … 1e6 in `scene::tests::far`.)
use crate::tracer::integrator::tests::{assert_within_4_sigma, furnace, pooled, render, settings};
use crate::tracer::integrator::{Estimator, Roulette};
use crate::tracer::light::Light;
use crate::tracer::scene::Scene;
use glam::{Mat4, Vec3};

/// The same scene moved by `offset` (geometry, cameras and punctual lights).
fn translated(scene: &Scene, offset: Vec3) -> Scene {
    let mut mesh = scene.mesh.clone();
    mesh.positions.iter_mut().flatten().for_each(|p| *p += offset);
    let mut cameras = scene.cameras.clone();
    for c in &mut cameras {
        c.to_world = Mat4::from_translation(offset) * c.to_world;
    }
    let punctual = scene.lights.iter().filter(|l| !matches!(l, Light::Triangle { .. })).map(|l| {
        let mut l = l.clone();
        if let Light::Point { position, .. } | Light::Spot { position, .. } = &mut l {
            *position += offset;
        }
        l
    });
    Scene::new(mesh, scene.materials.clone(), scene.textures.clone(), cameras, punctual.collect())
}

/// A closed Lambert box (side 2) built 1e4 and 1e5 away renders Le/(1 − ρ) within 4σ.
/// Catches a fixed-epsilon ray offset: at 1e5 the hit points' rounding (~0.01) exceeds any
/// epsilon that works near the origin, rays restart behind the wall, see its black back
/// face and the box loses energy.
#[test]
fn closed_furnace_far_from_the_origin_keeps_its_radiance() {
    let (rho, le) = (0.5, 0.25);
    let base = furnace(rho, le);
    for offset in [1e4f32, 1e5] {
        let scene = translated(&base, Vec3::new(offset, -0.7 * offset, 0.3 * offset));
        let s = settings(Estimator::Mis, Roulette::default(), 8, Vec3::ZERO);
        let got = pooled(&render(&scene, &s, 64));
        assert_within_4_sigma(&format!("furnace at {offset:e}"), got, (le / (1.0 - rho)) as f64);
    }
}
