//! A glTF file parsed once, from which the scene at any time of any of its animations is made.
//!
//! Decoding (buffers, textures, materials, animation tracks) happens once in [`Sequence::parse`];
//! each frame then walks the node tree with the animated local transforms ([`Sequence::parsed_at`])
//! and builds its BVH, or refits the previous frame's ([`Sequence::scene_after`]). A frame is a
//! pure function of (file, animation, time): far scenes are rebased per frame from that frame's
//! own geometry, and a refitted BVH gives the same hits as a rebuilt one.
use super::animation::{self, Animation, AnimationInfo, Pose};
use super::{Parsed, Preparation, SceneError, geometry, materials, uri, validate};
use crate::tracer::Scene;
use crate::tracer::material::Material;
use crate::tracer::texture::Texture;
use std::borrow::Cow;
use std::path::Path;
use std::sync::Arc;

pub struct Sequence {
    document: gltf::Document,
    buffers: Vec<Vec<u8>>,
    textures: Arc<[Texture]>,
    /// The file's materials followed by glTF's default material.
    materials: Vec<Material>,
    animations: Vec<Animation>,
    max_triangles: u64,
}

impl std::fmt::Debug for Sequence {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Sequence")
            .field("animations", &self.animations.len())
            .finish_non_exhaustive()
    }
}

impl Sequence {
    /// Parses and validates everything but the node tree (which each frame walks).
    pub fn parse(bytes: &[u8], base: Option<&Path>) -> Result<Sequence, SceneError> {
        Sequence::parse_limited(bytes, base, super::DEFAULT_MAX_TRIANGLES)
    }

    /// [`Sequence::parse`] with the triangle limit of [`super::parse_limited`].
    pub fn parse_limited(
        bytes: &[u8],
        base: Option<&Path>,
        max_triangles: u64,
    ) -> Result<Sequence, SceneError> {
        Sequence::parse_file(Cow::Borrowed(bytes), base, max_triangles)
    }

    /// [`Sequence::parse_limited`] taking the file: a `.glb`'s binary chunk then stays where it
    /// is instead of being copied out (the file is mostly that chunk).
    pub fn parse_owned(
        bytes: Vec<u8>,
        base: Option<&Path>,
        max_triangles: u64,
    ) -> Result<Sequence, SceneError> {
        Sequence::parse_file(Cow::Owned(bytes), base, max_triangles)
    }

