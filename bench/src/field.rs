//! The generated large scene (no mesh file is shipped): `spheres`² spheres on a
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
use tessera_render::tracer::camera::Camera;
use tessera_render::tracer::material::Material;
use tessera_render::tracer::scene::Mesh;

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
            light: [
                [at(lo, 6.0, lo), at(hi, 6.0, lo), at(lo, 6.0, hi)],
                [at(hi, 6.0, lo), at(hi, 6.0, hi), at(lo, 6.0, hi)],
            ],
            // … and the ground faces up, so that paths bounce between it and the spheres.
            ground: [
                [at(lo, 0.0, lo), at(lo, 0.0, hi), at(hi, 0.0, lo)],
                [at(hi, 0.0, lo), at(lo, 0.0, hi), at(hi, 0.0, hi)],
            ],
            camera: look_at(
                Vec3::new(-0.1 * size, 3.0, -0.1 * size),
                Vec3::new(0.5 * size, 0.5, 0.5 * size),
            ),
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
    glb(spheres, false)
}

/// [`field_glb`] with each row of spheres (along x) its own node, sliding to and fro along x
/// in an animation (`slide`, [`SLIDE_S`] seconds, LINEAR keys at 24 per second): row r is at
/// x + [`SLIDE`] · sin(π t + 0.9 r) at time t, so rows move against each other and an
/// animation frame's refitted BVH sees its boxes stretch. Triangle indices match
/// [`field_parts`]'s.
pub fn sliding_field_glb(spheres: &[[Vec3; 3]]) -> Vec<u8> {
    glb(spheres, true)
}

/// How far the rows of [`sliding_field_glb`] slide (spheres are 2 apart, of radius 0.8), and
/// for how long the animation runs.
pub const SLIDE: f32 = 0.5;
pub const SLIDE_S: f32 = 2.0;

