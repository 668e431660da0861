//! Building the tree: which triangles it holds, the power-of-two scale of tree space, obvhs's
//! binary build and its conversion to the wide tree, and the depth check that sends
//! pathological trees to the binary walk (see `accel.rs`'s header for why tree space is scaled).
use glam::{Vec3, Vec3A};
use obvhs::bvh2::reinsertion::ReinsertionOptimizer;
use obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh;
use obvhs::ploc::PlocBuilder;
use obvhs::{BvhBuildParams, bvh2::Bvh2, cwbvh::CwBvh, triangle::Triangle};
use rayon::prelude::*;

/// Tree space is scaled so that the scene is about 2^TARGET_EXTENT_LOG2 units across.
const TARGET_EXTENT_LOG2: i32 = 12;

/// The caller's triangles `keep`, scaled into tree space, as obvhs triangles.
pub(super) fn tree_triangles(tris: &[[Vec3; 3]], keep: &[u32], scale: f32) -> Vec<Triangle> {
    keep.iter().map(|&i| tree_triangle(&tris[i as usize], scale)).collect()
}

/// One triangle scaled into tree space, as obvhs takes it.
pub(super) fn tree_triangle(t: &[Vec3; 3], scale: f32) -> Triangle {
    Triangle {
        v0: Vec3A::from(t[0] * scale),
        v1: Vec3A::from(t[1] * scale),
        v2: Vec3A::from(t[2] * scale),
    }
}

/// The tree obvhs built: wide (its leaves packed, `layout.rs`), or binary.
pub(super) enum Topology {
    Wide(CwBvh),
    Binary(Bvh2),
}

impl Topology {
    /// Primitive slot → index into the triangles the tree was built over.
    pub(super) fn slots(&self) -> &[u32] {
        match self {
            Topology::Wide(w) => &w.primitive_indices,
            Topology::Binary(b) => &b.primitive_indices,
        }
    }
}

/// The binary tree obvhs's `build_cwbvh_from_tris` converts (the same steps, without spatial
/// splits, which `medium_build` does not use).
pub(super) fn wide_source(tris: &[Triangle], params: BvhBuildParams) -> Bvh2 {
    let mut bvh2 = PlocBuilder::with_capacity(tris.len()).build(
        params.ploc_search_distance,
        tris,
        (0..tris.len() as u32).collect::<Vec<_>>(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
    bvh2
}

pub(super) fn to_wide(bvh2: &Bvh2, params: BvhBuildParams) -> CwBvh {
    bvh2_to_cwbvh(bvh2, params.max_prims_per_leaf.clamp(1, 3), true, false)
}

/// The wide-tree traversal stack's depth.
pub(super) const WIDE_STACK: u32 = super::wide::STACK as u32;

/// Depth of a wide BVH, walked as obvhs's own validation does.
pub(super) fn wide_depth(bvh: &CwBvh) -> u32 {
    let mut stack = vec![(0usize, 0u32)];
    let mut deepest = 0;
    while let Some((i, depth)) = stack.pop() {
        deepest = deepest.max(depth);
        let Some(node) = bvh.nodes.get(i) else { continue };
        stack.extend(inner_children(node).map(|child| (child, depth + 1)));
    }
    deepest
}

/// The node indices of `node`'s inner children, as obvhs's `child_node_index` finds them but
/// without trusting the metadata (a slot below 24 is skipped, not an underflow): the trees
/// [`wide_depth`] vets may be pathological.
pub(super) fn inner_children(
    node: &obvhs::cwbvh::node::CwBvhNode,
) -> impl Iterator<Item = usize> + '_ {
    node.child_meta.iter().enumerate().filter_map(|(ch, meta)| {
        let slot = (meta & 0b11111).checked_sub(24).filter(|_| node.imask & (1 << ch) != 0)?;
        let before = (node.imask as u32 & !(u32::MAX << slot)).count_ones();
        Some(node.child_base_idx as usize + before as usize)
    })
}

/// Power of two bringing the extent of the triangles `held` near 2^TARGET_EXTENT_LOG2, clamped
/// so nothing overflows. Their box is found in parallel: minima and maxima, exact in any order.
pub(super) fn tree_scale(tris: &[[Vec3; 3]], held: impl Fn(usize) -> bool + Sync) -> f32 {
    const RUN: usize = 16_384;
    let empty = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    let run = |(r, run): (usize, &[[Vec3; 3]])| {
        let (mut lo, mut hi) = empty;
        for (_, t) in (r * RUN..).zip(run).filter(|(i, _)| held(*i)) {
            (lo, hi) = (lo.min(t[0]).min(t[1]).min(t[2]), hi.max(t[0]).max(t[1]).max(t[2]));
        }
        (lo, hi)
    };
    let (lo, hi) = tris
        .par_chunks(RUN)
        .enumerate()
        .map(run)
        .reduce(|| empty, |(l0, h0), (l1, h1)| (l0.min(l1), h0.max(h1)));
    scale_for_box(lo, hi)
}

/// [`tree_scale`] of triangles whose corners span the box from `lo` to `hi` (empty: lo > hi).
pub(super) fn scale_for_box(lo: Vec3, hi: Vec3) -> f32 {
    let extent = (hi - lo).max_element();
    let reach = lo.abs().max(hi.abs()).max_element();
    if !(extent.is_finite() && extent > 0.0) {
        return 1.0;
    }
    let mut k = TARGET_EXTENT_LOG2 - extent.log2().ceil() as i32;
    // Keep scaled coordinates below 2^100 so products in the triangle test cannot overflow.
    k = k.min(100 - reach.log2().ceil() as i32).clamp(-100, 100);
    2f32.powi(k)
}
