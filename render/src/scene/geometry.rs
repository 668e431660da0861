//! glTF nodes → world-space triangles (positions, normals, two UV sets, `TANGENT`s), cameras
//! and punctual lights.
use super::SceneError;
use super::animation::Pose;
use super::budget::{self, TriangleBudget};
use super::camera_light::{camera, punctual};
use super::corners::Corners;
use crate::tracer::camera::Camera;
use crate::tracer::light::Light;
use crate::tracer::scene::Mesh;
use glam::{DMat4, DVec3, Mat3, Mat4, Vec2, Vec3, Vec4};
use rayon::prelude::*;
use std::borrow::Cow;
use std::mem::MaybeUninit;

pub struct Parts {
    pub mesh: Mesh,
    pub cameras: Vec<Camera>,
    pub lights: Vec<Light>,
}

/// Walks the default scene (or the first one) and flattens it into world space, in f64; a scene
/// lying far from the origin (its centre farther than 4× its size) is then moved to the origin
/// before rounding to f32 (see [`rebase_origin`]).
///
/// `max_triangles` is checked from accessor counts before any vertex is read, so a small file
/// declaring a huge mesh (or instancing one many times) is refused without allocating it.
/// Nodes `pose` drives use its local transform instead of the file's.
pub fn load(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    material_count: usize,
    max_triangles: u64,
    pose: &Pose,
) -> Result<Parts, SceneError> {
    let scene = doc
        .default_scene()
        .or_else(|| doc.scenes().next())
        .ok_or_else(|| SceneError::new("the file has no scene"))?;
    // One allocation of the mesh's vectors, not a doubling series of them and their copies.
    let room = budget::instanced(&scene, doc.nodes().len(), buffers).min(max_triangles) as usize;
    let source = Source {
        scene,
        nodes: doc.nodes().len(),
        buffers,
        material_count,
        max_triangles,
        pose,
        room,
    };
    let mut walked = walk(&source, DVec3::ZERO)?;
    let origin = rebase_origin(&walked.bounds);
    if origin != DVec3::ZERO {
        // Rounded again about the new origin from the same f64 positions: walking twice costs
        // far scenes some time, where keeping every f64 corner would cost each scene 72 bytes
        // a triangle.
        walked = walk(&source, origin)?;
    }
    let Walked { mut parts, camera_worlds, light_worlds, .. } = walked;
    let to_local = DMat4::from_translation(-origin);
    for (c, w) in parts.cameras.iter_mut().zip(camera_worlds) {
        c.to_world = (to_local * w).as_mat4();
    }
    for (l, w) in parts.lights.iter_mut().zip(light_worlds) {
        if let Light::Point { position, .. } | Light::Spot { position, .. } = l {
            *position = (w.transform_point3(DVec3::ZERO) - origin).as_vec3();
        }
    }
    Ok(parts)
}

/// The scene's parts with positions rounded about `origin`, and the world transforms of its
/// cameras and lights.
struct Walked {
    parts: Parts,
    camera_worlds: Vec<DMat4>,
    light_worlds: Vec<DMat4>,
    bounds: Bounds64,
}

/// What [`walk`] reads: the scene's node trees (of `nodes` in the file) in `pose`, and the
/// triangles its mesh has room for.
struct Source<'a> {
    scene: gltf::Scene<'a>,
    nodes: usize,
    buffers: &'a [Vec<u8>],
    material_count: usize,
    max_triangles: u64,
    pose: &'a Pose,
    room: usize,
}

