//! The generated large scene of issue #9 (no mesh file is shipped): `spheres`² spheres on a
//! grid, each a UV sphere of `SEGMENTS` × `SEGMENTS / 2` quads whose radius wobbles by ±15 %
//! (sin 5θ · sin 7φ), so the triangles are small, numerous and not axis-aligned; grey Lambert
//! spheres on a grey ground under a square area light that overhangs the field.
//!
//! `tessera-bench bvh` builds it in memory ([`field_parts`]); `tessera-bench field -o field.glb`
//! writes the same scene as binary glTF ([`field_glb`]), so a farm can render it as a job and
//! report what loading, building and holding a million triangles cost its workers:
//!
//! ```text
//! target/release/tessera-bench field -o field.glb
//! target/release/tessera render field.glb --spp 16 -o field.exr
//! ```
use glam::{Mat4, Vec3};
use serde_json::json;
use std::f32::consts::PI;
use tessera_worker::tracer::camera::Camera;
use tessera_worker::tracer::material::Material;
use tessera_worker::tracer::scene::Mesh;

/// Albedo of the spheres and the ground, and radiance of the light.
const GREY: f32 = 0.6;
const RADIANCE: f32 = 3.0;
const YFOV: f32 = 0.8;

/// What surrounds the spheres: the light's two triangles (facing down at y = 6) and the ground's
/// (facing up at y = 0), both overhanging the field by a tenth on every side, and the camera at
/// a corner of the field looking across it (camera to world).
struct Surroundings {
    light: [[Vec3; 3]; 2],
    ground: [[Vec3; 3]; 2],
    camera: Mat4,
}

impl Surroundings {
    fn of(spheres: &[[Vec3; 3]]) -> Surroundings {
        let size = bounds(spheres).1.x.max(1.0);
        let (lo, hi) = (-0.1 * size, 1.1 * size);
        let at = |x: f32, y: f32, z: f32| Vec3::new(x, y, z);
        Surroundings {
            // (+x) × (+z) = −y: the light faces the field …
            light: [[at(lo, 6.0, lo), at(hi, 6.0, lo), at(lo, 6.0, hi)], [at(hi, 6.0, lo), at(hi, 6.0, hi), at(lo, 6.0, hi)]],
            // … and the ground faces up, so that paths bounce between it and the spheres.
            ground: [[at(lo, 0.0, lo), at(lo, 0.0, hi), at(hi, 0.0, lo)], [at(hi, 0.0, lo), at(lo, 0.0, hi), at(hi, 0.0, hi)]],
            camera: look_at(Vec3::new(-0.1 * size, 3.0, -0.1 * size), Vec3::new(0.5 * size, 0.5, 0.5 * size)),
        }
    }
}

/// The field as a scene's parts: the spheres (material 0), the light (material 1), the ground
/// (material 0), and the camera.
pub fn field_parts(spheres: Vec<[Vec3; 3]>) -> (Mesh, Vec<Material>, Camera) {
    let around = Surroundings::of(&spheres);
    let mut mesh = Mesh::default();
    // Exactly the space the triangles take (flat: one normal each, no UVs), so the heap figures
    // are the mesh's, not a Vec's slack.
    let count = spheres.len() + 4;
    mesh.positions.reserve_exact(count);
    mesh.flat_normals.reserve_exact(count);
    mesh.material.reserve_exact(count);
    spheres.into_iter().for_each(|t| mesh.push_flat(t, 0));
    around.light.into_iter().for_each(|t| mesh.push_flat(t, 1));
    around.ground.into_iter().for_each(|t| mesh.push_flat(t, 0));
    let mut light = Material::lambert("light", Vec3::ZERO);
    light.emission = Vec3::splat(RADIANCE);
    let camera = Camera::pinhole("field", around.camera, YFOV);
    (mesh, vec![Material::lambert("spheres", Vec3::splat(GREY)), light], camera)
}

