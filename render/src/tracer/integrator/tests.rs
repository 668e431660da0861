//! Analytic checks of every estimator. Tolerances are 4σ of the estimate, with σ measured from
//! the samples themselves (independent sampler, so the samples are i.i.d. and σ²/n is the
//! variance of the mean).
use super::*;
use crate::tracer::RenderOptions;
use crate::tracer::camera::Camera;
use crate::tracer::film::{PixelSums, Tile};
use crate::tracer::material::Material;
use crate::tracer::render::{RenderSettings, render_tile};
use crate::tracer::sampler::SamplerKind;
use crate::tracer::scene::Mesh;
use glam::{Mat4, Vec3};

/// Pools every sample of a render: (mean luminance-free per-channel mean of channel 0, σ of that mean).
pub(crate) fn pooled(pixels: &[PixelSums]) -> (f64, f64) {
    let (mut s, mut s2, mut n) = (0.0, 0.0, 0.0);
    for p in pixels {
        s += p.sum[0];
        s2 += p.sum_sq[0];
        n += p.count as f64;
    }
    let mean = s / n;
    let var = (s2 / n - mean * mean).max(0.0) * n / (n - 1.0);
    (mean, (var / n).sqrt())
}

pub(crate) fn quad(mesh: &mut Mesh, c: Vec3, u: Vec3, v: Vec3, material: u32) {
    // Counter-clockwise seen from the side u × v points to.
    let (a, b, d, e) = (c - u - v, c + u - v, c + u + v, c - u + v);
    mesh.push_flat([a, b, d], material);
    mesh.push_flat([a, d, e], material);
}

pub(crate) fn camera_at(eye: Vec3, target: Vec3, yfov: f32) -> Camera {
    let f = (target - eye).normalize();
    let up = if f.cross(Vec3::Y).length() < 1e-6 { Vec3::Z } else { Vec3::Y };
    let right = f.cross(up).normalize();
    let to_world = Mat4::from_cols(
        right.extend(0.0),
        right.cross(f).extend(0.0),
        (-f).extend(0.0),
        eye.extend(1.0),
    );
    Camera::pinhole("test", to_world, yfov)
}

pub(crate) fn settings(
    estimator: Estimator,
    roulette: Roulette,
    size: u32,
    background: Vec3,
) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        seed: 7,
        sampler: SamplerKind::Independent,
        path: PathSettings { estimator, roulette, ..PathSettings::default() },
        background,
        camera: None,
    }
}

/// [`settings`] with the light chosen by `light_sampler`.
fn settings_choosing(
    light_sampler: LightSampler,
    estimator: Estimator,
    size: u32,
) -> RenderSettings {
    let mut s = settings(estimator, Roulette::default(), size, Vec3::ZERO);
    s.path.light_sampler = light_sampler;
    s
}

pub(crate) fn render(scene: &Scene, s: &RenderSettings, spp: u32) -> Vec<PixelSums> {
    render_tile(scene, s, s.full_frame(), 0..spp, &RenderOptions::default()).expect("render").pixels
}

pub(crate) fn assert_within_4_sigma(what: &str, got: (f64, f64), expected: f64) {
    let (mean, sigma) = got;
    assert!(sigma > 0.0 || mean == expected, "{what}: no variance measured");
    assert!(
        (mean - expected).abs() <= 4.0 * sigma + 1e-6 * expected,
        "{what}: {mean} vs {expected} (σ {sigma})"
    );
}

/// A closed cube of side 2 with inward faces, Lambert albedo `rho`, emitting `le` everywhere.
pub(crate) fn furnace(rho: f32, le: f32) -> Scene {
    let mut mesh = Mesh::default();
    for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
        let (u, v) = (axis.any_orthonormal_vector(), axis.cross(axis.any_orthonormal_vector()));
        // Inward normals: the face at +axis looks towards −axis.
        quad(&mut mesh, axis, v, u, 0);
        quad(&mut mesh, -axis, u, v, 0);
    }
    let mut m = Material::lambert("wall", Vec3::splat(rho));
    m.emission = Vec3::splat(le);
    Scene::new(
        mesh,
        vec![m],
        vec![],
        vec![camera_at(Vec3::new(0.1, 0.2, 0.3), Vec3::new(1.0, 0.5, -2.0), 1.2)],
        vec![],
    )
}

#[test]
fn furnace_faces_point_inwards() {
    let scene = furnace(0.5, 1.0);
    for tri in &scene.mesh.positions {
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        let centre = (tri[0] + tri[1] + tri[2]) / 3.0;
        assert!(n.dot(centre) < 0.0, "face at {centre} must face the inside");
    }
}

#[test]
fn white_furnace_every_estimator_with_and_without_roulette() {
    let (rho, le) = (0.6, 0.2);
    let scene = furnace(rho, le);
    let expected = (le / (1.0 - rho)) as f64;
    let roulettes = [
        Roulette::Off,
        Roulette::Throughput { min_depth: 1 },
        Roulette::Threshold { threshold: 0.5, p: 0.5 },
    ];
    for est in Estimator::ALL {
        for rr in roulettes {
            let got = pooled(&render(&scene, &settings(est, rr, 8, Vec3::ZERO), 64));
            assert_within_4_sigma(&format!("{est:?} {rr:?}"), got, expected);
        }
    }
    // Its 12 emitting faces chosen through a light tree (from inside every bounding sphere).
    for est in [Estimator::Light, Estimator::Mis] {
        let s = settings_choosing(LightSampler::Tree, est, 8);
        assert_within_4_sigma(
            &format!("{est:?} through the tree"),
            pooled(&render(&scene, &s, 64)),
            expected,
        );
    }
}