/// The scene's parts, positions rounded to f32 about `origin`.
fn walk(src: &Source, origin: DVec3) -> Result<Walked, SceneError> {
    let Source { scene, nodes, buffers, material_count, max_triangles, pose, room } = src;
    let parts = Parts { mesh: Mesh::default(), cameras: Vec::new(), lights: Vec::new() };
    let mut w = Walked {
        parts,
        camera_worlds: Vec::new(),
        light_worlds: Vec::new(),
        bounds: Bounds64::default(),
    };
    let mut stack: Vec<(gltf::Node, DMat4, usize)> =
        scene.nodes().map(|n| (n, DMat4::IDENTITY, 0)).collect();
    // glTF nodes form disjoint trees. A node reached twice (two parents, or a cycle) would be
    // instanced once per path: a few nodes listing the same child twice make 2^depth copies.
    let mut seen = vec![false; *nodes];
    let mut budget = TriangleBudget::new(*max_triangles);
    w.parts.mesh.reserve(*room);
    while let Some((node, parent, depth)) = stack.pop() {
        if depth > 256 {
            return Err(SceneError::new(format!(
                "node {}: hierarchy deeper than 256 levels",
                node.index()
            )));
        }
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(SceneError::new(format!(
                "node {} appears more than once in the scene's node trees (glTF nodes must form disjoint trees)",
                node.index()
            )));
        }
        let local = pose
            .local(node.index())
            .unwrap_or_else(|| Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4());
        let world = parent * local;
        if !world.is_finite() {
            return Err(SceneError::new(format!("node {}: transform is not finite", node.index())));
        }
        if let Some(mesh) = node.mesh() {
            budget.spend(&mesh)?;
            let mut sink = Sink { mesh: &mut w.parts.mesh, bounds: &mut w.bounds, origin };
            add_mesh(&mut sink, &mesh, world, buffers, *material_count)?;
        }
        if let Some(cam) = node.camera()
            && let gltf::camera::Projection::Perspective(p) = cam.projection()
        {
            w.parts.cameras.push(camera(&node, &cam, &p, world.as_mat4())?);
            w.camera_worlds.push(world);
        }
        if let Some(light) = node.light() {
            w.parts.lights.push(punctual(&light, world.as_mat4())?);
            w.light_worlds.push(world);
        }
        stack.extend(node.children().map(|c| (c, world, depth + 1)));
    }
    if w.parts.mesh.tangents.iter().flatten().all(|t| t.w == 0.0) {
        w.parts.mesh.tangents = Vec::new();
    }
    Ok(w)
}

/// The box around world-space corners, in f64; empty (lo > hi) before the first.
#[derive(Clone, Copy)]
struct Bounds64 {
    lo: DVec3,
    hi: DVec3,
}

impl Default for Bounds64 {
    fn default() -> Bounds64 {
        Bounds64 { lo: DVec3::splat(f64::INFINITY), hi: DVec3::splat(f64::NEG_INFINITY) }
    }
}

/// Where the tracer's origin goes: the centre of the geometry's bounding box when that lies
/// farther than 4× the box's size from the world origin, else the world origin (scenes near it
/// load exactly as written). f32 spacing at 1e5 is 8 mm, enough to merge a light with the
/// ceiling 0.1 mm above it; subtracting the centre in f64 first keeps every millimetre. Images
/// do not depend on where the scene sits, so nothing downstream sees the move.
fn rebase_origin(bounds: &Bounds64) -> DVec3 {
    let Bounds64 { lo, hi } = *bounds;
    let (centre, size) = ((lo + hi) * 0.5, (hi - lo).max_element());
    let far = centre.abs().max_element() > 4.0 * size;
    if lo.x > hi.x || !far { DVec3::ZERO } else { centre }
}

/// Where a mesh's triangles go: their f32 positions are rounded about `origin` from the f64
/// world-space corners, which `bounds` grows around.
struct Sink<'a> {
    mesh: &'a mut Mesh,
    bounds: &'a mut Bounds64,
    origin: DVec3,
}

