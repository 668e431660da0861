//! The inputs of the bad-input suite (`tests_bad_input.rs`): small valid scenes and results,
//! and ways to break them.
use super::super::tests::sums_for;
use tessera_proto::Lease;

/// A camera and one triangle with these corners, as a `.glb`; `edits` are (from, to) string
/// replacements in its JSON, `image` is appended to the binary chunk as buffer view 1.
pub fn scene(corners: [[f32; 3]; 3], edits: &[(&str, &str)], image: Option<&[u8]>) -> Vec<u8> {
    let mut bin: Vec<u8> = corners.iter().flatten().flat_map(|c| c.to_le_bytes()).collect();
    let image_view = image.map_or(String::new(), |png| {
        format!(r#",{{"buffer":0,"byteOffset":36,"byteLength":{}}}"#, png.len())
    });
    bin.extend_from_slice(image.unwrap_or_default());
    let mut json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0,1]}}],
        "nodes":[{{"mesh":0}},{{"camera":0,"translation":[0,0,3]}}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"material":0}}]}}],
        "materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[0.5,0.5,0.5,1]}}}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}}],
        "bufferViews":[{{"buffer":0,"byteLength":36}}{image_view}],
        "buffers":[{{"byteLength":{}}}],
        "cameras":[{{"type":"perspective","perspective":{{"yfov":0.8,"znear":0.01}}}}]}}"#,
        bin.len()
    );
    for (from, to) in edits {
        assert!(json.contains(from), "{from:?} not in the scene");
        json = json.replace(from, to);
    }
    glb(&json, &bin)
}

pub const TRIANGLE: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

pub fn triangle() -> Vec<u8> {
    scene(TRIANGLE, &[], None)
}

/// The triangle with a base-colour texture whose image is `png`.
pub fn textured(png: &[u8], texture_index: usize) -> Vec<u8> {
    let edits = [
        (r#""baseColorFactor":[0.5,0.5,0.5,1]"#, format!(r#""baseColorFactor":[0.5,0.5,0.5,1],"baseColorTexture":{{"index":{texture_index}}}"#)),
        (r#""cameras":"#, r#""textures":[{"source":0}],"images":[{"bufferView":1,"mimeType":"image/png"}],"cameras":"#.to_string()),
    ];
    let edits: Vec<(&str, &str)> = edits.iter().map(|(a, b)| (*a, b.as_str())).collect();
    scene(TRIANGLE, &edits, Some(png))
}

/// The triangle's buffer given by URI instead of the binary chunk (a self-contained .gltf).
pub fn with_buffer_uri(uri: &str) -> Vec<u8> {
    let bytes = scene(
        TRIANGLE,
        &[(
            r#""buffers":[{"byteLength":36}]"#,
            &format!(r#""buffers":[{{"byteLength":36,"uri":"{uri}"}}]"#),
        )],
        None,
    );
    let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    bytes[20..20 + json_len].to_vec()
}

/// A `width`×`height` PNG header on a 1×1 image: decoders learn the size before any pixel.
pub fn png_declaring(width: u32, height: u32) -> Vec<u8> {
    let mut png = Vec::new();
    image::RgbaImage::from_pixel(1, 1, image::Rgba([255, 0, 0, 255]))
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    // Signature (8), IHDR length (4), "IHDR" (4), width, height (big-endian), …, CRC at 29.
    png[16..20].copy_from_slice(&width.to_be_bytes());
    png[20..24].copy_from_slice(&height.to_be_bytes());
    let crc = crc32fast::hash(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    png
}

pub use tessera_render::scene::pack_glb as glb;

pub fn patched(mut bytes: Vec<u8>, at: usize, with: &[u8]) -> Vec<u8> {
    bytes[at..at + with.len()].copy_from_slice(with);
    bytes
}

/// The lease's valid result with `f` applied.
pub fn result_with(l: &Lease, f: impl FnOnce(&mut tessera_proto::PartialSums)) -> Vec<u8> {
    let mut s = sums_for(l, 0.5);
    f(&mut s);
    s.encode()
}
