//! File formats and glTF features: .glb, external buffers, textures, transforms, topologies.
use super::super::tests::triangle_gltf;
use super::super::*;
use glam::{Vec2, Vec3};

use super::super::pack_glb as glb;

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_le_bytes()).collect()
}

/// A quad as a triangle strip (non-indexed), placed by a node with a mirroring scale.
fn strip_json(buffer: &str, extra: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"mesh":0,"scale":[-1,1,1],"translation":[0,0,-2]}},{{"camera":0,"translation":[0,0,3]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0,"TEXCOORD_0":1}},"mode":5{extra}}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
                     {{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}}],
        "bufferViews":[{{"buffer":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":32}}],
        "buffers":[{{"byteLength":80{buffer}}}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.8,"znear":0.01}}}}]}}"#
    )
}

fn strip_bin() -> Vec<u8> {
    let mut b = f32_bytes(&[0., 0., 0., 1., 0., 0., 0., 1., 0., 1., 1., 0.]);
    b.extend(f32_bytes(&[0., 1., 1., 1., 0., 0., 1., 0.]));
    b
}

fn check_strip(scene: &crate::tracer::Scene) {
    assert_eq!(scene.mesh.len(), 2, "a 4-vertex strip is two triangles");
    for (i, tri) in scene.mesh.positions.iter().enumerate() {
        assert!(tri.iter().all(|p| p.z == -2.0 && p.x <= 0.0), "mirrored and translated: {tri:?}");
        // Winding was swapped to undo the mirror, so faces still point at the camera (+Z).
        let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
        assert!(n.z > 0.0, "triangle {i} faces +Z");
        assert_eq!(scene.mesh.normals_of(i)[0], Vec3::Z);
    }
    assert!(scene.mesh.uvs[0][0].contains(&Vec2::new(0.0, 1.0)));
}

#[test]
fn glb_with_a_binary_chunk_loads() {
    let scene = load_bytes(&glb(&strip_json("", ""), &strip_bin()), None).unwrap();
    check_strip(&scene);
}

