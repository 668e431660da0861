//! Keyframe interpolation against hand-computed values, and the loader's checks on animations.
use super::super::animation::{Interpolation, Track, resolve};
use super::super::*;
use glam::{DQuat, DVec4};

fn v3(x: f64, y: f64, z: f64) -> DVec4 {
    DVec4::new(x, y, z, 0.0)
}

fn track(interpolation: Interpolation, times: &[f64], values: &[DVec4]) -> Track {
    Track { interpolation, times: times.to_vec(), values: values.to_vec() }
}

fn close(a: DVec4, b: DVec4) -> bool {
    (a - b).abs().max_element() < 1e-12
}

/// A rotation of `deg` degrees about +z, as xyzw.
fn about_z(deg: f64) -> DVec4 {
    DQuat::from_rotation_z(deg.to_radians()).into()
}

#[test]
fn step_holds_each_keyframe_until_the_next() {
    let t = track(
        Interpolation::Step,
        &[0.0, 1.0, 3.0],
        &[v3(1.0, 0.0, 0.0), v3(2.0, 0.0, 0.0), v3(4.0, 0.0, 0.0)],
    );
    for (time, x) in
        [(-1.0, 1.0), (0.0, 1.0), (0.5, 1.0), (1.0, 2.0), (2.999, 2.0), (3.0, 4.0), (9.0, 4.0)]
    {
        assert_eq!(t.sample(time).x, x, "t = {time}");
    }
}

#[test]
fn linear_interpolates_and_clamps_outside_the_keys() {
    let t = track(Interpolation::Linear, &[1.0, 3.0], &[v3(0.0, 0.0, 0.0), v3(4.0, -2.0, 8.0)]);
    assert!(close(t.sample(1.5), v3(1.0, -0.5, 2.0))); // s = 0.25 over a 2 s interval
    assert!(close(t.sample(2.0), v3(2.0, -1.0, 4.0)));
    assert!(close(t.sample(0.0), v3(0.0, 0.0, 0.0)), "before the first key: the first value");
    assert!(close(t.sample(10.0), v3(4.0, -2.0, 8.0)), "after the last key: the last value");
    assert!(close(t.sample(f64::NAN), v3(0.0, 0.0, 0.0)));
}

#[test]
fn linear_rotation_slerps_on_the_shortest_arc() {
    // Identity → 90° about z over [2, 6] s: at t = 3 (s = 1/4) the rotation is 22.5° about z.
    let t = track(Interpolation::Linear, &[2.0, 6.0], &[about_z(0.0), about_z(90.0)]);
    assert!(close(t.sample_rotation(3.0).into(), about_z(22.5)));
    assert!(close(t.sample_rotation(4.0).into(), about_z(45.0)));
    // The same end rotation written as −q: the shortest arc is still 22.5° at s = 1/4, where a
    // slerp without the sign flip would turn the long way round (−(360 − 90)/4 = −67.5°).
    let flipped = track(Interpolation::Linear, &[2.0, 6.0], &[about_z(0.0), -about_z(90.0)]);
    assert!(
        close(flipped.sample_rotation(3.0).into(), about_z(22.5)),
        "{:?}",
        flipped.sample_rotation(3.0)
    );
    // 170° → −170° (= 190°) is 20° apart: halfway is 180°, not 0°.
    let wrap = track(Interpolation::Linear, &[0.0, 1.0], &[about_z(170.0), about_z(-170.0)]);
    let mid = wrap.sample_rotation(0.5);
    let expected = DQuat::from_rotation_z(180f64.to_radians());
    assert!(mid.dot(expected).abs() > 1.0 - 1e-12, "{mid:?}");
}

