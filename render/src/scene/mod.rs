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
//! optional thin lens in `extras`; `KHR_lights_punctual`; animations of node translation,
//! rotation and scale ([`animation`]), played frame by frame through a [`Sequence`] (the file
//! parsed once; each frame's BVH built, or refitted from another frame's).
//!
//! Every error names what is wrong and where ("mesh 3 primitive 0: POSITION accessor count 0").
//! External files may only be plain relative paths below the scene's own directory.
mod accessors;
pub mod animation;
mod budget;
mod camera_light;
mod corners;
pub mod effects;
mod geometry;
mod materials;
mod sequence;
mod textures;
mod uri;
mod validate;

pub use animation::AnimationInfo;
pub use sequence::Sequence;

use crate::tracer::Scene;
use crate::tracer::accel::{Accel, BvhKind, Faces};
use std::path::Path;
use std::sync::Arc;

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
    let bytes = std::fs::read(path)
        .map_err(|e| SceneError::new(format!("cannot read {}: {e}", path.display())))?;
    // The file (a .glb's binary chunk) is freed before the build, whose peak is most of a
    // large scene's memory.
    let parsed =
        Sequence::parse_owned(bytes, path.parent(), DEFAULT_MAX_TRIANGLES)?.parsed_at(None, 0.0)?;
    Ok(parsed.build())
}

/// Loads a glTF document from memory. With `base` None, only self-contained files load.
pub fn load_bytes(bytes: &[u8], base: Option<&Path>) -> Result<Scene, SceneError> {
    Ok(parse(bytes, base)?.build())
}

/// A validated scene whose BVH is not built yet: cheap to make, enough to describe the scene.
pub struct Parsed {
    mesh: crate::tracer::scene::Mesh,
    materials: Vec<crate::tracer::material::Material>,
    textures: Arc<[crate::tracer::texture::Texture]>,
    cameras: Vec<crate::tracer::camera::Camera>,
    lights: Vec<crate::tracer::light::Light>,
    animations: Vec<AnimationInfo>,
    /// A frame of an animation: its BVH keeps what the next frame's refit needs.
    refittable: bool,
}

impl Parsed {
    pub fn build(mut self) -> Scene {
        // Before the build, whose peak is most of a large scene's memory.
        self.mesh.compact();
        let accel = match self.refittable {
            true => Accel::build_refittable(&self.mesh.positions, BvhKind::Wide),
            false => Accel::build(&self.mesh.positions, BvhKind::Wide),
        };
        // After the build, whose peak they would raise by 12 bytes a triangle.
        let faces = Faces::of(&self.mesh.positions);
        self.with_accel(accel, faces)
    }

    /// The scene, its BVH refitted from `previous` (another frame of the same sequence) when
    /// that holds the same triangles, else built: see [`Accel::refit`]. A refit that would wear
    /// the tree out ([`Accel::worn`]: its walk half as costly again as the tree's as built) is
    /// dropped for a build, whose tree later frames refit.
    pub fn build_from(mut self, previous: &Scene) -> (Scene, Preparation) {
        self.mesh.compact();
        // Once per frame: the refit, a build if it is refused, and the scene's shading read them.
        let faces = Faces::of(&self.mesh.positions);
        match previous.accel.refit_with_faces(&self.mesh.positions, &faces) {
            Some(accel) if !accel.worn() => (self.with_accel(accel, faces), Preparation::Refit),
            _ => {
                let accel = Accel::build_with_normals(
                    &self.mesh.positions,
                    &faces.normals,
                    BvhKind::Wide,
                    self.refittable,
                );
                (self.with_accel(accel, faces), Preparation::Build)
            }
        }
    }

    fn with_accel(self, accel: Accel, faces: Faces) -> Scene {
        Scene::with_accel(
            self.mesh,
            self.materials,
            self.textures,
            self.cameras,
            self.lights,
            (accel, faces),
        )
    }

    pub fn triangles(&self) -> usize {
        self.mesh.len()
    }

    pub fn cameras(&self) -> Vec<String> {
        self.cameras.iter().map(|c| c.name.clone()).collect()
    }

    /// The light-transport features this scene calls for (see [`effects`]).
    pub fn effects(&self) -> Vec<String> {
        effects::of(&self.mesh, &self.materials, &self.textures, &self.cameras, &self.lights)
    }

    /// The file's animations, in file order (validated: see [`animation`]).
    pub fn animations(&self) -> Vec<AnimationInfo> {
        self.animations.clone()
    }
}

/// How a frame's BVH was made from the previous frame's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Preparation {
    Build,
    Refit,
}

/// The animation a job's `selector` names (a name first, then a decimal index); None selects
/// the first animation, or none when the scene has none. The error lists the scene's animations.
pub fn resolve_animation(
    parsed: &Parsed,
    selector: Option<&str>,
) -> Result<Option<usize>, SceneError> {
    animation::resolve(&parsed.animations, selector)
}

/// Triangles [`parse`] accepts; a coordinator configures its own limit with [`parse_limited`].
pub const DEFAULT_MAX_TRIANGLES: u64 = 50_000_000;

/// Parses and validates a glTF document without building acceleration structures. Animated
/// nodes are in their static (rest) pose; frames come from [`Sequence`].
pub fn parse(bytes: &[u8], base: Option<&Path>) -> Result<Parsed, SceneError> {
    parse_limited(bytes, base, DEFAULT_MAX_TRIANGLES)
}

/// [`parse`] refusing scenes of more than `max_triangles` triangles before reading their
/// vertices (counted from accessor counts, so a "triangle bomb" costs no memory).
pub fn parse_limited(
    bytes: &[u8],
    base: Option<&Path>,
    max_triangles: u64,
) -> Result<Parsed, SceneError> {
    Sequence::parse_limited(bytes, base, max_triangles)?.parsed_at(None, 0.0)
}

/// A short description of a loaded scene.
pub fn info(scene: &Scene) -> SceneInfo {
    SceneInfo {
        triangles: scene.mesh.len(),
        emissive_triangles: scene
            .tri_light
            .iter()
            .filter(|&&l| l != crate::tracer::scene::NO_LIGHT)
            .count(),
        punctual_lights: scene.lights.len()
            - scene.tri_light.iter().filter(|&&l| l != crate::tracer::scene::NO_LIGHT).count(),
        cameras: scene.cameras.iter().map(|c| c.name.clone()).collect(),
    }
}

#[cfg(test)]
mod tests;

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
