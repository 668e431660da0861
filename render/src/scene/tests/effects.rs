//! Every bundled scene reports the effects it calls for, and its gated render agrees with a
//! render by the kernel with every effect compiled in, per pixel, within error bars.
use super::super::*;
use crate::tracer::RenderOptions;
use crate::tracer::effects::Effects;
use crate::tracer::integrator::tests::settings;
use crate::tracer::kernel::KernelBits;
use crate::tracer::{Estimator, PixelSums, Roulette, render_tile};
use std::path::PathBuf;

fn scene_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../scenes/{name}.gltf"))
}

/// Every scene in `scenes/` (all of them are bundled), by name.
fn bundled() -> Vec<String> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.unwrap().file_name().to_str()?.strip_suffix(".gltf").map(str::to_string))
        .collect();
    names.sort();
    assert!(names.len() >= 13, "{names:?}");
    names
}

#[test]
fn each_effect_scene_reports_its_effect_and_the_matte_scenes_do_not() {
    let effects = |name| parse(&std::fs::read(scene_path(name)).unwrap(), None).unwrap().effects();
    for (scene, effect) in [
        ("glass", "glass"),
        ("absorption", "absorption"),
        ("absorption", "glass"),
        ("alpha-mask", "alpha_mask"),
        ("alpha-mask", "textures"),
        ("depth-of-field", "depth_of_field"),
        ("punctual", "spot_lights"),
        ("glossy", "ggx"),
        ("phong", "phong"),
        ("textured", "textures"),
        ("textured", "normal_maps"),
        ("textured", "ggx"),
        ("emitters-only", "max_depth=0"),
        ("many-lights", "light_tree"),
    ] {
        assert!(effects(scene).contains(&effect.to_string()), "{scene}: {:?}", effects(scene));
    }
    assert_eq!(effects("cornell-box"), ["area_lights", "lambert"]);
    assert_eq!(effects("many-lights"), ["area_lights", "lambert", "light_tree"]);
    assert!(!effects("glass").contains(&"absorption".to_string()), "clear glass does not absorb");
    assert!(!effects("alpha-mask").contains(&"normal_maps".to_string()), "base colour only");
}

/// A scene reports the effects it is rendered with: the parsed file's (what an upload answers)
/// are the built scene's, whose lights and light tree exist only once it is built.
#[test]
fn every_bundled_scene_reports_the_effects_of_the_scene_it_builds() {
    for name in bundled() {
        let parsed = parse(&std::fs::read(scene_path(&name)).unwrap(), None).unwrap();
        let reported = parsed.effects();
        let built = parsed.build();
        let cameras = built.cameras.iter().fold(built.effects, |e, c| {
            if c.has_depth_of_field() { e | Effects::DEPTH_OF_FIELD } else { e }
        });
        assert_eq!(cameras.names(), reported, "{name}");
        let uses_tree = built.light_tree_for(crate::tracer::LightSampler::Auto).is_some();
        assert_eq!(uses_tree, reported.contains(&"light_tree".to_string()), "{name}");
    }
}

/// A 10 m white floor under 30 cm emissive squares facing down, 2.5 m up at `lamps` (x, z).
fn lamps_over_a_floor(lamps: &[(f32, f32)]) -> String {
    use base64::Engine;
    let square = |x: f32, y: f32, z: f32, s: f32, down: bool| {
        let [a, b, c, d] =
            [[x - s, y, z - s], [x + s, y, z - s], [x + s, y, z + s], [x - s, y, z + s]];
        if down { [a, b, c, a, c, d] } else { [a, c, b, a, d, c] }
    };
    let mut points: Vec<[f32; 3]> = square(0.0, 0.0, 0.0, 5.0, false).to_vec();
    lamps.iter().for_each(|&(x, z)| points.extend(square(x, 2.5, z, 0.15, true)));
    let bin: Vec<u8> = points.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    let data = base64::engine::general_purpose::STANDARD.encode(&bin);
    let lamp_vertices = points.len() - 6;
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1,2]}}],
        "nodes":[{{"mesh":0}},{{"mesh":1}},{{"camera":0,"translation":[0,1,8]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}},{{"primitives":[{{"attributes":{{"POSITION":1}},"material":1}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.8,0.8,0.8,1],"metallicFactor":0}}}},
                     {{"pbrMetallicRoughness":{{"baseColorFactor":[0,0,0,1],"metallicFactor":0}},"emissiveFactor":[1,1,1]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":6,"type":"VEC3","min":[-5,0,-5],"max":[5,0,5]}},
                     {{"bufferView":1,"componentType":5126,"count":{lamp_vertices},"type":"VEC3","min":[-9,2.5,-9],"max":[9,2.5,9]}}],
        "bufferViews":[{{"buffer":0,"byteLength":72}},{{"buffer":0,"byteOffset":72,"byteLength":{}}}],
        "buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{data}"}}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.8,"znear":0.01}}}}]}}"#,
        lamp_vertices * 12,
        bin.len()
    )
}

