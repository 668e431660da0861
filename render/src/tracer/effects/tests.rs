//! Each effect changes the image as physics says. Tolerances are 4σ of the pooled estimate
//! (independent sampler, σ measured from the samples).
use crate::tracer::RenderOptions;
use crate::tracer::effects::Effects;
use crate::tracer::integrator::tests::{
    assert_within_4_sigma, camera_at, pooled, quad, render, settings,
};
use crate::tracer::integrator::{Estimator, Roulette};
use crate::tracer::kernel::KernelBits;
use crate::tracer::material::{Glass, Material};
use crate::tracer::scene::{Mesh, Scene};
use glam::{Vec3, Vec4};

/// A box of glass, `t` thick in z around z = −1, 4 m wide, in front of an emitter (radiance 1,
/// black, facing +z) at z = −3; the camera at the origin looks down −z through it.
fn slab_scene(glass: Option<Glass>, t: f32) -> Scene {
    tinted_slab_scene(glass, t, Vec3::ONE)
}

/// [`slab_scene`] with glass of base colour `tint` (each refraction transmits `tint`).
fn tinted_slab_scene(glass: Option<Glass>, t: f32, tint: Vec3) -> Scene {
    let mut mesh = Mesh::default();
    let (x, y, z) = (Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z * (t / 2.0));
    let c = Vec3::new(0.0, 0.0, -1.0);
    quad(&mut mesh, c + z, x, y, 0);
    if glass.is_some_and(|g| !g.thin) {
        quad(&mut mesh, c - z, y, x, 0);
        quad(&mut mesh, c + x, y, z, 0);
        quad(&mut mesh, c - x, z, y, 0);
        quad(&mut mesh, c + y, z, x, 0);
        quad(&mut mesh, c - y, x, z, 0);
    }
    quad(&mut mesh, Vec3::new(0.0, 0.0, -3.0), x * 2.0, y * 2.0, 1);
    let glass_material = Material { glass, ..Material::lambert("glass", tint) };
    let light = Material { emission: Vec3::ONE, ..Material::lambert("light", Vec3::ZERO) };
    let cam = camera_at(Vec3::ZERO, Vec3::NEG_Z, 0.05);
    Scene::new(mesh, vec![glass_material, light], vec![], vec![cam], vec![])
}

fn clear(thin: bool, sigma_a: Vec3) -> Glass {
    Glass { weight: 1.0, ior: 1.5, alpha: 0.0, thin, sigma_a }
}

fn head_on(scene: &Scene, est: Estimator) -> (f64, f64) {
    pooled(&render(scene, &settings(est, Roulette::default(), 4, Vec3::ZERO), 4096))
}

#[test]
fn a_glass_slab_transmits_the_fresnel_slab_transmittance_at_normal_incidence() {
    // Two interfaces with every internal reflection: T = (1 − R)/(1 + R), R = ((η−1)/(η+1))².
    let r = 0.04f64;
    for thin in [false, true] {
        let scene = slab_scene(Some(clear(thin, Vec3::ZERO)), 0.2);
        assert!(
            scene.effects.contains(Effects::GLASS) && !scene.effects.contains(Effects::ABSORPTION)
        );
        for est in [Estimator::Mis, Estimator::Bsdf, Estimator::Light] {
            assert_within_4_sigma(
                &format!("thin {thin} {est:?}"),
                head_on(&scene, est),
                (1.0 - r) / (1.0 + r),
            );
        }
    }
    // Without glass the wall is opaque white Lambert facing away from the light: black.
    assert_eq!(head_on(&slab_scene(None, 0.2), Estimator::Mis).0, 0.0);
}

/// Refraction into glass divides radiance by η² and leaving multiplies it back, so a clear
/// slab loses a path nothing but its Fresnel reflections. With roulette from the first bounce,
/// a head-on camera sample through it is exactly 0 (reflected away) or 1 (through), so the sum
/// of squares equals the sum. Roulette judging β alone (0.44 inside the glass) would end 56 %
/// of paths there and weight the survivors 2.25: sum of squares ≈ 2.25 × sum.
#[test]
fn roulette_does_not_mistake_refraction_for_absorption() {
    let r = 0.04f64;
    let scene = slab_scene(Some(clear(false, Vec3::ZERO)), 0.2);
    let px = render(
        &scene,
        &settings(Estimator::Mis, Roulette::Throughput { min_depth: 1 }, 4, Vec3::ZERO),
        4096,
    );
    assert_within_4_sigma("slab with early roulette", pooled(&px), (1.0 - r) / (1.0 + r));
    let (sum, sum_sq): (f64, f64) =
        px.iter().fold((0.0, 0.0), |(a, b), p| (a + p.sum[0], b + p.sum_sq[0]));
    assert!(
        (sum_sq - sum).abs() <= 1e-4 * sum,
        "samples are not all 0 or 1: Σx² {sum_sq} vs Σx {sum}"
    );
}

