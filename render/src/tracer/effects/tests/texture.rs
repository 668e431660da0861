//! Textures, normal maps, textured emitters and the scene-driven depth limit change the image
//! as they should. Delta-lit and directly seen emitters give every sample the same value, so
//! those tolerances are float rounding; the rest are 4σ of the difference of two estimates.
use crate::tracer::RenderOptions;
use crate::tracer::effects::Effects;
use crate::tracer::integrator::tests::{camera_at, furnace, pooled, quad, render, settings};
use crate::tracer::integrator::{Estimator, Roulette};
use crate::tracer::kernel::KernelBits;
use crate::tracer::light::Light;
use crate::tracer::material::{Material, NormalTexture, TextureRef};
use crate::tracer::render::render_tile;
use crate::tracer::scene::{Mesh, Scene};
use crate::tracer::texture::{Texture, UvTransform, Wrap};
use glam::{Vec2, Vec3, Vec4};

fn texture(width: u32, texels: Vec<Vec4>, wrap: Wrap) -> Texture {
    Texture { width, height: texels.len() as u32 / width, texels, wrap_s: wrap, wrap_t: wrap }
}

/// A 4 m quad at z = −1 facing the camera at the origin, u along +x and v down the image
/// (along −y), so computed tangents are +x and bitangents +y.
fn facing_quad(mesh: &mut Mesh, material: u32) {
    let first = mesh.len();
    quad(mesh, Vec3::new(0.0, 0.0, -1.0), Vec3::X * 2.0, Vec3::Y * 2.0, material);
    for tri in first..mesh.len() {
        let uv = mesh.positions[tri].map(|p| Vec2::new((p.x + 2.0) / 4.0, (2.0 - p.y) / 4.0));
        mesh.set_uvs(tri, 0, uv);
    }
}

/// A white Lambert quad (ρ = 0.5) with a constant normal map `texel`, lit by a directional
/// light of irradiance 1 arriving from `from`; radiance seen head-on.
fn normal_mapped_radiance(texel: Vec3, from: Vec3, tangent_w: Option<f32>) -> f64 {
    let mut mesh = Mesh::default();
    facing_quad(&mut mesh, 0);
    if let Some(w) = tangent_w {
        mesh.tangents = vec![[Vec4::new(1.0, 0.0, 0.0, w); 3]; mesh.len()];
    }
    let mut m = Material::lambert("bumpy", Vec3::splat(0.5));
    m.normal_texture = Some(NormalTexture { texture: TextureRef::new(0, 0), scale: 1.0 });
    let light = Light::Directional { dir: -from.normalize(), irradiance: Vec3::ONE };
    let tex = texture(1, vec![texel.extend(1.0)], Wrap::Repeat);
    let scene = Scene::new(
        mesh,
        vec![m],
        vec![tex],
        vec![camera_at(Vec3::ZERO, Vec3::NEG_Z, 0.2)],
        vec![light],
    );
    assert!(
        scene.effects.contains(Effects::NORMAL_MAPS)
            && scene.effects.kernel().0 & KernelBits::SURFACES != 0
    );
    let (mean, sigma) =
        pooled(&render(&scene, &settings(Estimator::Mis, Roulette::default(), 4, Vec3::ZERO), 4));
    assert!(
        sigma < 1e-6 * mean.max(1e-3),
        "a delta light on a flat patch gives one value ({sigma})"
    );
    mean
}

/// The normal-map texel of a normal tilted by `theta` towards the tangent (red) or the
/// bitangent (green).
fn tilted(theta: f32, towards_green: bool) -> Vec3 {
    let t = (theta.sin() + 1.0) / 2.0;
    let z = (theta.cos() + 1.0) / 2.0;
    if towards_green { Vec3::new(0.5, t, z) } else { Vec3::new(t, 0.5, z) }
}

#[test]
fn a_normal_map_tilts_a_lambert_patch_by_its_encoded_angle() {
    let lambert = |cos: f32| 0.5 / std::f64::consts::PI * cos as f64;
    let close = |got: f64, want: f64| {
        assert!((got - want).abs() <= 1e-5 * want.max(1e-3), "{got} vs {want}")
    };
    let (theta, phi) = (0.6f32, 0.35f32);
    // Light from straight ahead: the tilted normal sees it at cos θ.
    close(normal_mapped_radiance(tilted(theta, false), Vec3::Z, None), lambert(theta.cos()));
    // Light from φ towards +x (the tangent): cos(θ − φ) when tilted towards it, cos(θ + φ) away.
    let from_x = Vec3::new(phi.sin(), 0.0, phi.cos());
    close(normal_mapped_radiance(tilted(theta, false), from_x, None), lambert((theta - phi).cos()));
    close(
        normal_mapped_radiance(tilted(-theta, false), from_x, None),
        lambert((theta + phi).cos()),
    );
    // Green tilts towards the bitangent, +y (image up) for these UVs and for TANGENT w = +1,
    // −y for w = −1.
    let from_y = Vec3::new(0.0, phi.sin(), phi.cos());
    close(normal_mapped_radiance(tilted(theta, true), from_y, None), lambert((theta - phi).cos()));
    close(
        normal_mapped_radiance(tilted(theta, true), from_y, Some(1.0)),
        lambert((theta - phi).cos()),
    );
    close(
        normal_mapped_radiance(tilted(theta, true), from_y, Some(-1.0)),
        lambert((theta + phi).cos()),
    );
    // A flat map changes nothing.
    close(normal_mapped_radiance(Vec3::new(0.5, 0.5, 1.0), from_x, None), lambert(phi.cos()));
}

