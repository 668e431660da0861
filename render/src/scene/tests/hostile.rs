//! Small files that declare huge scenes: each must be refused before anything big is allocated
//! (the tests would otherwise take gigabytes and minutes, which is how they fail).
use super::super::tests::triangle_gltf;
use super::super::*;

fn refused(bytes: &[u8], max_triangles: u64, expect: &str) {
    let t0 = std::time::Instant::now();
    let err = parse_limited(bytes, None, max_triangles)
        .err()
        .unwrap_or_else(|| panic!("accepted; expected {expect:?}"));
    assert!(err.0.contains(expect), "{:?} does not mention {expect:?}", err.0);
    assert!(t0.elapsed().as_secs_f64() < 1.0, "refusing took {:?}", t0.elapsed());
}

/// The triangle scene with a second primitive whose POSITION accessor has no buffer view:
/// `count` zero vertices (one overridden by sparse data) that cost nothing in the file.
fn viewless_bomb(count: u64) -> String {
    triangle_gltf(true, "")
        .replace(r#""material":0}]"#, r#""material":0},{"attributes":{"POSITION":1}}]"#)
        .replace(r#""max":[1,1,0]}]"#, &format!(r#""max":[1,1,0]}},{{"componentType":5126,"count":{count},"type":"VEC3","min":[0,0,0],"max":[1,1,0],
            "sparse":{{"count":1,"indices":{{"bufferView":0,"componentType":5125}},"values":{{"bufferView":0}}}}}}]"#))
}

#[test]
fn a_triangle_bomb_is_refused_from_its_counts() {
    // 10⁷ triangles declared in a 1 KB file.
    let bomb = viewless_bomb(30_000_000);
    assert!(bomb.len() < 2048);
    refused(bomb.as_bytes(), 5_000_000, "more than 5000000 triangles");
    // Under the triangle limit, the zero-filled accessor itself is too large to read.
    refused(bomb.as_bytes(), DEFAULT_MAX_TRIANGLES, "has no bufferView and count 30000000");
    // A small view-less accessor is legal glTF (zeros: a degenerate triangle) and loads.
    let scene = parse(viewless_bomb(3).as_bytes(), None).expect("a small zero accessor is fine");
    assert_eq!(scene.triangles(), 2);
}

#[test]
fn instances_count_against_the_limit() {
    // Three nodes instancing the one-triangle mesh: three triangles.
    let three = triangle_gltf(true, "")
        .replace(r#""nodes":[0,1]"#, r#""nodes":[0,1,2,3]"#)
        .replace(r#""translation":[0,0,3]}]"#, r#""translation":[0,0,3]},{"mesh":0},{"mesh":0}]"#);
    assert_eq!(parse_limited(three.as_bytes(), None, 3).expect("at the limit").triangles(), 3);
    refused(three.as_bytes(), 2, "more than 2 triangles");
}

#[test]
fn a_node_reached_twice_is_refused() {
    // Node 2 is both a root and node 0's child.
    let shared = triangle_gltf(true, "")
        .replace(r#""nodes":[0,1]"#, r#""nodes":[0,1,2]"#)
        .replace(r#""nodes":[{"mesh":0}"#, r#""nodes":[{"mesh":0,"children":[2]}"#)
        .replace(r#""translation":[0,0,3]}]"#, r#""translation":[0,0,3]},{"mesh":0}]"#);
    refused(shared.as_bytes(), DEFAULT_MAX_TRIANGLES, "node 2 appears more than once");
    let cycle = triangle_gltf(true, "")
        .replace(r#""nodes":[{"mesh":0}"#, r#""nodes":[{"mesh":0,"children":[0]}"#);
    refused(cycle.as_bytes(), DEFAULT_MAX_TRIANGLES, "node 0 appears more than once");
}

#[test]
fn a_doubling_node_chain_is_refused_at_once() {
    // Node k lists node k+1 twice: 2⁶⁰ instances of the last node's mesh if walked naively.
    let chain: Vec<String> =
        (2..62).map(|k| format!(r#"{{"children":[{},{}]}}"#, k + 1, k + 1)).collect();
    let nodes = format!(
        r#""nodes":[{{"mesh":0}},{{"camera":0,"translation":[0,0,3]}},{},{{"mesh":0}}]"#,
        chain.join(",")
    );
    let chain = triangle_gltf(true, "")
        .replace(r#""nodes":[0,1]"#, r#""nodes":[0,1,2]"#)
        .replace(r#""nodes":[{"mesh":0},{"camera":0,"translation":[0,0,3]}]"#, &nodes);
    assert!(chain.contains(r#"{"children":[61,61]}"#));
    let e = parse(chain.as_bytes(), None).err().expect("refused");
    assert!(e.0.contains("appears more than once") || e.0.contains("invalid glTF"), "{e}");
}

/// A mutated bundled scene (found by libFuzzer) whose wide BVH is deeper than obvhs's 32-entry
/// traversal stack: it gets the binary tree, so every ray finds what an unlimited-stack traversal
/// finds. (The loop over triangles is no reference here: with corners near 1e32 its unscaled
/// triangle test overflows to a NaN distance, where the tree, built in a rescaled space, does not.)
#[test]
fn a_scene_too_deep_for_the_wide_bvh_still_finds_every_hit() {
    use crate::tracer::accel::{Accel, BvhKind};
    use crate::tracer::ray::Ray;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus/bvh-too-deep-f4728aa7.bin");
    let scene = load_bytes(&std::fs::read(path).expect("corpus file"), None).expect("loads");
    let tris = &scene.mesh.positions;
    let binary = Accel::build(tris, BvhKind::Binary);
    let mut x = 11u64;
    let mut rnd = || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x >> 40) as f32 / (1u64 << 24) as f32
    };
    let mut hits = 0;
    for k in 0..2000 {
        let target = tris[k % tris.len()].iter().sum::<glam::Vec3>() / 3.0;
        let origin = target + (glam::Vec3::new(rnd(), rnd(), rnd()) - 0.5) * 8.0;
        let ray = Ray::new(origin, (target - origin).normalize_or(glam::Vec3::Z));
        let expected = binary.intersect(&ray, f32::INFINITY).map(|h| h.t.to_bits());
        assert_eq!(
            scene.accel.intersect(&ray, f32::INFINITY).map(|h| h.t.to_bits()),
            expected,
            "ray {k}"
        );
        assert_eq!(scene.accel.occluded(&ray, f32::INFINITY), expected.is_some(), "ray {k}");
        hits += expected.is_some() as u32;
    }
    assert!(hits > 1000, "{hits} hits");
}