/// Appends the mesh's triangles to `out`.
fn add_mesh(
    out: &mut Sink,
    mesh: &gltf::Mesh,
    world64: DMat4,
    buffers: &[Vec<u8>],
    material_count: usize,
) -> Result<(), SceneError> {
    let world = world64.as_mat4();
    let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
    // A mirroring transform flips the winding; swap two corners to keep front faces in front.
    let mirrored = Mat3::from_mat4(world).determinant() < 0.0;
    for prim in mesh.primitives() {
        let at = |what: &str| format!("mesh {} primitive {}: {what}", mesh.index(), prim.index());
        super::accessors::check_primitive(&prim, buffers, &at)?;
        let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
        let position_accessor = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| SceneError::new(at("no POSITION attribute")))?;
        let positions: Cow<[[f32; 3]]> =
            match super::accessors::packed_vec3(&position_accessor, buffers) {
                Some(packed) => Cow::Borrowed(packed),
                None => Cow::Owned(
                    reader
                        .read_positions()
                        .ok_or_else(|| SceneError::new(at("no POSITION attribute")))?
                        .collect(),
                ),
            };
        if positions.is_empty() {
            return Err(SceneError::new(at("POSITION has no vertices")));
        }
        if let Some(k) = positions
            .par_iter()
            .with_min_len(SLICE)
            .position_first(|p| !p.iter().all(|c| c.is_finite()))
        {
            return Err(SceneError::new(at(&format!("POSITION {k} is not finite"))));
        }
        let normals: Option<Vec<Vec3>> = reader.read_normals().map(|n| n.map(Vec3::from).collect());
        let tangents: Option<Vec<Vec4>> =
            reader.read_tangents().map(|t| t.map(Vec4::from).collect());
        let uv = |set| {
            reader.read_tex_coords(set).map(|t| t.into_f32().map(Vec2::from).collect::<Vec<_>>())
        };
        let uvs = [uv(0), uv(1)];
        let corners = match reader.read_indices() {
            Some(ix) => Corners::Listed(ix.into_u32().collect()),
            None => Corners::InOrder(positions.len() as u32),
        };
        if let Some(bad) = corners.out_of_range(positions.len()) {
            return Err(SceneError::new(at(&format!(
                "index {bad} out of range (POSITION count {})",
                positions.len()
            ))));
        }
        check_len(&at, "NORMAL", normals.as_ref().map(Vec::len), positions.len())?;
        check_len(&at, "TANGENT", tangents.as_ref().map(Vec::len), positions.len())?;
        check_len(&at, "TEXCOORD_0", uvs[0].as_ref().map(Vec::len), positions.len())?;
        check_len(&at, "TEXCOORD_1", uvs[1].as_ref().map(Vec::len), positions.len())?;
        let material = match prim.material().index() {
            Some(m) if m < material_count => m as u32,
            Some(m) => return Err(SceneError::new(at(&format!("material {m} does not exist")))),
            None => material_count as u32, // glTF's default material, appended by the loader
        };
        let (count, corners_of) = corners.indexed(prim.mode()).ok_or_else(|| {
            SceneError::new(at("not a triangle mode (points and lines have no area)"))
        })?;
        let corners_at = |t: usize| {
            let [a, b, c] = corners_of(t);
            if mirrored { [a, c, b] } else { [a, b, c] }
        };
        let world_corners = |t: usize| {
            corners_at(t)
                .map(|i| world64.transform_point3(Vec3::from(positions[i as usize]).as_dvec3()))
        };
        let origin = out.origin;
        let posed_into = |positions: &mut Vec<[Vec3; 3]>, faces: &mut Vec<Vec3>| {
            pose(positions, faces, count, world_corners, origin)
        };
        if normals.is_none() && uvs.iter().all(Option::is_none) && tangents.is_none() {
            let box64 = out.mesh.extend_flat(count, material, posed_into);
            (out.bounds.lo, out.bounds.hi) =
                (out.bounds.lo.min(box64.lo), out.bounds.hi.max(box64.hi));
            continue;
        }
        let mut faces = Vec::new();
        let box64 = posed_into(&mut out.mesh.positions, &mut faces);
        (out.bounds.lo, out.bounds.hi) = (out.bounds.lo.min(box64.lo), out.bounds.hi.max(box64.hi));
        for (t, face) in faces.into_iter().enumerate() {
            let corners = corners_at(t);
            let n = match &normals {
                Some(ns) => corners.map(|i| (normal_matrix * ns[i as usize]).normalize_or(face)),
                None => [face; 3],
            };
            let t = (uvs[0].is_some() || uvs[1].is_some()).then(|| {
                uvs.each_ref().map(|set| match set {
                    Some(set) => corners.map(|i| set[i as usize]),
                    None => [Vec2::ZERO; 3],
                })
            });
            // Tangents lie in the surface: they transform like positions (w, the handedness,
            // flips with a mirroring transform). Zero marks "none" (normal maps use UVs).
            let tg = tangents
                .as_ref()
                .map(|ts| corners.map(|i| tangent(ts[i as usize], world, mirrored)));
            // Flat normals, absent UVs and tangents take no memory (see tracer::mesh).
            out.mesh.push_attributes(n, t, tg, material);
        }
    }
    Ok(())
}

