use super::*;
use crate::tracer::chi2::Rng;
use glam::Vec3A;
use obvhs::{BvhBuildParams, cwbvh::builder::build_cwbvh_from_tris, triangle::Triangle};
use std::time::Duration;

/// Small random triangles in clusters, so that nodes hold leaf children of one to three.
fn random_tree(seed: u64, count: usize) -> CwBvh {
    let mut rng = Rng::new(seed);
    let mut v = || Vec3A::new(rng.f32(), rng.f32(), rng.f32());
    let tris: Vec<Triangle> = (0..count)
        .map(|_| {
            let c = v() * 100.0;
            Triangle { v0: c, v1: c + v(), v2: c + v() }
        })
        .collect();
    build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut Duration::default())
}

/// Each leaf child's (first slot, count).
fn leaves(bvh: &CwBvh) -> Vec<(u32, u32)> {
    bvh.nodes
        .iter()
        .flat_map(|n| {
            (0..8).filter(|&c| n.child_meta[c] != 0 && n.is_leaf(c)).map(|c| n.child_primitives(c))
        })
        .collect()
}

#[test]
fn every_primitive_keeps_one_slot_and_leaves_keep_their_triangles() {
    for (seed, count) in [(1, 3000), (2, 37), (3, 1)] {
        let before = random_tree(seed, count);
        let mut after = before.clone();
        pack_leaves(&mut after);
        let real: Vec<u32> =
            after.primitive_indices.iter().copied().filter(|&p| p != PAD).collect();
        let mut sorted = real.clone();
        sorted.sort_unstable();
        assert_eq!(
            sorted,
            (0..count as u32).collect::<Vec<_>>(),
            "seed {seed}: each primitive once"
        );
        assert_eq!(after.primitive_indices.len() % 4, 0, "whole packets");
        for (b, a) in leaves(&before).into_iter().zip(leaves(&after)) {
            let of = |bvh: &CwBvh, (first, n): (u32, u32)| {
                bvh.primitive_indices[first as usize..(first + n) as usize].to_vec()
            };
            assert_eq!(of(&before, b), of(&after, a), "a leaf child's triangles, in order");
        }
        // Padding is never named by a node, and the hit mask's leaf bits stay below bit 24.
        for node in &after.nodes {
            assert_eq!(node.primitive_base_idx % 4, 0, "a node's slots start a packet");
            for c in (0..8).filter(|&c| node.child_meta[c] != 0 && node.is_leaf(c)) {
                let (first, n) = node.child_primitives(c);
                assert!(first + n - node.primitive_base_idx <= NODE_SLOTS);
            }
        }
    }
}

#[test]
fn no_leaf_straddles_a_packet_where_the_node_has_room() {
    let mut bvh = random_tree(4, 3000);
    pack_leaves(&mut bvh);
    let (mut within, mut all) = (0, 0);
    for (first, n) in leaves(&bvh) {
        all += 1;
        within += usize::from(first / 4 == (first + n - 1) / 4);
    }
    // A node needs more than six packets only with more than six leaves of three: rare.
    assert!(within * 100 >= all * 99, "{within} of {all} leaves within one packet");
}

#[test]
fn first_fit_decreasing_shares_packets() {
    // Leaves of 3, 1, 2, 2: [3 1] [2 2], two packets.
    let leaves = [(0, 0, 3), (1, 3, 1), (2, 4, 2), (3, 6, 2)];
    assert_eq!(packed(&leaves), Some(vec![0, 3, 4, 6]));
    // Eight leaves of three need eight packets, more than 24 slots: obvhs's order instead.
    let full: Vec<(usize, u32, u32)> = (0..8).map(|c| (c, 3 * c as u32, 3)).collect();
    assert_eq!(packed(&full), None);
    assert_eq!(in_order(&full), (0..8).map(|c| 3 * c).collect::<Vec<u32>>());
}