fn glb(spheres: &[[Vec3; 3]], sliding: bool) -> Vec<u8> {
    let around = Surroundings::of(spheres);
    let row = match sliding {
        true => spheres_per_side(spheres.len()) * PER_SPHERE,
        false => spheres.len().max(1),
    };
    let rows: Vec<&[[Vec3; 3]]> = spheres.chunks(row).collect();
    let mut bin = Bin::default();
    let positions: Vec<usize> = rows
        .iter()
        .chain([&&around.light[..], &&around.ground[..]])
        .map(|p| bin.positions(p))
        .collect();
    let (light, ground) = (positions[rows.len()], positions[rows.len() + 1]);
    let primitive = |accessor: usize, material: usize| json!({"attributes": {"POSITION": accessor}, "material": material});
    let room = [primitive(light, 1), primitive(ground, 0)];
    let (meshes, mut nodes, animations) = match sliding {
        false => {
            let primitives = [primitive(positions[0], 0), room[0].clone(), room[1].clone()];
            (
                vec![json!({"name": "field", "primitives": primitives})],
                vec![json!({"name": "field", "mesh": 0})],
                vec![],
            )
        }
        true => {
            let keys: Vec<f32> = (0..=(24.0 * SLIDE_S) as usize).map(|i| i as f32 / 24.0).collect();
            let times = bin.scalars(&keys);
            let mut meshes: Vec<_> = (0..rows.len()).map(|r| json!({"name": format!("row {r}"), "primitives": [primitive(positions[r], 0)]})).collect();
            meshes.push(json!({"name": "room", "primitives": room}));
            let nodes: Vec<_> = (0..meshes.len()).map(|m| json!({"mesh": m})).collect();
            let (mut channels, mut samplers) = (Vec::new(), Vec::new());
            for r in 0..rows.len() {
                let moves: Vec<Vec3> = keys
                    .iter()
                    .map(|t| Vec3::X * SLIDE * (PI * t + 0.9 * r as f32).sin())
                    .collect();
                samplers.push(json!({"input": times, "output": bin.vectors(&moves), "interpolation": "LINEAR"}));
                channels.push(json!({"sampler": r, "target": {"node": r, "path": "translation"}}));
            }
            (
                meshes,
                nodes,
                vec![json!({"name": "slide", "channels": channels, "samplers": samplers})],
            )
        }
    };
    nodes.push(json!({"name": "camera", "camera": 0, "matrix": around.camera.to_cols_array()}));
    let diffuse = |albedo: f32| json!({"baseColorFactor": [albedo, albedo, albedo, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0});
    let mut gltf = json!({
        "asset": {"version": "2.0", "generator": "tessera-bench field"},
        "extensionsUsed": ["KHR_materials_specular", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "field", "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "cameras": [{"name": "field", "type": "perspective", "perspective": {"yfov": YFOV, "znear": 0.01}}],
        "meshes": meshes,
        "materials": [
            {"name": "spheres", "pbrMetallicRoughness": diffuse(GREY), "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}}},
            {"name": "light", "pbrMetallicRoughness": diffuse(0.0), "emissiveFactor": [1.0, 1.0, 1.0],
             "extensions": {"KHR_materials_specular": {"specularFactor": 0.0}, "KHR_materials_emissive_strength": {"emissiveStrength": RADIANCE}}},
        ],
        "accessors": bin.accessors,
        "bufferViews": bin.views,
        "buffers": [{"byteLength": bin.bytes.len()}],
    });
    if !animations.is_empty() {
        gltf["animations"] = json!(animations);
    }
    tessera_render::scene::pack_glb(&gltf.to_string(), &bin.bytes)
}

/// The binary chunk being written, with a buffer view and an accessor per array of f32s.
#[derive(Default)]
struct Bin {
    bytes: Vec<u8>,
    views: Vec<serde_json::Value>,
    accessors: Vec<serde_json::Value>,
}

impl Bin {
    /// Triangles' corners as a POSITION accessor; returns its index.
    fn positions(&mut self, tris: &[[Vec3; 3]]) -> usize {
        let corners: Vec<Vec3> = tris.iter().flatten().copied().collect();
        self.vectors(&corners)
    }

    fn vectors(&mut self, v: &[Vec3]) -> usize {
        let (lo, hi) = corners_box(v.iter());
        let floats: Vec<f32> = v.iter().flat_map(|p| p.to_array()).collect();
        self.push(
            &floats,
            json!({"type": "VEC3", "count": v.len(), "min": lo.to_array(), "max": hi.to_array()}),
        )
    }

    fn scalars(&mut self, v: &[f32]) -> usize {
        let (lo, hi) = v
            .iter()
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &x| (lo.min(x), hi.max(x)));
        self.push(v, json!({"type": "SCALAR", "count": v.len(), "min": [lo], "max": [hi]}))
    }

    fn push(&mut self, floats: &[f32], mut accessor: serde_json::Value) -> usize {
        let index = self.accessors.len();
        self.views.push(
            json!({"buffer": 0, "byteOffset": self.bytes.len(), "byteLength": floats.len() * 4}),
        );
        self.bytes.extend(floats.iter().flat_map(|x| x.to_le_bytes()));
        accessor["bufferView"] = json!(index);
        accessor["componentType"] = json!(5126);
        self.accessors.push(accessor);
        index
    }
}

/// Camera to world at `eye` looking at `target` (+y up), as glTF cameras look (down −z).
fn look_at(eye: Vec3, target: Vec3) -> Mat4 {
    let f = (target - eye).normalize();
    let right = f.cross(Vec3::Y).normalize();
    Mat4::from_cols(
        right.extend(0.0),
        right.cross(f).extend(0.0),
        (-f).extend(0.0),
        eye.extend(1.0),
    )
}

/// The axis-aligned box around the triangles.
pub fn bounds(tris: &[[Vec3; 3]]) -> (Vec3, Vec3) {
    corners_box(tris.iter().flatten())
}

/// The axis-aligned box around the points.
fn corners_box<'a>(points: impl Iterator<Item = &'a Vec3>) -> (Vec3, Vec3) {
    points.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| (lo.min(*v), hi.max(*v)))
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
            let (theta, phi) =
                (PI * j as f32 / (SEGMENTS / 2) as f32, 2.0 * PI * i as f32 / SEGMENTS as f32);
            let r = 0.8 * (1.0 + 0.15 * (5.0 * theta).sin() * (7.0 * phi).sin());
            centre + r * Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())
        };
        for j in 0..SEGMENTS / 2 {
            for i in 0..SEGMENTS {
                let (a, b, c, d) =
                    (point(i, j), point(i + 1, j), point(i, j + 1), point(i + 1, j + 1));
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
        let parsed = tessera_render::scene::parse(&glb, None).expect("the written field parses");
        assert_eq!(
            parsed.effects(),
            ["area_lights", "lambert"],
            "purely diffuse, lit by the emitter"
        );
        let scene = parsed.build();
        // Near the origin the loader keeps positions as they are (no rebase), so the triangles
        // are the same bits, in the same order.
        assert_eq!(scene.mesh.positions, mesh.positions);
        assert_eq!(scene.mesh.material, mesh.material);
        // The loader appends its default material (unused here) after the file's.
        let used = |mats: &[Material]| {
            mats[..2].iter().map(|m| format!("{:?} {}", m.model, m.emission)).collect::<Vec<_>>()
        };
        assert_eq!(
            used(&scene.materials),
            used(&materials),
            "the same BSDF parameters and emission"
        );
        let c = &scene.cameras[0];
        assert!(
            c.to_world.abs_diff_eq(camera.to_world, 1e-6) && c.yfov == camera.yfov,
            "{c:?} vs {camera:?}"
        );
    }

    /// The sliding field: one animation, and from time t1 to t2 each row of spheres (told by
    /// its z) moves along x by [`SLIDE`] · (sin(π t2 + 0.9 r) − sin(π t1 + 0.9 r)) (up to
    /// rounding; t1 and t2 on keys) while the light and the ground stay. The next frame refits the last one's BVH.
    #[test]
    fn the_sliding_field_moves_its_rows_against_each_other() {
        use tessera_render::scene::{Preparation, Sequence};
        let spheres = sphere_field(4 * PER_SPHERE); // two rows of two
        let seq =
            Sequence::parse(&sliding_field_glb(&spheres), None).expect("the sliding field parses");
        let info = seq.animations();
        assert_eq!((info.len(), info[0].name.as_deref(), info[0].channels), (1, Some("slide"), 2));
        assert!((info[0].duration_s - f64::from(SLIDE_S)).abs() < 1e-6);
        let (t1, t2) = (7.0 / 24.0, 17.0 / 24.0); // on keys: between them the motion is linear
        let (a, b) = (seq.scene_at(Some(0), t1).unwrap(), seq.scene_at(Some(0), t2).unwrap());
        assert_eq!(a.mesh.positions.len(), spheres.len() + 4);
        let x = |t: f64, r: f32| SLIDE * (PI * t as f32 + 0.9 * r).sin();
        let mut rows = [0; 2];
        for (i, (p, q)) in a.mesh.positions.iter().zip(&b.mesh.positions).enumerate() {
            let centre = (p[0] + p[1] + p[2]) / 3.0;
            let shift = match centre.y {
                0.0 | 6.0 => 0.0, // the ground and the light
                _ => {
                    let r = ((centre.z - 1.0) / 2.0).round() as usize;
                    rows[r] += 1;
                    x(t2, r as f32) - x(t1, r as f32)
                }
            };
            for (v, w) in p.iter().zip(q) {
                assert!(
                    (*w - (*v + Vec3::X * shift)).abs().max_element() < 1e-5,
                    "triangle {i}: {v} → {w}, not by {shift}"
                );
            }
        }
        assert_eq!(rows, [2 * PER_SPHERE; 2]);
        let (_, how) = seq.scene_after(&a, Some(0), t1 + 1.0 / 24.0).unwrap();
        assert_eq!(how, Preparation::Refit);
    }
}