#[test]
fn gltf_with_an_external_buffer_loads_from_its_directory() {
    let dir = std::env::temp_dir().join(format!("tessera-ext-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("quad data.bin"), strip_bin()).unwrap();
    std::fs::write(dir.join("quad.gltf"), strip_json(r#","uri":"quad%20data.bin""#, "")).unwrap();
    check_strip(&load_path(&dir.join("quad.gltf")).unwrap());
    let err =
        load_bytes(strip_json(r#","uri":"quad%20data.bin""#, "").as_bytes(), None).unwrap_err();
    assert!(err.0.contains("buffer 0") && err.0.contains("single file"), "{err}");
}

#[test]
fn points_and_lines_are_refused() {
    let err = load_bytes(
        &glb(&strip_json("", "").replace(r#""mode":5"#, r#""mode":1"#), &strip_bin()),
        None,
    )
    .unwrap_err();
    assert!(err.0.contains("not a triangle mode"), "{err}");
}

#[test]
fn base_colour_texture_is_decoded_from_srgb() {
    let mut png = Vec::new();
    let img = image::RgbaImage::from_pixel(2, 2, image::Rgba([188, 188, 188, 255]));
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    use base64::Engine;
    let uri =
        format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png));
    let material = r#","baseColorTexture":{"index":0}}"#;
    let json = triangle_gltf(true, "")
        .replace(
            r#""baseColorFactor":[0.5,0.5,0.5,1]}"#,
            &format!(r#""baseColorFactor":[0.5,0.5,0.5,1]{material}"#),
        )
        .replace(
            r#""cameras":"#,
            &format!(r#""textures":[{{"source":0}}],"images":[{{"uri":"{uri}"}}],"cameras":"#),
        );
    let scene = load_bytes(json.as_bytes(), None).unwrap();
    assert_eq!(scene.textures.len(), 1);
    let t = scene.textures[0].sample(Vec2::splat(0.5));
    assert!((t.x - 0.5029).abs() < 2e-3, "sRGB 188 decodes to ≈0.503 linear, got {}", t.x);
    assert_eq!(scene.materials[0].base_color_texture.unwrap().texture, 0);
}

#[test]
fn tangents_follow_the_node_transform_and_mirroring_flips_their_handedness() {
    let json = strip_json("", "")
        .replace(r#""TEXCOORD_0":1}"#, r#""TEXCOORD_0":1,"TANGENT":2}"#)
        .replace(r#"{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"}]"#,
            r#"{"bufferView":1,"componentType":5126,"count":4,"type":"VEC2"},{"bufferView":2,"componentType":5126,"count":4,"type":"VEC4"}]"#)
        .replace(r#"{"buffer":0,"byteOffset":48,"byteLength":32}]"#, r#"{"buffer":0,"byteOffset":48,"byteLength":32},{"buffer":0,"byteOffset":80,"byteLength":64}]"#)
        .replace(r#""byteLength":80}"#, r#""byteLength":144}"#);
    let mut bin = strip_bin();
    bin.extend(f32_bytes(&[1., 0., 0., 1.].repeat(4)));
    let scene = load_bytes(&glb(&json, &bin), None).unwrap();
    // scale (−1, 1, 1) maps +x to −x and mirrors the frame: w flips from +1 to −1.
    assert!(
        scene.mesh.tangents.iter().flatten().all(|t| *t == glam::Vec4::new(-1.0, 0.0, 0.0, -1.0)),
        "{:?}",
        scene.mesh.tangents
    );
    // Without TANGENT anywhere, no tangents are stored (normal maps derive them from UVs).
    assert!(
        load_bytes(&glb(&strip_json("", ""), &strip_bin()), None).unwrap().mesh.tangents.is_empty()
    );
}

#[test]
fn a_texture_in_colour_and_data_slots_is_decoded_once_per_colour_space() {
    let mut png = Vec::new();
    let img = image::RgbaImage::from_pixel(2, 2, image::Rgba([188, 188, 188, 255]));
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    use base64::Engine;
    let uri =
        format!("data:image/png;base64,{}", base64::engine::general_purpose::STANDARD.encode(&png));
    let material = r#","baseColorTexture":{"index":0}},"normalTexture":{"index":0,"scale":0.5}"#;
    let json = triangle_gltf(true, "")
        .replace(
            r#""baseColorFactor":[0.5,0.5,0.5,1]}"#,
            &format!(r#""baseColorFactor":[0.5,0.5,0.5,1]{material}"#),
        )
        .replace(
            r#""cameras":"#,
            &format!(r#""textures":[{{"source":0}}],"images":[{{"uri":"{uri}"}}],"cameras":"#),
        );
    let scene = load_bytes(json.as_bytes(), None).unwrap();
    assert_eq!(scene.textures.len(), 2, "one sRGB-decoded and one linear copy");
    let m = &scene.materials[0];
    let (colour, normal) = (m.base_color_texture.unwrap(), m.normal_texture.unwrap());
    assert_eq!(normal.scale, 0.5);
    let linear = scene.textures[normal.texture.texture as usize].sample(Vec2::splat(0.5)).x;
    let decoded = scene.textures[colour.texture as usize].sample(Vec2::splat(0.5)).x;
    assert!(
        (linear - 188.0 / 255.0).abs() < 1e-6 && (decoded - 0.5029).abs() < 2e-3,
        "{linear} {decoded}"
    );
}

#[test]
fn a_mesh_without_texture_coordinates_stores_none() {
    let with = load_bytes(&glb(&strip_json("", ""), &strip_bin()), None).unwrap();
    assert_eq!(with.mesh.uvs.len(), 2, "the strip's TEXCOORD_0 is kept");
    let json = strip_json("", "").replace(r#""POSITION":0,"TEXCOORD_0":1"#, r#""POSITION":0"#);
    let without = load_bytes(&glb(&json, &strip_bin()), None).unwrap();
    assert!(without.mesh.uvs.is_empty(), "all-zero UVs take no memory");
    assert_eq!(without.mesh.uvs_of(1), [[Vec2::ZERO; 3]; 2], "and still read as zero");
    assert_eq!(without.mesh.positions, with.mesh.positions);
}

#[test]
fn a_flat_mesh_keeps_one_normal_per_triangle_and_reads_the_same() {
    let flat = load_bytes(&glb(&strip_json("", ""), &strip_bin()), None).unwrap();
    assert!(
        flat.mesh.normals.is_empty() && flat.mesh.flat_normals.len() == 2,
        "12 bytes a triangle, not 36"
    );
    assert_eq!(flat.mesh.normals_of(1), [Vec3::Z; 3]);
    assert!(flat.mesh.tangents.is_empty());
}

#[test]
fn a_mesh_stores_corners_only_from_the_first_triangle_that_needs_them() {
    let mut mesh = crate::tracer::scene::Mesh::default();
    mesh.push_flat([Vec3::ZERO, Vec3::X, Vec3::Y], 0);
    mesh.push_flat([Vec3::ZERO, Vec3::Y, Vec3::X], 0);
    let flat = [mesh.normals_of(0), mesh.normals_of(1)];
    assert_eq!((mesh.normals.len(), mesh.flat_normals.len(), mesh.uvs.len()), (0, 2, 0));
    // Equal as numbers, not as bits: a sign of zero can decide a shading frame's orientation.
    let mut n = flat[1];
    n[2].x = -n[2].x;
    let uv = [[Vec2::ONE; 3], [Vec2::ZERO; 3]];
    mesh.positions.push([Vec3::ZERO, Vec3::Z, Vec3::X]);
    mesh.push_attributes(n, Some(uv), None, 1);
    assert_eq!(
        (mesh.normals.len(), mesh.flat_normals.len(), mesh.uvs.len(), mesh.tangents.len()),
        (3, 0, 3, 0)
    );
    assert_eq!(
        [mesh.normals_of(0), mesh.normals_of(1), mesh.normals_of(2)],
        [flat[0], flat[1], n],
        "the same normals read back"
    );
    assert_eq!([mesh.uvs_of(0), mesh.uvs_of(2)], [[[Vec2::ZERO; 3]; 2], uv]);
    mesh.push_flat([Vec3::ZERO, Vec3::X, Vec3::Y], 0);
    assert_eq!((mesh.normals.len(), mesh.uvs.len()), (4, 4), "per corner once needed");
    assert_eq!(mesh.material, [0, 0, 1, 0]);

    // A mesh whose vectors were filled directly compacts to the same reading.
    let mut direct = crate::tracer::scene::Mesh {
        normals: vec![flat[0], flat[1]],
        uvs: vec![[[Vec2::ZERO; 3]; 2]; 2],
        ..Default::default()
    };
    direct.compact();
    assert_eq!((direct.normals.len(), direct.flat_normals.len(), direct.uvs.len()), (0, 2, 0));
    assert_eq!([direct.normals_of(0), direct.normals_of(1)], flat);
}