/// The same scene as binary glTF: one primitive each for the spheres, the light and the ground
/// (in that order, so triangle indices match [`field_parts`]), positions only (the loader gives
/// flat triangles their face normals), materials purely diffuse (metallic 0, specular 0).
pub fn field_glb(spheres: &[[Vec3; 3]]) -> Vec<u8> {
    let around = Surroundings::of(spheres);
    let parts: [&[[Vec3; 3]]; 3] = [spheres, &around.light, &around.ground];
    const TRIANGLE_BYTES: usize = size_of::<[Vec3; 3]>();
    let mut bin = Vec::with_capacity(parts.iter().map(|p| p.len() * TRIANGLE_BYTES).sum());
    let (mut views, mut accessors) = (Vec::new(), Vec::new());
    for p in parts {
        let (lo, hi) = bounds(p);
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": p.len() * TRIANGLE_BYTES}));
        accessors.push(json!({"bufferView": accessors.len(), "componentType": 5126, "count": p.len() * 3, "type": "VEC3", "min": lo.to_array(), "max": hi.to_array()}));
        bin.extend(p.iter().flatten().flat_map(|v| v.to_array()).flat_map(f32::to_le_bytes));
    }
    // Accessor i holds part i; the light (part 1) has material 1.
    let primitives: Vec<_> = (0..3).map(|i| json!({"attributes": {"POSITION": i}, "material": usize::from(i == 1)})).collect();
    let diffuse = |albedo: f32| json!({"baseColorFactor": [albedo, albedo, albedo, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0});
    let gltf = json!({
        "asset": {"version": "2.0", "generator": "tessera-bench field"},
        "extensionsUsed": ["KHR_materials_specular", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "field", "nodes": [0, 1]}],
        "nodes": [{"name": "field", "mesh": 0}, {"name": "camera", "camera": 0, "matrix": around.camera.to_cols_array()}],
        "cameras": [{"name": "field", "type": "perspective", "perspective": {"yfov": YFOV, "znear": 0.01}}],
        "meshes": [{"name": "field", "primitives": primitives}],
        "materials": [
            {"name": "spheres", "pbrMetallicRoughness": diffuse(GREY), "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}},
            {"name": "light", "pbrMetallicRoughness": diffuse(0.0), "emissiveFactor": [1.0, 1.0, 1.0],
             "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}, "KHR_materials_emissive_strength": {"emissiveStrength": RADIANCE}}},
        ],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    tessera_worker::scene::pack_glb(&gltf.to_string(), &bin)
}

/// Camera to world at `eye` looking at `target` (+y up), as glTF cameras look (down −z).
fn look_at(eye: Vec3, target: Vec3) -> Mat4 {
    let f = (target - eye).normalize();
    let right = f.cross(Vec3::Y).normalize();
    Mat4::from_cols(right.extend(0.0), right.cross(f).extend(0.0), (-f).extend(0.0), eye.extend(1.0))
}

/// The axis-aligned box around the triangles.
pub fn bounds(tris: &[[Vec3; 3]]) -> (Vec3, Vec3) {
    tris.iter().flatten().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
}

const SEGMENTS: usize = 128;

/// Triangles of one sphere: `SEGMENTS` × `SEGMENTS / 2` quads, two triangles each.
const PER_SPHERE: usize = SEGMENTS * SEGMENTS;

fn spheres_per_side(triangles: usize) -> usize {
    ((triangles as f64 / PER_SPHERE as f64).sqrt().ceil() as usize).max(1)
}

pub fn sphere_field(triangles: usize) -> Vec<[Vec3; 3]> {
    let n = spheres_per_side(triangles);
    let count = triangles.div_ceil(PER_SPHERE).max(1);
    let mut tris = Vec::with_capacity(count * PER_SPHERE);
    for k in 0..count {
        let centre = Vec3::new((k % n) as f32 * 2.0 + 1.0, 1.0, (k / n) as f32 * 2.0 + 1.0);
        let point = |i: usize, j: usize| {
            let (theta, phi) = (PI * j as f32 / (SEGMENTS / 2) as f32, 2.0 * PI * i as f32 / SEGMENTS as f32);
            let r = 0.8 * (1.0 + 0.15 * (5.0 * theta).sin() * (7.0 * phi).sin());
            centre + r * Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
        };
        for j in 0..SEGMENTS / 2 {
            for i in 0..SEGMENTS {
                let (a, b, c, d) = (point(i, j), point(i + 1, j), point(i, j + 1), point(i + 1, j + 1));
                // Wound to face outwards: surfaces are black from behind (Conventions, ARCHITECTURE.md).
                tris.push([a, b, c]);
                tris.push([b, d, c]);
            }
        }
    }
    tris
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_written_field_loads_as_the_scene_the_bench_builds() {
        let spheres = sphere_field(1);
        assert_eq!(spheres.len(), PER_SPHERE);
        let (mesh, materials, camera) = field_parts(spheres.clone());
        let glb = field_glb(&spheres);
        let parsed = tessera_worker::scene::parse(&glb, None).expect("the written field parses");
        assert_eq!(parsed.effects(), ["area_lights", "lambert"], "purely diffuse, lit by the emitter");
        let scene = parsed.build();
        // Near the origin the loader keeps positions as they are (no rebase), so the triangles
        // are the same bits, in the same order.
        assert_eq!(scene.mesh.positions, mesh.positions);
        assert_eq!(scene.mesh.material, mesh.material);
        // The loader appends its default material (unused here) after the file's.
        let used = |mats: &[Material]| mats[..2].iter().map(|m| format!("{:?} {}", m.model, m.emission)).collect::<Vec<_>>();
        assert_eq!(used(&scene.materials), used(&materials), "the same BSDF parameters and emission");
        let c = &scene.cameras[0];
        assert!(c.to_world.abs_diff_eq(camera.to_world, 1e-6) && c.yfov == camera.yfov, "{c:?} vs {camera:?}");
    }
}