    fn parse_file(
        bytes: Cow<[u8]>,
        base: Option<&Path>,
        max_triangles: u64,
    ) -> Result<Sequence, SceneError> {
        let (document, blob) = open(bytes)?;
        let buffers = uri::load_buffers(&document, base, blob)?;
        let mut pool = super::textures::TexturePool::load(&document, base, &buffers)?;
        let mut materials = materials::load_materials(&document, &mut pool)?;
        let textures = pool.finish();
        // Primitives without a material use glTF's default material, appended last.
        materials.push(materials::default_material());
        let animations = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            animation::parse(&document, &buffers)
        }))
        .map_err(|_| {
            SceneError::new("malformed animation data (the glTF reader failed on it)")
        })??;
        Ok(Sequence {
            document,
            buffers,
            textures: textures.into(),
            materials,
            animations,
            max_triangles,
        })
    }

    /// The file's animations, in file order.
    pub fn animations(&self) -> Vec<AnimationInfo> {
        self.animations.iter().map(Animation::info).collect()
    }

    /// The scene at `time_s` seconds of animation `animation` (None: the static pose), before
    /// its BVH is built.
    pub fn parsed_at(&self, animation: Option<usize>, time_s: f64) -> Result<Parsed, SceneError> {
        let pose = match animation {
            None => Pose::default(),
            Some(_) if !time_s.is_finite() => {
                return Err(SceneError::new(format!("animation time {time_s} is not finite")));
            }
            Some(i) => self
                .animations
                .get(i)
                .ok_or_else(|| {
                    SceneError::new(format!(
                        "animation {i} does not exist (the scene has {})",
                        self.animations.len()
                    ))
                })?
                .pose(&self.document, time_s),
        };
        let material_count = self.materials.len() - 1;
        // Defence in depth: accessors are bounds-checked first, but a panic inside the gltf crate on
        // some input we did not foresee must still become an error, not a crashed worker.
        let load = || {
            geometry::load(&self.document, &self.buffers, material_count, self.max_triangles, &pose)
        };
        let parts = std::panic::catch_unwind(std::panic::AssertUnwindSafe(load))
            .map_err(|_| SceneError::new("malformed mesh data (the glTF reader failed on it)"))??;
        Ok(Parsed {
            mesh: parts.mesh,
            materials: self.materials.clone(),
            textures: self.textures.clone(),
            cameras: parts.cameras,
            lights: parts.lights,
            animations: self.animations(),
            refittable: animation.is_some(),
        })
    }

    /// The scene at `time_s` of `animation`, its BVH built.
    pub fn scene_at(&self, animation: Option<usize>, time_s: f64) -> Result<Scene, SceneError> {
        Ok(self.parsed_at(animation, time_s)?.build())
    }

    /// [`Sequence::scene_at`], refitting the BVH of `previous` (another frame of this sequence)
    /// when it holds the same triangles, else building it; says which it did.
    pub fn scene_after(
        &self,
        previous: &Scene,
        animation: Option<usize>,
        time_s: f64,
    ) -> Result<(Scene, Preparation), SceneError> {
        Ok(self.parsed_at(animation, time_s)?.build_from(previous))
    }
}

/// The document of a `.gltf` or `.glb` file and the `.glb`'s binary chunk, validated.
fn open(bytes: Cow<[u8]>) -> Result<(gltf::Document, Option<Vec<u8>>), SceneError> {
    // gltf-json 1.4's validator indexes `accessors[POSITION]` unchecked and panics on an index
    // out of range: turn that into an error naming the attribute.
    if bytes.iter().all(u8::is_ascii_whitespace) {
        return Err(SceneError::new("invalid glTF: the scene is empty"));
    }
    validate::glb_container(&bytes).map_err(|e| SceneError::new(format!("invalid glTF: {e}")))?;
    let opened = std::panic::catch_unwind(|| document_and_chunk(&bytes))
        .map_err(|_| SceneError::new(format!("invalid glTF: {}", validate::explain_panic(&bytes))))?
        .map_err(|e| {
            SceneError::new(format!(
                "invalid glTF: {}",
                e.to_string().trim_start_matches("invalid glTF: ")
            ))
        })?;
    let (document, chunk) = opened;
    let blob = chunk.map(|range| match bytes {
        Cow::Owned(mut file) => {
            file.truncate(range.end);
            file.drain(..range.start);
            file
        }
        Cow::Borrowed(file) => file[range].to_vec(),
    });
    Ok((document, blob))
}

/// What `gltf::Gltf::from_slice` reads, with the binary chunk as a range of `bytes` (which
/// that function would copy).
fn document_and_chunk(
    bytes: &[u8],
) -> gltf::Result<(gltf::Document, Option<std::ops::Range<usize>>)> {
    if !bytes.starts_with(b"glTF") {
        return Ok((gltf::Document::from_json(gltf::json::deserialize::from_slice(bytes)?)?, None));
    }
    let glb = gltf::binary::Glb::from_slice(bytes)?;
    let document = gltf::Document::from_json(gltf::json::deserialize::from_slice(&glb.json)?)?;
    let chunk = glb.bin.map(|bin| {
        let start = (bin.as_ptr() as usize)
            .checked_sub(bytes.as_ptr() as usize)
            .expect("Glb::from_slice borrows the chunk from the file");
        start..start + bin.len()
    });
    Ok((document, chunk))
}
