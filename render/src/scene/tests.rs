use super::*;
use std::path::PathBuf;

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes")
}

#[test]
fn bundled_scenes_load() {
    for name in ["cornell-box", "furnace", "glossy", "phong", "punctual"] {
        let scene = load_path(&scenes_dir().join(format!("{name}.gltf")))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        let info = info(&scene);
        assert!(info.triangles > 0, "{name}");
        assert!(!info.cameras.is_empty(), "{name} has a camera");
    }
}

#[test]
fn cornell_box_has_its_light_and_camera() {
    let scene = load_path(&scenes_dir().join("cornell-box.gltf")).unwrap();
    let info = info(&scene);
    assert_eq!(info.emissive_triangles, 2, "the light quad");
    assert_eq!(info.punctual_lights, 0);
    let light = scene.materials.iter().find(|m| m.is_emissive()).unwrap();
    assert!(
        (light.emission - glam::Vec3::new(17.0, 12.0, 4.0)).length() < 1e-4,
        "{}",
        light.emission
    );
    assert!(scene.camera(None).is_ok());
    assert!(scene.camera(Some("nope")).unwrap_err().to_string().contains("no camera named"));
}

#[test]
fn punctual_scene_has_its_three_lights() {
    let scene = load_path(&scenes_dir().join("punctual.gltf")).unwrap();
    assert_eq!(info(&scene).punctual_lights, 3);
}

/// A minimal valid glTF: one triangle, optionally with a camera, as JSON with a data-URI buffer.
pub fn triangle_gltf(with_camera: bool, extra_material: &str) -> String {
    use base64::Engine;
    let mut bin = Vec::new();
    for v in [[0f32, 0., 0.], [1., 0., 0.], [0., 1., 0.]] {
        for c in v {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let data = base64::engine::general_purpose::STANDARD.encode(&bin);
    let (cam_node, cams) = if with_camera {
        (
            r#",{"camera":0,"translation":[0,0,3]}"#,
            r#","cameras":[{"type":"perspective","perspective":{"yfov":0.8,"znear":0.01}}]"#,
        )
    } else {
        ("", "")
    };
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0{}]}}],
        "nodes":[{{"mesh":0}}{cam_node}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.5,0.5,0.5,1]}}{extra_material}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}],
        "buffers":[{{"byteLength":36,"uri":"data:application/octet-stream;base64,{data}"}}]{cams}}}"#,
        if with_camera { ",1" } else { "" }
    )
}

#[test]
fn a_minimal_scene_loads_with_flat_normals() {
    let scene = load_bytes(triangle_gltf(true, "").as_bytes(), None).unwrap();
    assert_eq!(scene.mesh.len(), 1);
    assert_eq!(scene.mesh.normals_of(0), [glam::Vec3::Z; 3]);
    assert_eq!(scene.cameras.len(), 1);
}

#[test]
fn a_scene_without_a_camera_loads_but_cannot_be_viewed() {
    let scene = load_bytes(triangle_gltf(false, "").as_bytes(), None).unwrap();
    assert_eq!(scene.camera(None).unwrap_err().to_string(), "the scene has no perspective camera");
}

#[test]
fn bad_input_is_refused_with_a_message_that_says_why() {
    let cases: Vec<(Vec<u8>, &str)> = vec![
        (b"not a gltf".to_vec(), "invalid glTF"),
        (b"glTF\x02\x00\x00\x00\x10\x00\x00\x00garbage!".to_vec(), "invalid glTF"),
        (
            triangle_gltf(true, r#","extensions":{"TESSERA_materials_phong":{"kd":[0.6,0.6,0.6],"ks":[0.6,0.6,0.6],"n":10}}"#).into_bytes(),
            "material 0: TESSERA_materials_phong",
        ),
        (triangle_gltf(true, r#","extensions":{"TESSERA_materials_phong":{"kd":[0.5],"ks":[0.5,0.5,0.5],"n":10}}"#).into_bytes(), "kd must be an array of 3"),
        (triangle_gltf(true, "").replace("\"count\":3", "\"count\":0").into_bytes(), "mesh 0 primitive 0: POSITION accessor count 0"),
        (triangle_gltf(true, "").replace("\"count\":3", "\"count\":4").into_bytes(), "reads past the end of buffer view 0"),
        (triangle_gltf(true, "").replace(r#""uri":"data:"#, r#""uri":"../../etc/passwd","x":"data:"#).into_bytes(), "leaves the scene's directory"),
    ];
    for (bytes, expect) in cases {
        match load_bytes(&bytes, None) {
            Ok(_) => panic!("accepted bad input expecting {expect:?}"),
            Err(e) => assert!(e.0.contains(expect), "{:?} does not mention {expect:?}", e.0),
        }
    }
}
mod animation;
mod effects;
mod far;
mod formats;
mod fuzz;
mod hostile;
mod memory;
mod sequence;