/// Roulette waits for non-specular bounces: through a grey slab (each refraction transmits
/// 0.5) every path that gets through carries exactly 0.25, however early roulette may start.
/// Counting the two refractions as bounces would roulette the path at 0.5 and weight the
/// survivors 2×.
#[test]
fn roulette_waits_for_a_non_specular_bounce() {
    let (r, tint) = (0.04f64, 0.5f64);
    let scene = tinted_slab_scene(Some(clear(false, Vec3::ZERO)), 0.2, Vec3::splat(tint as f32));
    let px = render(
        &scene,
        &settings(Estimator::Mis, Roulette::Throughput { min_depth: 1 }, 4, Vec3::ZERO),
        4096,
    );
    assert_within_4_sigma(
        "grey slab with early roulette",
        pooled(&px),
        tint * tint * (1.0 - r) / (1.0 + r),
    );
    let (sum, sum_sq): (f64, f64) =
        px.iter().fold((0.0, 0.0), |(a, b), p| (a + p.sum[0], b + p.sum_sq[0]));
    let through = tint * tint;
    assert!(
        (sum_sq - through * sum).abs() <= 1e-4 * sum,
        "samples are not all 0 or {through}: Σx² {sum_sq} vs Σx {sum}"
    );
}

#[test]
fn absorbing_glass_follows_beer_lambert() {
    // T = (1 − R)² e^{−σd} / (1 − R² e^{−2σd}) per channel.
    let (r, d) = (0.04f64, 0.5f64);
    let sigma = Vec3::new(2.0, 0.5, 0.0);
    let scene = slab_scene(Some(clear(false, sigma)), d as f32);
    assert!(scene.effects.contains(Effects::ABSORPTION));
    let px = render(&scene, &settings(Estimator::Mis, Roulette::default(), 4, Vec3::ZERO), 4096);
    let red = (-(sigma.x as f64) * d).exp();
    assert_within_4_sigma("red", pooled(&px), (1.0 - r).powi(2) * red / (1.0 - r * r * red * red));
    let green: f64 = px.iter().map(|p| p.mean()[1]).sum::<f64>() / px.len() as f64;
    let tg = (-(sigma.y as f64) * d).exp();
    let expected = (1.0 - r).powi(2) * tg / (1.0 - r * r * tg * tg);
    assert!((green - expected).abs() < 0.02 * expected, "green {green} vs {expected}");
}

/// A small emitter (8 cm square) 4 m away on the axis, seen through a lens focused at 2 m.
fn point_scene(aperture: f32) -> Scene {
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::new(0.0, 0.0, -4.0), Vec3::X * 0.04, Vec3::Y * 0.04, 0);
    let light = Material { emission: Vec3::ONE, ..Material::lambert("light", Vec3::ZERO) };
    let mut cam = camera_at(Vec3::ZERO, Vec3::NEG_Z, 2.0 * (0.2f32 / 2.0).atan());
    (cam.aperture_radius, cam.focus_distance) = (aperture, 2.0);
    Scene::new(mesh, vec![light], vec![], vec![cam], vec![])
}

/// Flux-weighted mean squared distance from the image centre, in metres on the focal plane
/// (64 px span 0.4 m there).
fn spot_second_moment(scene: &Scene) -> f64 {
    let px = render(scene, &settings(Estimator::Mis, Roulette::default(), 64, Vec3::ZERO), 256);
    let (mut m0, mut m2) = (0.0, 0.0);
    for (i, p) in px.iter().enumerate() {
        let (x, y) = ((i % 64) as f64 + 0.5 - 32.0, (i / 64) as f64 + 0.5 - 32.0);
        let l = p.mean()[0];
        m0 += l;
        m2 += l * (x * x + y * y) * (0.4f64 / 64.0).powi(2);
    }
    m2 / m0
}

#[test]
fn an_out_of_focus_point_spreads_to_the_thin_lens_circle_of_confusion() {
    let (a, z, f) = (0.1f64, 4.0f64, 2.0f64);
    let scene = point_scene(a as f32);
    let camera = scene.camera(None).unwrap();
    assert!(scene.effects_for(camera, Vec3::ZERO).contains(Effects::DEPTH_OF_FIELD));
    // Circle of confusion on the focal plane: radius ρ = a·|z − f|/z. Second moments of
    // independent spreads add: the disc's ρ²/2, the pixel box's 2·w²/12 and the source's sharp
    // image (a square of half-width s·f/z: 2·(s f/z)²/3).
    let rho = a * (z - f) / z;
    let pixel = 0.4 / 64.0;
    let image = 0.04 * f / z;
    let expected = rho * rho / 2.0 + pixel * pixel / 6.0 + 2.0 * image * image / 3.0;
    let got = spot_second_moment(&scene);
    assert!((got - expected).abs() < 0.05 * expected, "E[r²] {got} vs {expected}");
    // A pinhole images the source sharply.
    let sharp = point_scene(0.0);
    assert!(
        !sharp
            .effects_for(sharp.camera(None).unwrap(), Vec3::ZERO)
            .contains(Effects::DEPTH_OF_FIELD)
    );
    let pinhole = pixel * pixel / 6.0 + 2.0 * image * image / 3.0;
    let got = spot_second_moment(&sharp);
    assert!((got - pinhole).abs() < 0.1 * pinhole, "pinhole E[r²] {got} vs {pinhole}");
}

