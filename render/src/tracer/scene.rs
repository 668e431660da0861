//! The renderable scene: world-space triangles, materials, textures, lights, cameras and the BVH.
//!
//! Built once per scene (by [`crate::scene`] from glTF, or directly in tests) and then shared
//! read-only by every thread and every unit that renders it.
use crate::tracer::accel::{Accel, BvhKind, Faces, PARALLEL_GRAIN};
use crate::tracer::camera::{Camera, CameraError};
use crate::tracer::effects::Effects;
use crate::tracer::light::{EmissiveTexture, Light, LightSampler, LightTree};
use crate::tracer::material::Material;
pub use crate::tracer::mesh::Mesh;
use crate::tracer::texture::Texture;
use glam::Vec3;
use rayon::prelude::*;
use std::sync::Arc;

pub struct Scene {
    pub mesh: Mesh,
    pub materials: Vec<Material>,
    /// Shared: the frames of an animation reuse one set of decoded textures.
    pub textures: Arc<[Texture]>,
    pub cameras: Vec<Camera>,
    /// Area lights (one per emissive triangle of non-zero area) followed by punctual lights.
    pub lights: Vec<Light>,
    /// The area lights (`lights[..tree.len()]`) in a tree, when there are any. Light samples
    /// choose through it (favouring the lights near a point) as the job's [`LightSampler`]
    /// says: [`Scene::light_tree_for`]; `auto` does where `effects` has `LIGHT_TREE`
    /// ([`LightTree::suits`]).
    pub light_tree: Option<LightTree>,
    /// Triangle → index in `lights`, or `NO_LIGHT`.
    pub tri_light: Vec<u32>,
    /// Unit geometric normal per triangle, from f64 (zero for degenerate triangles, which
    /// the BVH leaves out).
    pub face_normals: Vec<Vec3>,
    pub accel: Accel,
    /// Centre and radius of a sphere bounding all geometry (for infinite lights).
    pub bounds_centre: Vec3,
    pub bounds_radius: f32,
    /// The effects of the scene's used materials and its lights (not cameras, not the job's
    /// background: see [`Scene::effects_for`]).
    pub effects: Effects,
}

pub const NO_LIGHT: u32 = u32::MAX;

impl std::fmt::Debug for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Scene")
            .field("triangles", &self.mesh.len())
            .field("materials", &self.materials.len())
            .field("lights", &self.lights.len())
            .field("cameras", &self.cameras.len())
            .finish_non_exhaustive()
    }
}

impl Scene {
    /// Builds lights and the BVH. `punctual` are the scene's non-geometric lights.
    pub fn new(
        mesh: Mesh,
        materials: Vec<Material>,
        textures: impl Into<Arc<[Texture]>>,
        cameras: Vec<Camera>,
        punctual: Vec<Light>,
    ) -> Scene {
        Scene::with_bvh(mesh, materials, textures, cameras, punctual, BvhKind::Wide)
    }

    pub fn with_bvh(
        mesh: Mesh,
        materials: Vec<Material>,
        textures: impl Into<Arc<[Texture]>>,
        cameras: Vec<Camera>,
        punctual: Vec<Light>,
        kind: BvhKind,
    ) -> Scene {
        let mut mesh = mesh;
        mesh.compact();
        let accel = Accel::build(&mesh.positions, kind);
        let faces = Faces::of(&mesh.positions);
        Scene::with_accel(mesh, materials, textures.into(), cameras, punctual, (accel, faces))
    }

    /// Builds lights around an acceleration structure made for `mesh.positions` (e.g. by
    /// [`Accel::refit_with_faces`]) and the [`Faces`] it was made with.
    pub fn with_accel(
        mesh: Mesh,
        materials: Vec<Material>,
        textures: Arc<[Texture]>,
        cameras: Vec<Camera>,
        punctual: Vec<Light>,
        (accel, faces): (Accel, Faces),
    ) -> Scene {
        let mut mesh = mesh;
        mesh.compact();
        let Faces { normals: face_normals, solid_box } = faces;
        assert_eq!(face_normals.len(), mesh.len(), "one face normal per triangle");
        let (mut lights, tri_light) = area_lights(&mesh, &materials, &textures);
        let light_tree = LightTree::over(&lights);
        let scatters = |t: usize| materials[mesh.material[t] as usize].scatters();
        let suits_tree =
            light_tree.as_ref().is_some_and(|t| t.suits(&lights, &mesh.positions, scatters));
        lights.extend(punctual);
        let (bounds_centre, bounds_radius) = bounding_sphere(solid_box);
        let mut used = vec![false; materials.len()];
        mesh.material.iter().for_each(|&m| used[m as usize] = true);
        let used_materials = materials.iter().zip(&used).filter(|(_, u)| **u).map(|(m, _)| m);
        let mut effects = Effects::analyse(used_materials, &lights);
        if suits_tree {
            effects = effects | Effects::LIGHT_TREE;
        }
        Scene {
            mesh,
            materials,
            textures,
            cameras,
            lights,
            light_tree,
            tri_light,
            face_normals,
            accel,
            bounds_centre,
            bounds_radius,
            effects,
        }
    }

