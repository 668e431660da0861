//! glTF 2.0 → [`Scene`]: the only part of the worker that parses files.
//!
//! Supported: `.gltf` (buffers and images as data URIs or files next to it) and `.glb`; every
//! node of the default scene with its transform; indexed and non-indexed triangles, strips and
//! fans; normals (flat where missing); two UV sets; tangents (`TANGENT`, else derived from UVs);
//! the metallic-roughness material with `KHR_materials_specular`, `KHR_materials_ior`,
//! `KHR_materials_emissive_strength`, base-colour, metallic-roughness, normal and emissive
//! textures (PNG/JPEG) with `KHR_texture_transform`, and the project's
//! `TESSERA_materials_phong`; `KHR_materials_transmission`
//! and `KHR_materials_volume` (glass, absorption); `alphaMode: MASK`; perspective cameras with an
//! optional thin lens in `extras`; `KHR_lights_punctual`.
//!
//! Every error names what is wrong and where ("mesh 3 primitive 0: POSITION accessor count 0").
//! External files may only be plain relative paths below the scene's own directory.
mod accessors;
pub mod effects;
mod geometry;
mod materials;
mod textures;
mod uri;
mod validate;

use crate::tracer::Scene;
use std::path::Path;

#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("{0}")]
pub struct SceneError(pub String);

impl SceneError {
    pub fn new(msg: impl Into<String>) -> SceneError {
        SceneError(msg.into())
    }
}

/// What `load_*` reports about a scene besides the scene itself.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneInfo {
    pub triangles: usize,
    pub emissive_triangles: usize,
    pub punctual_lights: usize,
    pub cameras: Vec<String>,
}

/// Loads a `.gltf` or `.glb` file; external resources resolve relative to its directory.
pub fn load_path(path: &Path) -> Result<Scene, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::new(format!("cannot read {}: {e}", path.display())))?;
    load_bytes(&bytes, path.parent())
}

/// Loads a glTF document from memory. With `base` None, only self-contained files load.
pub fn load_bytes(bytes: &[u8], base: Option<&Path>) -> Result<Scene, SceneError> {
    Ok(parse(bytes, base)?.build())
}

/// A validated scene whose BVH is not built yet: cheap to make, enough to describe the scene.
pub struct Parsed {
    mesh: crate::tracer::scene::Mesh,
    materials: Vec<crate::tracer::material::Material>,
    textures: Vec<crate::tracer::texture::Texture>,
    cameras: Vec<crate::tracer::camera::Camera>,
    lights: Vec<crate::tracer::light::Light>,
}

impl Parsed {
    pub fn build(self) -> Scene {
        Scene::new(self.mesh, self.materials, self.textures, self.cameras, self.lights)
    }

    pub fn triangles(&self) -> usize {
        self.mesh.len()
    }

    pub fn cameras(&self) -> Vec<String> {
        self.cameras.iter().map(|c| c.name.clone()).collect()
    }

    /// The light-transport features this scene calls for (see [`effects`]).
    pub fn effects(&self) -> Vec<String> {
        effects::of(&self.mesh, &self.materials, &self.cameras, &self.lights)
    }
}

/// Triangles [`parse`] accepts; a coordinator configures its own limit with [`parse_limited`].
pub const DEFAULT_MAX_TRIANGLES: u64 = 50_000_000;

/// Parses and validates a glTF document without building acceleration structures.
pub fn parse(bytes: &[u8], base: Option<&Path>) -> Result<Parsed, SceneError> {
    parse_limited(bytes, base, DEFAULT_MAX_TRIANGLES)
}

/// [`parse`] refusing scenes of more than `max_triangles` triangles before reading their
/// vertices (counted from accessor counts, so a "triangle bomb" costs no memory).
pub fn parse_limited(bytes: &[u8], base: Option<&Path>, max_triangles: u64) -> Result<Parsed, SceneError> {
    // gltf-json 1.4's validator indexes `accessors[POSITION]` unchecked and panics on an index
    // out of range: turn that into an error naming the attribute.
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(SceneError::new("invalid glTF: the scene is empty"));
    }
    validate::glb_container(bytes).map_err(|e| SceneError::new(format!("invalid glTF: {e}")))?;
    let gltf = std::panic::catch_unwind(|| gltf::Gltf::from_slice(bytes))
        .map_err(|_| SceneError::new(format!("invalid glTF: {}", validate::explain_panic(bytes))))?
        .map_err(|e| SceneError::new(format!("invalid glTF: {}", e.to_string().trim_start_matches("invalid glTF: "))))?;
    let doc = gltf.document;
    let buffers = uri::load_buffers(&doc, base, gltf.blob)?;
    let mut pool = textures::TexturePool::load(&doc, base, &buffers)?;
    let mut materials = materials::load_materials(&doc, &mut pool)?;
    let textures = pool.finish();
    // Defence in depth: accessors are bounds-checked first, but a panic inside the gltf crate on
    // some input we did not foresee must still become an error, not a crashed worker.
    let parts = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| geometry::load(&doc, &buffers, materials.len(), max_triangles)))
        .map_err(|_| SceneError::new("malformed mesh data (the glTF reader failed on it)"))??;
    // Primitives without a material use glTF's default material, appended last.
    materials.push(materials::default_material());
    Ok(Parsed { mesh: parts.mesh, materials, textures, cameras: parts.cameras, lights: parts.lights })
}

/// A short description of a loaded scene.
pub fn info(scene: &Scene) -> SceneInfo {
    SceneInfo {
        triangles: scene.mesh.len(),
        emissive_triangles: scene.tri_light.iter().filter(|&&l| l != crate::tracer::scene::NO_LIGHT).count(),
        punctual_lights: scene.lights.len()
            - scene.tri_light.iter().filter(|&&l| l != crate::tracer::scene::NO_LIGHT).count(),
        cameras: scene.cameras.iter().map(|c| c.name.clone()).collect(),
    }
}

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_formats;

#[cfg(test)]
mod tests_far;
#[cfg(test)]
mod tests_fuzz;
#[cfg(test)]
mod tests_hostile;
#[cfg(test)]
mod tests_effects;

/// Packs a glTF JSON document and its binary buffer into a `.glb` container (glTF 2.0 §4.4:
/// 12-byte header, a JSON chunk padded with spaces, a BIN chunk padded with zeros).
pub fn pack_glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let (mut j, mut b) = (json.as_bytes().to_vec(), bin.to_vec());
    j.resize(j.len().next_multiple_of(4), b' ');
    b.resize(b.len().next_multiple_of(4), 0);
    let mut out = Vec::with_capacity(28 + j.len() + b.len());
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((28 + j.len() + b.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}
