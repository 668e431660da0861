//! Case 9: zero-area and needle triangles, emissive ones included.
use crate::tracer::RenderOptions;
use crate::tracer::accel::triangle_normal;
use crate::tracer::integrator::tests::{camera_at, quad, settings};
use crate::tracer::integrator::{Estimator, Roulette};
use crate::tracer::light::Light;
use crate::tracer::material::Material;
use crate::tracer::ray::Ray;
use crate::tracer::render::render_tile;
use crate::tracer::scene::{Mesh, NO_LIGHT, Scene};
use glam::Vec3;

/// A floor under a quad light, seen from above: 4 triangles.
fn lit_floor() -> Mesh {
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::ZERO, Vec3::X, Vec3::NEG_Z, 0);
    quad(&mut mesh, Vec3::new(0.1, 0.8, 0.0), Vec3::X * 0.3, Vec3::Z * 0.3, 1);
    mesh
}

/// Zero-area (collinear, repeated and single-point) and needle triangles, on the floor and
/// inside the light, half of them emissive. Needles are 1e-9 wide at coordinates ~0.5: below
/// half an f32 ulp there.
fn degenerates() -> Vec<[Vec3; 3]> {
    let (a, b) = (Vec3::new(-0.4, 0.0, 0.3), Vec3::new(0.5, 0.0, -0.2));
    let (la, lb) = (Vec3::new(-0.1, 0.8, -0.2), Vec3::new(0.3, 0.8, 0.2));
    let needle = |p: Vec3, q: Vec3, across: Vec3| [p, q, (p + q) * 0.5 + across * 1e-9];
    vec![
        [a, b, a + (b - a) * 2.0],
        [a, a, b],
        [b, b, b],
        needle(a, b, Vec3::Z),
        needle(a, b, Vec3::Y),
        [la, lb, la + (lb - la) * 0.5],
        needle(la, lb, Vec3::X),
        needle(lb, la, Vec3::NEG_Y),
    ]
}

fn scene(extra: &[[Vec3; 3]]) -> Scene {
    let mut mesh = lit_floor();
    for (k, t) in extra.iter().enumerate() {
        mesh.push_flat(*t, (k % 2) as u32);
    }
    let mut light = Material::lambert("light", Vec3::ZERO);
    light.emission = Vec3::splat(5.0);
    let camera = camera_at(Vec3::new(0.0, 2.0, 0.5), Vec3::ZERO, 1.0);
    Scene::new(
        mesh,
        vec![Material::lambert("floor", Vec3::splat(0.8)), light],
        vec![],
        vec![camera],
        vec![],
    )
}

#[test]
fn degenerate_triangles_are_neither_lights_nor_hit() {
    let s = scene(&degenerates());
    for (k, t) in degenerates().iter().enumerate() {
        let i = 4 + k;
        assert!(triangle_normal(t).is_none(), "triangle {k} should count as degenerate");
        assert!(Light::triangle(i as u32, t, Vec3::ONE, true).is_none());
        assert_eq!(s.tri_light[i], NO_LIGHT);
        // Aim at its corners and midpoints, from above and from the side: never this triangle.
        let targets = [
            t[0],
            t[1],
            t[2],
            (t[0] + t[1]) * 0.5,
            (t[1] + t[2]) * 0.5,
            (t[0] + t[1] + t[2]) / 3.0,
        ];
        for target in targets {
            for from in
                [Vec3::new(0.01, 3.0, 0.02), Vec3::new(2.0, 0.4, 1.0), Vec3::new(-1.0, -2.0, 0.3)]
            {
                let hit = s.accel.intersect(&Ray::new(from, target - from), f32::INFINITY);
                assert!(
                    hit.is_none_or(|h| h.prim < 4),
                    "false hit on degenerate triangle {k}: {hit:?}"
                );
            }
        }
    }
    assert_eq!(s.lights.len(), 2, "only the light quad's two triangles emit");
}

/// Adding the degenerate triangles leaves the image bit for bit unchanged, with no dropped
/// sample. Catches lights and BVH leaves made of them: a needle's f32 cross product gives a
/// light of tiny but non-zero power (shifting every light's choice probability) and a
/// NaN-prone normal, and rounding in the hit test can report hits on it.
#[test]
fn degenerate_triangles_leave_the_image_unchanged() {
    let s = settings(Estimator::Mis, Roulette::default(), 16, Vec3::splat(0.1));
    let clean =
        render_tile(&scene(&[]), &s, s.full_frame(), 0..32, &RenderOptions::default()).unwrap();
    let dirty =
        render_tile(&scene(&degenerates()), &s, s.full_frame(), 0..32, &RenderOptions::default())
            .unwrap();
    assert_eq!(dirty.dropped, 0);
    assert!(dirty.pixels.iter().all(|p| p.sum.iter().all(|v| v.is_finite())));
    assert!(clean.pixels.iter().any(|p| p.sum[0] > 0.0));
    assert_eq!((clean.dropped, clean.max_weight), (dirty.dropped, dirty.max_weight));
    if let Some(i) = (0..clean.pixels.len()).find(|&i| clean.pixels[i] != dirty.pixels[i]) {
        panic!("pixel {i} changed: {:?} vs {:?}", clean.pixels[i], dirty.pixels[i]);
    }
}