    /// The tree a job's light samples choose through, if its `sampler` uses one here.
    pub fn light_tree_for(&self, sampler: LightSampler) -> Option<&LightTree> {
        self.light_tree
            .as_ref()
            .filter(|_| sampler.uses_tree(self.effects.contains(Effects::LIGHT_TREE)))
    }

    /// The effects of a render through `camera` with the job's `background`.
    pub fn effects_for(&self, camera: &Camera, background: Vec3) -> Effects {
        let mut e = self.effects;
        if camera.has_depth_of_field() {
            e = e | Effects::DEPTH_OF_FIELD;
        }
        if background.max_element() > 0.0 {
            e = e | Effects::BACKGROUND;
        }
        e
    }

    /// The most scattering events a path needs in a render with the job's `background`:
    /// 0 when the camera can see nothing but emitters — no material scatters light, or
    /// nothing emits at all (no lights, black background) — else unlimited (`u32::MAX`).
    /// Renders use min(job's max_depth, this): paths stop where nothing more can be found.
    pub fn needed_depth(&self, background: Vec3) -> u32 {
        let dark = self.lights.is_empty() && !(background.max_element() > 0.0);
        if self.effects.contains(Effects::NO_SCATTERING) || dark { 0 } else { u32::MAX }
    }

    pub fn camera(&self, name: Option<&str>) -> Result<&Camera, CameraError> {
        match name {
            Some(n) => {
                self.cameras.iter().find(|c| c.name == n).ok_or_else(|| CameraError::Unknown {
                    name: n.to_string(),
                    names: self.cameras.iter().map(|c| c.name.clone()).collect(),
                })
            }
            None => self.cameras.first().ok_or(CameraError::Missing),
        }
    }
}

/// One light per emissive triangle of non-zero area, in triangle order, and each triangle's
/// index among them (`NO_LIGHT` if none). The emissive triangles are found over the worker's
/// threads: an animation's frame makes its lights anew from a million triangles, few of them lit.
pub(crate) fn area_lights(
    mesh: &Mesh,
    materials: &[Material],
    textures: &[Texture],
) -> (Vec<Light>, Vec<u32>) {
    let emissive: Vec<bool> = materials.iter().map(Material::is_emissive).collect();
    let lit: Vec<u32> = match emissive.contains(&true) {
        true => (0..mesh.len() as u32)
            .into_par_iter()
            .with_min_len(PARALLEL_GRAIN)
            .filter(|&i| emissive[mesh.material[i as usize] as usize])
            .collect(),
        false => Vec::new(),
    };
    let mut lights = Vec::new();
    let mut tri_light = vec![NO_LIGHT; mesh.len()];
    let mut means = vec![None; textures.len()];
    for i in lit.into_iter().map(|i| i as usize) {
        let m = &materials[mesh.material[i] as usize];
        if let Some(mut l) =
            Light::triangle(i as u32, &mesh.positions[i], m.emission, m.double_sided)
        {
            if let Some(t) = m.emissive_texture {
                let mean = *means[t.texture as usize]
                    .get_or_insert_with(|| textures[t.texture as usize].mean_rgb());
                l = l.with_texture(EmissiveTexture { texture: t, uvs: mesh.uvs_of(i), mean });
            }
            tri_light[i] = lights.len() as u32;
            lights.push(l);
        }
    }
    (lights, tri_light)
}

/// A sphere around the triangles that are geometry (degenerate ones must not move the bounds):
/// around their box `solid_box`, a unit sphere at the origin if there are none.
fn bounding_sphere(solid_box: Option<(Vec3, Vec3)>) -> (Vec3, f32) {
    let Some((lo, hi)) = solid_box else { return (Vec3::ZERO, 1.0) };
    let c = (lo + hi) * 0.5;
    (c, ((hi - lo).length() * 0.5).max(1e-6))
}
