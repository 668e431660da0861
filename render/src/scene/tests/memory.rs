//! What loading a large scene allocates: the file's binary chunk is not copied when the file is
//! handed over, tightly packed positions are read in place, and the mesh is allocated once at
//! its final size. Each path must give the same scene as the general one.
use super::super::accessors::packed_vec3;
use super::super::*;
use crate::tracer::Scene;

/// A zigzag strip of `vertices` vertices (non-indexed), instanced by `nodes` nodes, with each
/// position padded to `stride` bytes (12: tightly packed).
fn strip_glb(vertices: usize, nodes: usize, stride: usize) -> Vec<u8> {
    let (json, bin) = strip_parts(vertices, nodes, stride);
    pack_glb(&json, &bin)
}

/// [`strip_glb`]'s JSON and binary chunks.
fn strip_parts(vertices: usize, nodes: usize, stride: usize) -> (String, Vec<u8>) {
    let mut bin = Vec::new();
    for i in 0..vertices {
        let p = [i as f32 * 0.01, (i % 2) as f32, 0.25];
        bin.extend(p.iter().flat_map(|c| c.to_le_bytes()));
        bin.resize(bin.len() + stride - 12, 0xAB);
    }
    let node_list: Vec<String> = (0..nodes).map(|n| n.to_string()).collect();
    let node_json: Vec<String> = (0..nodes)
        .map(|n| format!(r#"{{"mesh":0,"translation":[0,0,{}]}}"#, -(n as f32)))
        .collect();
    let stride_json =
        if stride == 12 { String::new() } else { format!(r#","byteStride":{stride}"#) };
    let json = format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[{}]}}],"nodes":[{}],
        "meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"mode":5}}]}}],
        "accessors":[{{"bufferView":0,"componentType":5126,"count":{vertices},"type":"VEC3","min":[0,0,0.25],"max":[{:?},1,0.25]}}],
        "bufferViews":[{{"buffer":0,"byteLength":{}{stride_json}}}],"buffers":[{{"byteLength":{}}}]}}"#,
        node_list.join(","),
        node_json.join(","),
        (vertices - 1) as f32 * 0.01,
        bin.len(),
        bin.len()
    );
    (json, bin)
}

fn assert_same_scene(a: &Scene, b: &Scene) {
    let bits = |s: &Scene| {
        s.mesh
            .positions
            .iter()
            .flatten()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(a), bits(b));
    assert_eq!((a.mesh.len(), &a.mesh.material), (b.mesh.len(), &b.mesh.material));
    assert_eq!(
        (0..a.mesh.len()).map(|i| a.mesh.normals_of(i)).collect::<Vec<_>>(),
        (0..b.mesh.len()).map(|i| b.mesh.normals_of(i)).collect::<Vec<_>>()
    );
}

#[test]
fn a_file_handed_over_gives_the_scene_its_borrowed_bytes_give() {
    let glb = strip_glb(50, 2, 12);
    let borrowed = Sequence::parse(&glb, None).unwrap().scene_at(None, 0.0).unwrap();
    let owned = Sequence::parse_owned(glb, None, DEFAULT_MAX_TRIANGLES)
        .unwrap()
        .scene_at(None, 0.0)
        .unwrap();
    assert_eq!(owned.mesh.len(), 2 * 48);
    assert_same_scene(&owned, &borrowed);
    // A .gltf (JSON, its buffer a data URI) has no binary chunk to keep.
    let json = tests::triangle_gltf(true, "").into_bytes();
    let owned = Sequence::parse_owned(json.clone(), None, DEFAULT_MAX_TRIANGLES)
        .unwrap()
        .scene_at(None, 0.0)
        .unwrap();
    assert_same_scene(&owned, &load_bytes(&json, None).unwrap());
    // Errors are the same either way.
    let broken = strip_glb(50, 1, 12)[..100].to_vec();
    assert_eq!(
        Sequence::parse_owned(broken.clone(), None, DEFAULT_MAX_TRIANGLES).unwrap_err(),
        Sequence::parse(&broken, None).unwrap_err()
    );
}

#[test]
fn packed_positions_are_read_in_place_and_strided_ones_through_the_reader_alike() {
    let packed = strip_glb(40, 1, 12);
    let strided = strip_glb(40, 1, 16);
    for (glb, in_place) in [(&packed, true), (&strided, false)] {
        let gltf = gltf::Gltf::from_slice(glb).unwrap();
        let buffers = vec![gltf.blob.clone().unwrap()];
        let accessor = gltf.document.accessors().next().unwrap();
        assert_eq!(packed_vec3(&accessor, &buffers).is_some(), in_place);
    }
    assert_same_scene(&load_bytes(&packed, None).unwrap(), &load_bytes(&strided, None).unwrap());
}

#[test]
fn a_loaded_mesh_is_allocated_at_its_size() {
    // 3 × 998 triangles: grown by doubling, the vectors would hold room for 4,096.
    let scene = load_bytes(&strip_glb(1000, 3, 12), None).unwrap();
    let n = scene.mesh.len();
    assert_eq!(n, 3 * 998);
    let per_triangle = size_of::<[glam::Vec3; 3]>() + size_of::<glam::Vec3>() + size_of::<u32>();
    assert_eq!(
        scene.mesh.heap_bytes(),
        n * per_triangle,
        "positions, one flat normal and a material each"
    );
}

#[test]
fn the_mesh_is_sized_by_the_triangles_instanced_that_the_buffers_hold() {
    let count = |glb: &[u8]| {
        let gltf = gltf::Gltf::from_slice(glb).unwrap();
        let buffers = vec![gltf.blob.clone().unwrap()];
        super::super::budget::instanced(
            &gltf.document.scenes().next().unwrap(),
            gltf.document.nodes().len(),
            &buffers,
        )
    };
    assert_eq!(count(&strip_glb(10, 3, 12)), 3 * 8, "each instance counts");
    // An accessor claiming more vertices than its buffer holds reserves nothing (and fails to load).
    let (json, bin) = strip_parts(10, 3, 12);
    let claims_more = pack_glb(&json.replace(r#""count":10,"#, r#""count":99999,"#), &bin);
    assert_eq!(count(&claims_more), 0);
    assert!(
        load_bytes(&claims_more, None).unwrap_err().0.contains("POSITION accessor"),
        "refused when read"
    );
}

/// A large frame is posed, its face normals found and its tree made over several threads, in
/// chunks: it must come out the same bits on one thread as on four.
#[test]
fn a_large_scene_loads_the_same_on_one_thread_and_on_four() {
    // 2 × 39,998 triangles: more than one posing chunk per node, many parallel pieces each.
    let glb = strip_glb(40_000, 2, 12);
    let load = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| Sequence::parse(&glb, None).unwrap().scene_at(None, 0.0).unwrap())
    };
    let (one, four) = (load(1), load(4));
    assert_eq!(one.mesh.len(), 2 * 39_998);
    assert_same_scene(&one, &four);
    assert_eq!(one.face_normals, four.face_normals);
    assert_eq!((one.bounds_centre, one.bounds_radius), (four.bounds_centre, four.bounds_radius));
    for k in 0..2000 {
        let x = k as f32 * 0.2;
        let ray = crate::tracer::ray::Ray::new(
            glam::Vec3::new(x, 0.5, 3.0),
            glam::Vec3::new(0.01, 0.001, -1.0).normalize(),
        );
        assert_eq!(
            one.accel.intersect(&ray, f32::INFINITY),
            four.accel.intersect(&ray, f32::INFINITY),
            "ray {k}"
        );
    }
}