/// An opaque black quad with alpha `alpha` (cutoff 0.5) in front of an emitter of radiance 1.
fn mask_scene(alpha: f32, texture_alpha: Option<[f32; 2]>) -> Scene {
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::new(0.0, 0.0, -1.0), Vec3::X * 2.0, Vec3::Y * 2.0, 0);
    // u runs across x: the left half of the quad reads texel 0, the right half texel 1.
    for tri in 0..2 {
        let uv = mesh.positions[tri].map(|p| glam::Vec2::new((p.x + 2.0) / 4.0, 0.5));
        mesh.set_uvs(tri, 0, uv);
    }
    quad(&mut mesh, Vec3::new(0.0, 0.0, -3.0), Vec3::X * 4.0, Vec3::Y * 4.0, 1);
    let mut textures = vec![];
    let mut mask =
        Material { alpha, alpha_cutoff: Some(0.5), ..Material::lambert("mask", Vec3::ZERO) };
    if let Some([a0, a1]) = texture_alpha {
        use crate::tracer::texture::{Texture, Wrap};
        let texels = vec![Vec4::new(1.0, 1.0, 1.0, a0), Vec4::new(1.0, 1.0, 1.0, a1)];
        textures.push(Texture {
            width: 2,
            height: 1,
            texels,
            wrap_s: Wrap::ClampToEdge,
            wrap_t: Wrap::ClampToEdge,
        });
        mask.base_color_texture = Some(crate::tracer::material::TextureRef::new(0, 0));
    }
    let light = Material { emission: Vec3::ONE, ..Material::lambert("light", Vec3::ZERO) };
    let cam = camera_at(Vec3::ZERO, Vec3::NEG_Z, 1.0);
    Scene::new(mesh, vec![mask, light], textures, vec![cam], vec![])
}

#[test]
fn alpha_masks_cut_out_geometry_by_factor_and_by_texture() {
    let s = settings(Estimator::Mis, Roulette::default(), 8, Vec3::ZERO);
    let cut = mask_scene(0.3, None);
    assert!(cut.effects.contains(Effects::ALPHA_MASK));
    assert_within_4_sigma("cut out", pooled(&render(&cut, &s, 16)), 1.0);
    assert_eq!(pooled(&render(&mask_scene(0.8, None), &s, 16)).0, 0.0, "kept");
    // Texture alpha 0 on the left, 1 on the right: the left columns see the light.
    let px = render(&mask_scene(1.0, Some([0.0, 1.0])), &s, 16);
    let column = |x: usize| (0..8).map(|y| px[y * 8 + x].mean()[0]).sum::<f64>() / 8.0;
    assert!((column(0) - 1.0).abs() < 1e-6 && column(7) == 0.0, "{} {}", column(0), column(7));
    // The matte kernel (no alpha code) would not see through: gating matters.
    let matte = crate::tracer::render_tile(
        &cut,
        &s,
        s.full_frame(),
        0..4,
        &RenderOptions { kernel: Some(KernelBits::MATTE), ..RenderOptions::default() },
    );
    assert_eq!(pooled(&matte.unwrap().pixels).0, 0.0);
}

#[test]
fn a_point_light_lights_a_floor_by_the_inverse_square_law() {
    use crate::tracer::light::Light;
    for h in [1.0f32, 2.0] {
        let mut mesh = Mesh::default();
        quad(&mut mesh, Vec3::ZERO, Vec3::X * 10.0, Vec3::NEG_Z * 10.0, 0);
        let cam = camera_at(Vec3::new(0.0, 0.5, 0.0) * h, Vec3::ZERO, 0.01);
        let light = Light::Point { position: Vec3::Y * h, intensity: Vec3::splat(3.0) };
        let scene = Scene::new(
            mesh,
            vec![Material::lambert("floor", Vec3::splat(0.5))],
            vec![],
            vec![cam],
            vec![light],
        );
        assert!(scene.effects.contains(Effects::POINT_LIGHTS));
        let got = pooled(&render(
            &scene,
            &settings(Estimator::Mis, Roulette::default(), 2, Vec3::ZERO),
            256,
        ));
        // Radiance = ρ/π · E, E = I/h² (cos ≈ 1 under the light).
        let expected = 0.5 / std::f64::consts::PI * 3.0 / (h * h) as f64;
        assert!((got.0 - expected).abs() < 1e-3 * expected, "h {h}: {got:?} vs {expected}");
    }
}
mod texture;
