//! Scenes shipped with Tessera (`scenes/`), compiled into the binary so that
//! `tessera render cornell-box` works from any directory.
use std::path::Path;

/// By name, in alphabetical order.
pub const SCENES: &[(&str, &[u8])] = &[
    ("absorption", include_bytes!("../../scenes/absorption.gltf")),
    ("alpha-mask", include_bytes!("../../scenes/alpha-mask.gltf")),
    ("cornell-animated", include_bytes!("../../scenes/cornell-animated.gltf")),
    ("cornell-box", include_bytes!("../../scenes/cornell-box.gltf")),
    ("cornell-small-light", include_bytes!("../../scenes/cornell-small-light.gltf")),
    ("depth-of-field", include_bytes!("../../scenes/depth-of-field.gltf")),
    ("emitters-only", include_bytes!("../../scenes/emitters-only.gltf")),
    ("furnace", include_bytes!("../../scenes/furnace.gltf")),
    ("glass", include_bytes!("../../scenes/glass.gltf")),
    ("glossy", include_bytes!("../../scenes/glossy.gltf")),
    ("many-lights", include_bytes!("../../scenes/many-lights.gltf")),
    ("phong", include_bytes!("../../scenes/phong.gltf")),
    ("punctual", include_bytes!("../../scenes/punctual.gltf")),
    ("textured", include_bytes!("../../scenes/textured.gltf")),
];

pub fn get(name: &str) -> Option<&'static [u8]> {
    SCENES.iter().find(|(n, _)| *n == name).map(|(_, b)| *b)
}

pub fn names() -> Vec<&'static str> {
    SCENES.iter().map(|(n, _)| *n).collect()
}

/// Loads a scene given as a bundled name or a path to a `.gltf`/`.glb` file.
pub fn load(scene: &str) -> anyhow::Result<tessera_render::tracer::Scene> {
    let path = Path::new(scene);
    if path.exists() {
        return Ok(tessera_render::scene::load_path(path)?);
    }
    match get(scene) {
        Some(bytes) => Ok(tessera_render::scene::load_bytes(bytes, None)?),
        None => anyhow::bail!(
            "{scene:?} is neither a file nor a bundled scene ({})",
            names().join(", ")
        ),
    }
}