/// A black quad filling a 90° view, emitting `emission` × an emissive texture bound by `slot`.
fn emissive_wall(tex: Texture, slot: TextureRef, emission: Vec3) -> Scene {
    let mut mesh = Mesh::default();
    facing_quad(&mut mesh, 0);
    mesh.positions.iter_mut().flatten().for_each(|p| *p = Vec3::new(p.x / 2.0, p.y / 2.0, p.z));
    let m = Material {
        emission,
        emissive_texture: Some(slot),
        ..Material::lambert("sign", Vec3::ZERO)
    };
    Scene::new(
        mesh,
        vec![m],
        vec![tex],
        vec![camera_at(Vec3::ZERO, Vec3::NEG_Z, std::f32::consts::FRAC_PI_2)],
        vec![],
    )
}

#[test]
fn an_emissive_texture_emits_its_texels_times_the_factor() {
    let (a, b) = (Vec3::new(0.2, 0.4, 0.8), Vec3::new(1.0, 0.5, 0.1));
    let tex = texture(2, vec![a.extend(1.0), b.extend(1.0)], Wrap::ClampToEdge);
    let scene = emissive_wall(tex, TextureRef::new(0, 0), Vec3::splat(2.0));
    assert!(
        scene.effects.contains(Effects::TEXTURES) && scene.effects.contains(Effects::NO_SCATTERING)
    );
    let px = render(&scene, &settings(Estimator::Mis, Roulette::default(), 8, Vec3::ZERO), 16);
    // Columns 0–1 cover u ≤ ¼ (texel a exactly, clamped), columns 6–7 u ≥ ¾ (texel b).
    for y in 0..8 {
        for (x, texel) in [(0, a), (1, a), (6, b), (7, b)] {
            let got = Vec3::from(px[y * 8 + x].mean().map(|c| c as f32));
            assert!(
                (got - texel * 2.0).length() < 1e-5,
                "pixel ({x}, {y}): {got} vs {}",
                texel * 2.0
            );
        }
    }
}

#[test]
fn a_texture_transform_offset_shifts_the_pattern_by_the_expected_pixels() {
    let texels = [0.1, 0.9, 0.3, 0.6].map(|v| Vec4::new(v, 1.0 - v, 0.5, 1.0)).to_vec();
    let shifted = |offset: f32| {
        let slot = TextureRef {
            transform: UvTransform::from_gltf(Vec2::new(offset, 0.0), 0.0, Vec2::ONE),
            ..TextureRef::new(0, 0)
        };
        let scene = emissive_wall(texture(4, texels.clone(), Wrap::Repeat), slot, Vec3::ONE);
        render(&scene, &settings(Estimator::Mis, Roulette::default(), 8, Vec3::ZERO), 256)
    };
    let (plain, moved) = (shifted(0.0), shifted(0.25));
    // 8 pixels span u ∈ [0, 1]: an offset of ¼ shows at column x what column x + 2 showed.
    let (mut compared, mut differs) = (0, 0);
    for y in 0..8 {
        for x in 0..6 {
            for c in 0..3 {
                let (p, q) = (&moved[y * 8 + x], &plain[y * 8 + x + 2]);
                let (mp, mq) = (p.mean()[c], q.mean()[c]);
                let var = |s: &crate::tracer::PixelSums, m: f64| {
                    (s.sum_sq[c] / s.count as f64 - m * m).max(0.0) / (s.count as f64 - 1.0)
                };
                let sigma = (var(p, mp) + var(q, mq)).sqrt();
                assert!(
                    (mp - mq).abs() <= 4.5 * sigma + 1e-6,
                    "pixel ({x}, {y}) channel {c}: {mp} vs {mq} (σ {sigma})"
                );
                compared += 1;
                differs += ((plain[y * 8 + x].mean()[c] - mp).abs() > 4.5 * sigma + 1e-3) as usize;
            }
        }
    }
    assert!(
        differs > compared / 3,
        "the offset must move the pattern ({differs} of {compared} changed)"
    );
}