#[test]
fn lambert_plane_under_a_uniform_background_reflects_rho_times_lb() {
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::ZERO, Vec3::X * 1e3, Vec3::NEG_Z * 1e3, 0);
    let rho = 0.7;
    let scene = Scene::new(
        mesh,
        vec![Material::lambert("ground", Vec3::splat(rho))],
        vec![],
        vec![camera_at(Vec3::Y, Vec3::ZERO, 0.5)],
        vec![],
    );
    let lb = 2.0;
    for est in Estimator::ALL {
        let got =
            pooled(&render(&scene, &settings(est, Roulette::default(), 8, Vec3::splat(lb)), 64));
        assert_within_4_sigma(&format!("{est:?}"), got, (rho * lb) as f64);
    }
}

/// Irradiance at `x` (normal `n`) from a uniform polygon of radiance `le` (Lambert's formula).
pub(crate) fn polygon_irradiance(x: Vec3, n: Vec3, poly: &[Vec3], le: f64) -> f64 {
    let mut sum = 0.0f64;
    for i in 0..poly.len() {
        let a = (poly[i] - x).as_dvec3().normalize();
        let b = (poly[(i + 1) % poly.len()] - x).as_dvec3().normalize();
        let theta = a.dot(b).clamp(-1.0, 1.0).acos();
        sum += theta * n.as_dvec3().dot(a.cross(b).normalize());
    }
    0.5 * le * sum.abs()
}

#[test]
fn small_quad_light_irradiance_matches_the_polygon_formula() {
    let (rho, le) = (0.8f32, 5.0f32);
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::ZERO, Vec3::X * 10.0, Vec3::NEG_Z * 10.0, 0); // receiver, facing +Y
    let light_c = Vec3::new(0.3, 1.0, -0.2);
    let (lu, lv) = (Vec3::X * 0.25, Vec3::Z * 0.25);
    quad(&mut mesh, light_c, lu, lv, 1); // facing −Y (x × z = −y)
    let mut light = Material::lambert("light", Vec3::ZERO);
    light.emission = Vec3::splat(le);
    let x = Vec3::ZERO;
    // A narrow camera between the light and the floor, looking at x.
    let cam = camera_at(Vec3::new(0.0, 0.5, 0.0), x, 1e-3);
    let scene = Scene::new(
        mesh,
        vec![Material::lambert("floor", Vec3::splat(rho)), light],
        vec![],
        vec![cam],
        vec![],
    );
    let poly = [light_c - lu - lv, light_c + lu - lv, light_c + lu + lv, light_c - lu + lv];
    let expected =
        rho as f64 / std::f64::consts::PI * polygon_irradiance(x, Vec3::Y, &poly, le as f64);
    for est in Estimator::ALL {
        let spp = if est == Estimator::Mis || est == Estimator::Light { 256 } else { 4096 };
        let got = pooled(&render(&scene, &settings(est, Roulette::default(), 4, Vec3::ZERO), spp));
        assert_within_4_sigma(&format!("{est:?}"), got, expected);
    }
    for (est, sampler) in [Estimator::Light, Estimator::Mis]
        .into_iter()
        .flat_map(|e| [(e, LightSampler::Power), (e, LightSampler::Tree)])
    {
        let s = settings_choosing(sampler, est, 4);
        assert_within_4_sigma(
            &format!("{est:?} {sampler:?}"),
            pooled(&render(&scene, &s, 256)),
            expected,
        );
    }
    let with = |sampler| render(&scene, &settings_choosing(sampler, Estimator::Light, 4), 16);
    assert_ne!(
        with(LightSampler::Power),
        with(LightSampler::Tree),
        "the job's light sampler reaches the light samples"
    );
}

#[test]
fn a_unit_is_bit_identical_across_thread_counts_and_repeats() {
    let scene = furnace(0.6, 0.2);
    let s = RenderSettings {
        sampler: SamplerKind::Sobol,
        ..settings(Estimator::Mis, Roulette::default(), 16, Vec3::ZERO)
    };
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            render_tile(
                &scene,
                &s,
                Tile { x0: 3, y0: 2, w: 9, h: 7 },
                5..21,
                &RenderOptions::default(),
            )
            .unwrap()
        })
    };
    let one = run(1);
    assert_eq!(one, run(2));
    assert_eq!(one, run(1));
}

#[test]
fn merged_sample_ranges_equal_one_range_whatever_the_tile_split() {
    let scene = furnace(0.6, 0.2);
    let s = settings(Estimator::Mis, Roulette::default(), 6, Vec3::ZERO);
    let whole = render_tile(&scene, &s, s.full_frame(), 0..128, &RenderOptions::default()).unwrap();
    for columns in [[(0, 6), (6, 0)], [(0, 2), (2, 4)]] {
        let mut frame = vec![PixelSums::default(); 36];
        for (x0, w) in columns.into_iter().filter(|c| c.1 > 0) {
            for range in [0..64, 64..128] {
                render_tile(
                    &scene,
                    &s,
                    Tile { x0, y0: 0, w, h: 6 },
                    range,
                    &RenderOptions::default(),
                )
                .unwrap()
                .add_into_frame(&mut frame, 6);
            }
        }
        for (a, b) in whole.pixels.iter().zip(&frame) {
            assert_eq!(a.count, b.count);
            for c in 0..3 {
                assert!(
                    (a.sum[c] - b.sum[c]).abs() <= 1e-12 * a.sum[c].abs(),
                    "{} vs {}",
                    a.sum[c],
                    b.sum[c]
                );
                assert!((a.sum_sq[c] - b.sum_sq[c]).abs() <= 1e-12 * a.sum_sq[c].abs());
            }
        }
    }
}
mod mis;