#[test]
fn cubic_spline_scales_tangents_by_the_keyframe_interval() {
    // Keys at 1 s and 3 s (Δt = 2). Triplets (in-tangent, value, out-tangent); the first
    // in-tangent and the last out-tangent are never used.
    let values = [
        v3(9.0, 9.0, 9.0),
        v3(0.0, 0.0, 0.0),
        v3(1.0, 0.0, 0.0),
        v3(0.0, 2.0, 0.0),
        v3(2.0, 4.0, 0.0),
        v3(9.0, 9.0, 9.0),
    ];
    let t = track(Interpolation::CubicSpline, &[1.0, 3.0], &values);
    // s = 1/2: h00 = 1/2, h10 = 1/8, h01 = 1/2, h11 = −1/8:
    // p = ½·0 + 2·⅛·(1,0,0) + ½·(2,4,0) − 2·⅛·(0,2,0) = (1.25, 1.5, 0)
    assert!(close(t.sample(2.0), v3(1.25, 1.5, 0.0)), "{:?}", t.sample(2.0));
    // s = 1/4: h10 = 9/64, h01 = 5/32, h11 = −3/64:
    // p = 2·9/64·(1,0,0) + 5/32·(2,4,0) − 2·3/64·(0,2,0) = (0.59375, 0.4375, 0)
    assert!(close(t.sample(1.5), v3(0.59375, 0.4375, 0.0)), "{:?}", t.sample(1.5));
    assert!(close(t.sample(1.0), v3(0.0, 0.0, 0.0)) && close(t.sample(3.0), v3(2.0, 4.0, 0.0)));
    assert!(close(t.sample(-5.0), v3(0.0, 0.0, 0.0)) && close(t.sample(7.0), v3(2.0, 4.0, 0.0)));
    // Tangents are velocities in units per second: the curve leaves key 0 at (1, 0, 0) per
    // second and reaches key 1 at (0, 2, 0) per second.
    let h = 1e-6;
    let leave = (t.sample(1.0 + h) - t.sample(1.0)) / h;
    let arrive = (t.sample(3.0) - t.sample(3.0 - h)) / h;
    assert!((leave - v3(1.0, 0.0, 0.0)).abs().max_element() < 1e-5, "{leave:?}");
    assert!((arrive - v3(0.0, 2.0, 0.0)).abs().max_element() < 1e-5, "{arrive:?}");
}

#[test]
fn cubic_spline_rotations_are_normalised() {
    // Zero tangents: at s = 1/2 the Hermite value is the mean of the two quaternions, whose
    // normalisation is the 45° rotation halfway between identity and 90° about z.
    let zero = DVec4::ZERO;
    let t = track(
        Interpolation::CubicSpline,
        &[0.0, 0.5],
        &[zero, about_z(0.0), zero, zero, about_z(90.0), zero],
    );
    let q = t.sample_rotation(0.25);
    assert!((q.length() - 1.0).abs() < 1e-12);
    assert!(close(q.into(), about_z(45.0)), "{q:?}");
}

fn infos(names: &[Option<&str>]) -> Vec<AnimationInfo> {
    names
        .iter()
        .map(|n| AnimationInfo { name: n.map(str::to_owned), duration_s: 1.0, channels: 1 })
        .collect()
}

#[test]
fn animations_resolve_by_name_then_index() {
    let two = infos(&[Some("walk"), None, Some("2")]);
    assert_eq!(resolve(&two, None), Ok(Some(0)));
    assert_eq!(resolve(&two, Some("walk")), Ok(Some(0)));
    assert_eq!(resolve(&two, Some("1")), Ok(Some(1)));
    assert_eq!(resolve(&two, Some("2")), Ok(Some(2)), "a name wins over an index");
    let e = resolve(&two, Some("run")).unwrap_err().0;
    assert_eq!(e, "no animation named run (the scene has: walk, 1 (unnamed), 2)");
    assert!(resolve(&two, Some("3")).is_err());
    assert_eq!(resolve(&[], None), Ok(None));
    assert_eq!(
        resolve(&[], Some("0")).unwrap_err().0,
        "no animation named 0 (the scene has no animations)"
    );
}

/// A one-triangle scene whose node 0 (the mesh) is driven by `channels` (JSON) reading floats
/// from accessors 1 (times) and 2 (values): `times` and `values` are their contents.
pub(super) fn animated_glb(
    times: &[f32],
    values: &[f32],
    output_type: &str,
    interpolation: &str,
    path: &str,
    extra_node: &str,
) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    for f in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().chain(times).chain(values) {
        bin.extend_from_slice(&f.to_le_bytes());
    }
    let width = match output_type {
        "VEC4" => 4,
        _ => 3,
    };
    let (tb, vb) = (times.len() * 4, values.len() * 4);
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
        "nodes":[{{"mesh":0{extra_node}}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}}}}]}}],
        "buffers":[{{"byteLength":{len}}}],
        "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":{tb}}},{{"buffer":0,"byteOffset":{vo},"byteLength":{vb}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5126,"count":{tc},"type":"SCALAR"}},
                     {{"bufferView":2,"componentType":5126,"count":{vc},"type":"{output_type}"}}],
        "animations":[{{"name":"move","samplers":[{{"input":1,"output":2,"interpolation":"{interpolation}"}}],
                        "channels":[{{"sampler":0,"target":{{"node":0,"path":"{path}"}}}}]}}]}}"#,
        len = bin.len(),
        vo = 36 + tb,
        tc = times.len(),
        vc = values.len() / width,
    );
    pack_glb(&json, &bin)
}

