//! Which light-transport features a scene calls for, by name (see
//! [`crate::tracer::effects::Effects`] for the list and the kernels they select).
//!
//! | effect               | when                                                   |
//! |----------------------|--------------------------------------------------------|
//! | `area_lights`        | some triangle emits                                    |
//! | `light_tree`         | `auto` chooses lights through a light tree: at least 32 triangles emit, or 2–31 that differ enough in what they give the scene's surfaces ([`LightTree::suits`](crate::tracer::light::LightTree::suits)) |
//! | `point_lights`, `spot_lights`, `directional_lights` | `KHR_lights_punctual` lights |
//! | `lambert`            | a material is purely diffuse (metallic 0, specular 0)  |
//! | `ggx`                | a material has a microfacet specular layer or is metal |
//! | `phong`              | a material uses `TESSERA_materials_phong`              |
//! | `textures`           | a material reads a texture (any slot)                  |
//! | `normal_maps`        | a material has a `normalTexture`                       |
//! | `max_depth=0`        | no used material scatters light: paths end at the first hit |
//! | `glass`              | a material transmits (`KHR_materials_transmission`)    |
//! | `absorption`         | a glass material has a volume with finite `attenuationDistance` |
//! | `alpha_mask`         | a material has `alphaMode: MASK`                       |
//! | `depth_of_field`     | a camera has a non-zero `extras.aperture_radius`       |
//!
//! The job adds `background` when it sets a non-black background.
use crate::tracer::camera::Camera;
use crate::tracer::effects::Effects;
use crate::tracer::light::{Light, LightTree};
use crate::tracer::material::Material;
use crate::tracer::scene::{Mesh, area_lights};
use crate::tracer::texture::Texture;

pub fn of(
    mesh: &Mesh,
    materials: &[Material],
    textures: &[Texture],
    cameras: &[Camera],
    lights: &[Light],
) -> Vec<String> {
    let mut used = vec![false; materials.len()];
    mesh.material.iter().for_each(|&m| used[m as usize] = true);
    let used_materials = materials.iter().zip(&used).filter(|(_, u)| **u).map(|(m, _)| m);
    let mut e = Effects::analyse(used_materials, lights);
    if suits_light_tree(mesh, materials, textures) {
        e = e | Effects::LIGHT_TREE;
    }
    if cameras.iter().any(Camera::has_depth_of_field) {
        e = e | Effects::DEPTH_OF_FIELD;
    }
    e.names()
}

/// What [`LightTree::suits`] will say of the scene once it is built and its area lights made.
/// Many emissive triangles suit the tree whatever they are, so they are only counted: making
/// their lights (over 100 bytes each) would cost the coordinator memory on a large emissive mesh.
fn suits_light_tree(mesh: &Mesh, materials: &[Material], textures: &[Texture]) -> bool {
    let emits = |t: usize| {
        let m = &materials[mesh.material[t] as usize];
        m.is_emissive()
            && Light::triangle(t as u32, &mesh.positions[t], m.emission, m.double_sided).is_some()
    };
    if (0..mesh.len()).filter(|&t| emits(t)).take(LightTree::MIN_LIGHTS).count()
        == LightTree::MIN_LIGHTS
    {
        return true;
    }
    let (area_lights, _) = area_lights(mesh, materials, textures);
    let scatters = |t: usize| materials[mesh.material[t] as usize].scatters();
    LightTree::over(&area_lights)
        .is_some_and(|tree| tree.suits(&area_lights, &mesh.positions, scatters))
}