/// Below 32 emissive triangles, `auto` uses the tree where the lights differ in what they give
/// the surfaces: four lamps apart over a floor (8 triangles) list `light_tree` and render
/// through the tree; one lamp (2) does neither. The upload's listing is the built scene's.
#[test]
fn a_few_lamps_apart_choose_through_the_tree_and_one_lamp_does_not() {
    for (lamps, tree) in [
        (&[(-3.0, -3.0), (3.0, -3.0), (-3.0, 3.0), (3.0, 3.0)][..], true),
        (&[(0.0, 0.0)][..], false),
    ] {
        let parsed = parse(lamps_over_a_floor(lamps).as_bytes(), None).unwrap();
        let reported = parsed.effects();
        let built = parsed.build();
        assert_eq!(
            built.light_tree.as_ref().map(|t| t.len()),
            Some(2 * lamps.len()),
            "the scene holds a tree either way"
        );
        assert_eq!(reported.contains(&"light_tree".to_string()), tree, "{lamps:?}: {reported:?}");
        assert_eq!(
            built.light_tree_for(crate::tracer::LightSampler::Auto).is_some(),
            tree,
            "{lamps:?}"
        );
        assert_eq!(built.effects.names(), reported);
    }
}

#[test]
fn the_textured_scene_binds_each_slot_in_its_colour_space_with_its_transform() {
    use crate::tracer::texture::UvTransform;
    use glam::Vec2;
    let scene = load_path(&scene_path("textured")).unwrap();
    let by_name = |n: &str| scene.materials.iter().find(|m| m.name == n).unwrap();
    let (tile, sign) = (by_name("textured_tile"), by_name("glowing_sign"));
    let base = tile.base_color_texture.unwrap();
    assert_eq!(base.transform, UvTransform::from_gltf(Vec2::ZERO, 0.0, Vec2::splat(2.0)));
    let normal = tile.normal_texture.unwrap();
    assert_eq!(
        (normal.scale, normal.texture.transform),
        (1.0, UvTransform::from_gltf(Vec2::ZERO, 0.0, Vec2::new(3.0, 1.0)))
    );
    let emissive = sign.emissive_texture.unwrap();
    let want = UvTransform::from_gltf(Vec2::new(0.25, 0.0), 30f32.to_radians(), Vec2::ONE);
    let t = emissive.transform;
    // The file stores the angle to 6 decimals.
    assert!(
        (t.x - want.x).length() + (t.y - want.y).length() + (t.offset - want.offset).length()
            < 1e-5,
        "{t:?}"
    );
    assert!(tile.metallic_roughness_texture.is_some());
    // The normal map is data: texel (0, 0) holds the generator's 8-bit value, not sRGB-decoded.
    let tilt = 30f64.to_radians() * (std::f64::consts::PI * 0.5 / 4.0).sin();
    let blue = ((tilt.cos() + 1.0) * 0.5 * 255.0).round() / 255.0;
    let texel = scene.textures[normal.texture.texture as usize].texels[0];
    assert!((texel.z as f64 - blue).abs() < 1e-6, "{texel} vs {blue}");
    // The emissive sign is a textured area light, and no other light is.
    let textured = scene
        .lights
        .iter()
        .filter(|l| matches!(l, crate::tracer::light::Light::Triangle { texture: Some(_), .. }))
        .count();
    assert_eq!(textured, 2);
}

#[test]
fn the_cornell_box_runs_the_matte_kernel() {
    let scene = load_path(&scene_path("cornell-box")).unwrap();
    assert_eq!(
        scene.effects_for(scene.camera(None).unwrap(), glam::Vec3::ZERO).kernel(),
        KernelBits::MATTE
    );
}

/// Per-channel mean and variance of the mean of one pixel.
fn mean_var(p: &PixelSums, c: usize) -> (f64, f64) {
    let n = p.count as f64;
    let m = p.sum[c] / n;
    (m, (p.sum_sq[c] / n - m * m).max(0.0) / (n - 1.0))
}

#[test]
fn gated_and_all_effects_renders_agree_within_error_bars() {
    for name in bundled() {
        let scene = load_path(&scene_path(&name)).unwrap();
        let s = settings(Estimator::Mis, Roulette::default(), 24, glam::Vec3::ZERO);
        let render = |k| {
            render_tile(
                &scene,
                &s,
                s.full_frame(),
                0..64,
                &RenderOptions { kernel: k, ..RenderOptions::default() },
            )
            .unwrap()
        };
        let (gated, all) = (render(None), render(Some(KernelBits::ALL)));
        assert_eq!((gated.dropped, all.dropped), (0, 0), "{name}: non-finite samples");
        let (mut outliers, mut n) = (0, 0);
        for (a, b) in gated.pixels.iter().zip(&all.pixels) {
            for c in 0..3 {
                let ((ma, va), (mb, vb)) = (mean_var(a, c), mean_var(b, c));
                n += 1;
                // Both exactly equal (e.g. background pixels) or within 4.5σ of their difference.
                if (ma - mb).abs() > 4.5 * (va + vb).sqrt() + 1e-9 * ma.abs() {
                    outliers += 1;
                }
            }
        }
        // At 4.5σ a normal difference is out 7 times in a million; allow for heavy tails (a
        // firefly in one render and none in the other) but not for a systematic difference.
        assert!(outliers <= n / 200, "{name}: {outliers} of {n} pixel channels differ beyond 4.5σ");
        let (mg, ma) = (
            crate::tracer::render::frame_mean(&gated.pixels),
            crate::tracer::render::frame_mean(&all.pixels),
        );
        for c in 0..3 {
            assert!(
                (mg[c] - ma[c]).abs() <= 0.05 * ma[c].max(1e-3),
                "{name}: frame means {mg:?} vs {ma:?}"
            );
        }
    }
}