/// Appends `count` triangles to `positions` and `faces`: each one's corners (`world(t)`:
/// triangle t's corners in world space, in f64) rounded to f32 about `origin`, and its unit
/// face normal from the f64 corners; returns their f64 box. In parallel, a slice of triangles
/// at a time: the transforms are most of a frame's walk, and a box's minima and maxima are
/// exact in any order. Written straight into the vectors' spare room: filling it with zeros
/// first would be two more passes over a frame's 48 MB.
fn pose(
    positions: &mut Vec<[Vec3; 3]>,
    faces: &mut Vec<Vec3>,
    count: usize,
    world: impl Fn(usize) -> [DVec3; 3] + Sync,
    origin: DVec3,
) -> Bounds64 {
    fn room<T>(v: &mut Vec<T>, count: usize) -> &mut [MaybeUninit<T>] {
        v.reserve(count);
        &mut v.spare_capacity_mut()[..count]
    }
    let slice = |k: usize, ps: &mut [MaybeUninit<[Vec3; 3]>], fs: &mut [MaybeUninit<Vec3>]| {
        let mut b = Bounds64::default();
        for (j, (p, f)) in ps.iter_mut().zip(fs).enumerate() {
            let p64 = world(k * SLICE + j);
            f.write((p64[1] - p64[0]).cross(p64[2] - p64[0]).normalize_or_zero().as_vec3());
            p.write(p64.map(|c| (c - origin).as_vec3()));
            b = p64.iter().fold(b, |b, &c| Bounds64 { lo: b.lo.min(c), hi: b.hi.max(c) });
        }
        b
    };
    let union = |a: Bounds64, b: Bounds64| Bounds64 { lo: a.lo.min(b.lo), hi: a.hi.max(b.hi) };
    let (ps, fs) = (room(positions, count), room(faces, count));
    let bounds = ps
        .par_chunks_mut(SLICE)
        .zip(fs.par_chunks_mut(SLICE))
        .enumerate()
        .map(|(k, (ps, fs))| slice(k, ps, fs))
        .reduce(Bounds64::default, union);
    // SAFETY: the chunks cover both rooms, and each slot of a chunk was written above; a panic
    // in `world` would have unwound before the lengths grow.
    unsafe {
        positions.set_len(positions.len() + count);
        faces.set_len(faces.len() + count);
    }
    bounds
}

/// Triangles per task of the parallel passes over a mesh.
const SLICE: usize = 4096;

fn tangent(t: Vec4, world: Mat4, mirrored: bool) -> Vec4 {
    let xyz = world.transform_vector3(t.truncate()).normalize_or_zero();
    let w = if (t.w < 0.0) != mirrored { -1.0 } else { 1.0 };
    if xyz == Vec3::ZERO || !xyz.is_finite() { Vec4::ZERO } else { xyz.extend(w) }
}

fn check_len(
    at: &dyn Fn(&str) -> String,
    name: &str,
    len: Option<usize>,
    expected: usize,
) -> Result<(), SceneError> {
    match len {
        Some(n) if n != expected => Err(SceneError::new(at(&format!(
            "{name} count {n} differs from POSITION count {expected}"
        )))),
        _ => Ok(()),
    }
}
