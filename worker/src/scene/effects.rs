//! Which light-transport features a scene calls for, by name.
//!
//! | effect               | when                                                   |
//! |----------------------|--------------------------------------------------------|
//! | `area_lights`        | some triangle emits                                    |
//! | `point_lights`, `spot_lights`, `directional_lights` | `KHR_lights_punctual` lights |
//! | `lambert`            | a material is purely diffuse (metallic 0, specular 0)  |
//! | `ggx`                | a material has a microfacet specular layer or is metal |
//! | `phong`              | a material uses `TESSERA_materials_phong`              |
//! | `textures`           | a material reads a texture                             |
//!
//! The job adds `background` when it sets a non-black background.
use crate::tracer::light::Light;
use crate::tracer::material::{Material, MaterialModel};
use crate::tracer::scene::Mesh;
use crate::tracer::texture::Texture;
use std::collections::BTreeSet;

pub fn of(mesh: &Mesh, materials: &[Material], _textures: &[Texture], lights: &[Light]) -> Vec<String> {
    let mut e = BTreeSet::new();
    let used: BTreeSet<u32> = mesh.material.iter().copied().collect();
    for m in used.iter().filter_map(|&i| materials.get(i as usize)) {
        if m.is_emissive() {
            e.insert("area_lights");
        }
        match &m.model {
            MaterialModel::Pbr(p) if p.metallic == 0.0 && p.specular == 0.0 => e.insert("lambert"),
            MaterialModel::Pbr(_) => e.insert("ggx"),
            MaterialModel::Phong(_) => e.insert("phong"),
        };
        if m.base_color_texture.is_some() {
            e.insert("textures");
        }
    }
    for l in lights {
        e.insert(match l {
            Light::Point { .. } => "point_lights",
            Light::Spot { .. } => "spot_lights",
            Light::Directional { .. } => "directional_lights",
            Light::Triangle { .. } => "area_lights",
            Light::Background { .. } => "background",
        });
    }
    e.into_iter().map(str::to_string).collect()
}