#[test]
fn light_sampling_of_a_textured_emitter_agrees_with_bsdf_hits() {
    // A white floor under a textured ceiling light (texels 1 and 0.02: a light sampler that
    // ignored the texture would see ~2× the light a BSDF ray finds).
    let mut mesh = Mesh::default();
    quad(&mut mesh, Vec3::ZERO, Vec3::X * 3.0, Vec3::NEG_Z * 3.0, 0);
    let first = mesh.len();
    quad(&mut mesh, Vec3::Y, Vec3::NEG_Z, Vec3::X, 1);
    for tri in first..mesh.len() {
        let uv = mesh.positions[tri].map(|p| Vec2::new((p.x + 1.0) / 2.0, (p.z + 1.0) / 2.0));
        mesh.set_uvs(tri, 1, uv);
    }
    let tex = texture(2, vec![Vec4::ONE, Vec4::splat(0.02)], Wrap::ClampToEdge);
    let light = Material {
        emission: Vec3::splat(3.0),
        emissive_texture: Some(TextureRef::new(0, 1)),
        ..Material::lambert("light", Vec3::ZERO)
    };
    let cam = camera_at(Vec3::new(0.0, 0.9, 2.5), Vec3::ZERO, 0.6);
    let scene = Scene::new(
        mesh,
        vec![Material::lambert("floor", Vec3::splat(0.8)), light],
        vec![tex],
        vec![cam],
        vec![],
    );
    let est = |e| pooled(&render(&scene, &settings(e, Roulette::default(), 16, Vec3::ZERO), 256));
    let (bsdf, light, mis) = (est(Estimator::Bsdf), est(Estimator::Light), est(Estimator::Mis));
    for (name, (m, s)) in [("light", light), ("mis", mis)] {
        let sigma = (s * s + bsdf.1 * bsdf.1).sqrt();
        assert!((m - bsdf.0).abs() <= 4.0 * sigma, "{name} {m} vs bsdf {} (σ {sigma})", bsdf.0);
    }
    assert!(bsdf.0 > 0.01, "the floor is lit ({bsdf:?})");
}

#[test]
fn the_metallic_roughness_texture_multiplies_the_factors() {
    use crate::tracer::bsdf::{Bsdf, Pbr};
    let tex = texture(
        2,
        vec![Vec4::new(0.0, 0.25, 0.5, 1.0), Vec4::new(0.0, 1.0, 0.0, 1.0)],
        Wrap::ClampToEdge,
    );
    // No dielectric specular layer: with metallic 0 from the texture the BSDF is Lambert.
    let mut m = Material::lambert("mr", Vec3::splat(0.7));
    m.model = crate::tracer::material::MaterialModel::Pbr(Pbr {
        specular: 0.0,
        ..Pbr::new(Vec3::splat(0.7), 1.0, 0.8)
    });
    m.metallic_roughness_texture = Some(TextureRef::new(0, 0));
    let at = |u: f32| m.bsdf(&[Vec2::new(u, 0.5), Vec2::ZERO], std::slice::from_ref(&tex));
    match at(0.1) {
        Bsdf::Pbr(p) => {
            assert!((p.metallic - 0.5).abs() < 1e-6 && (p.roughness - 0.2).abs() < 1e-6, "{p:?}")
        }
        b => panic!("{b:?}"),
    }
    assert!(matches!(at(0.9), Bsdf::Lambert(l) if l.albedo == Vec3::splat(0.7)), "{:?}", at(0.9));
}

#[test]
fn scenes_where_nothing_scatters_or_nothing_emits_need_no_bounce() {
    let black = furnace(0.0, 1.0);
    assert!(black.effects.contains(Effects::NO_SCATTERING));
    assert_eq!(black.needed_depth(Vec3::ZERO), 0);
    assert!(black.effects.names().contains(&"max_depth=0".to_string()));
    let lit = furnace(0.5, 1.0);
    assert_eq!(
        (lit.effects.contains(Effects::NO_SCATTERING), lit.needed_depth(Vec3::ZERO)),
        (false, u32::MAX)
    );
    let dark = furnace(0.5, 0.0);
    assert_eq!((dark.needed_depth(Vec3::ZERO), dark.needed_depth(Vec3::splat(0.1))), (0, u32::MAX));
    // Limited (gated) and unlimited (forced kernel: the job's full depth) renders agree: Le = 1
    // everywhere in the black furnace, nothing in the dark one.
    let s = settings(Estimator::Mis, Roulette::Off, 4, Vec3::ZERO);
    for (scene, want) in [(&black, 1.0), (&dark, 0.0)] {
        for kernel in [None, Some(KernelBits::ALL)] {
            let px = render_tile(
                scene,
                &s,
                s.full_frame(),
                0..8,
                &RenderOptions { kernel, ..RenderOptions::default() },
            )
            .unwrap()
            .pixels;
            assert!(px.iter().all(|p| p.mean() == [want; 3]), "{kernel:?}: {:?}", px[0].mean());
        }
    }
}