#[test]
fn a_translated_node_moves_its_triangles_and_the_static_pose_stays() {
    let glb = animated_glb(
        &[0.0, 2.0],
        &[0.0, 0.0, 0.0, 4.0, 0.0, 0.0],
        "VEC3",
        "LINEAR",
        "translation",
        "",
    );
    let seq = Sequence::parse(&glb, None).unwrap();
    assert_eq!(
        seq.animations(),
        vec![AnimationInfo { name: Some("move".into()), duration_s: 2.0, channels: 1 }]
    );
    let parsed = seq.parsed_at(Some(0), 0.5).unwrap();
    assert_eq!(parsed.mesh.positions[0][1], glam::Vec3::new(2.0, 0.0, 0.0)); // (1, 0, 0) + (1, 0, 0)
    let rest = parse(&glb, None).unwrap();
    assert_eq!(rest.mesh.positions[0][1], glam::Vec3::new(1.0, 0.0, 0.0));
    assert_eq!(rest.animations().len(), 1);
    assert_eq!(resolve_animation(&rest, Some("move")), Ok(Some(0)));
}

#[test]
fn refuses_what_it_cannot_animate_with_messages_naming_the_place() {
    let t2 = [0.0f32, 1.0];
    let xyz2 = [0.0f32; 6];
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (
            animated_glb(&t2, &[0.0, 1.0], "SCALAR", "LINEAR", "weights", ""),
            "animation 0 channel 0: morph-target weights are not supported",
        ),
        (
            animated_glb(&t2, &xyz2, "VEC3", "LINEAR", "translation", r#","skin":0"#),
            "animation 0 channel 0: node 0 is skinned",
        ),
        (
            animated_glb(
                &t2,
                &xyz2,
                "VEC3",
                "LINEAR",
                "translation",
                r#","matrix":[1,0,0,0,0,1,0,0,0,0,1,0,0,0,0,1]"#,
            ),
            "node 0 has a matrix",
        ),
        (
            animated_glb(&[1.0, 1.0], &xyz2, "VEC3", "LINEAR", "translation", ""),
            "animation 0 channel 0: sampler 0: keyframe times must increase strictly",
        ),
        (
            animated_glb(&[0.0, f32::NAN], &xyz2, "VEC3", "LINEAR", "translation", ""),
            "keyframe time 1 is not finite",
        ),
        (
            animated_glb(&t2, &xyz2, "VEC3", "CUBICSPLINE", "translation", ""),
            "sampler 0: output count 2 should be 6",
        ),
        (
            animated_glb(&t2, &[0.0; 8], "VEC4", "LINEAR", "translation", ""),
            "output accessor has type Vec4",
        ),
        (
            animated_glb(&t2, &[0.0; 8], "VEC4", "LINEAR", "rotation", ""),
            "output value 0 is a zero quaternion",
        ),
        (
            animated_glb(
                &t2,
                &[0.0, 0.0, f32::INFINITY, 0.0, 0.0, 0.0],
                "VEC3",
                "LINEAR",
                "scale",
                "",
            ),
            "output value 0 is not finite",
        ),
    ];
    for (glb, want) in cases {
        let glb = if want.contains("skinned") {
            with_top_level(&glb, r#","skins":[{"joints":[0]}]"#)
        } else {
            glb
        };
        match Sequence::parse(&glb, None) {
            Ok(_) => panic!("accepted; expected {want:?}"),
            Err(e) => assert!(e.0.contains(want), "{:?} should contain {want:?}", e.0),
        }
    }
}

/// Adds top-level members (`extra`, starting with a comma) to a glb made by [`animated_glb`].
fn with_top_level(glb: &[u8], extra: &str) -> Vec<u8> {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let json = std::str::from_utf8(&glb[20..20 + json_len]).unwrap().trim_end();
    let json = format!("{}{extra}}}", &json[..json.len() - 1]);
    let bin_len =
        u32::from_le_bytes(glb[20 + json_len..24 + json_len].try_into().unwrap()) as usize;
    pack_glb(&json, &glb[28 + json_len..28 + json_len + bin_len])
}

#[test]
fn an_animated_camera_moves() {
    let glb = animated_glb(
        &[0.0, 1.0],
        &[0.0, 0.0, 0.0, 0.0, 0.0, -3.0],
        "VEC3",
        "LINEAR",
        "translation",
        r#","camera":0"#,
    );
    let glb = with_top_level(
        &glb,
        r#","cameras":[{"type":"perspective","perspective":{"yfov":0.7,"znear":0.01}}]"#,
    );
    let seq = Sequence::parse(&glb, None).unwrap();
    for (time, z) in [(0.0, 0.0), (0.5, -1.5), (1.0, -3.0), (2.0, -3.0)] {
        let scene = seq.scene_at(Some(0), time).unwrap();
        let origin = scene.cameras[0].to_world.transform_point3(glam::Vec3::ZERO);
        assert_eq!(origin, glam::Vec3::new(0.0, 0.0, z), "t = {time}");
    }
}
