//! The wide-BVH node test, on tight f32 child boxes computed when the tree is built.
//!
//! obvhs stores a node's eight child boxes as bytes on a per-node grid (origin `p`, a
//! power-of-two cell of 1/255 of the node's extent, boxes rounded outward to it) and decodes them
//! in every node test. Two costs follow, both measured on the Cornell box (callgrind,
//! 2026-12-03):
//! - the decoding: 24 byte-to-float conversions, the grid's scale and a branch per axis on the
//!   ray's direction made up most of a node test's ≈ 185 instructions;
//! - the rounding: a flat box (a wall, the ceiling, the light) grows by up to a cell, ≈ 2 units
//!   of the box's 556 at the root. A shadow ray ends just below the light, so it entered the
//!   light's and the ceiling's leaves and tested their triangles on nearly every light sample.
//!
//! Here each node is a [`Node`] of 256 bytes: the exact union of the triangles' boxes below
//! each child, in f32, and the links the walk follows (it reads obvhs's node no more). The test
//! is a plain slab test, four children per SIMD register, the near plane chosen by an index
//! computed once per ray ([`Slabs`]). Shadow rays cost 43 % fewer instructions, closest-hit rays 5 % fewer.
//!
//! Robustness: the far distance is scaled by 1 + 2γ₃ as in pbrt-v4's `Bounds3::IntersectP`, so
//! rounding in (plane − origin) · (1/d) never culls a box the ray enters, and a zero direction
//! component of either sign is a plain slab (obvhs's grid transform computes 0·∞ = NaN there
//! and culls boxes such rays enter). Which boxes are culled only changes the work done: the hit
//! is the closest (t, triangle index) whatever the walk ([`super::Accel::intersect_where`]).
//!
//! The arithmetic is glam's `Vec4` (SSE2 on x86_64, NEON on aarch64), so every target gets the
//! same test.
use glam::{BVec4A, Vec3A, Vec4};
use obvhs::aabb::Aabb;
use obvhs::cwbvh::{CwBvh, node::CwBvhNode};
use obvhs::ray::Ray;
use rayon::prelude::*;

/// A node as the walk reads it: its child boxes in tree space, one row of eight planes (two SIMD
/// vectors, lane i of vector h is child slot 4h + i) per axis and side (row 2·axis holds the low
/// planes, row 2·axis + 1 the high ones), and what the walk needs of obvhs's node, so that it
/// reads one 256-byte record per node and not obvhs's 80 bytes besides.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct Node {
    rows: [[Vec4; 2]; 6],
    /// Per child slot, the candidate-triangle bits a leaf child adds to the hit mask (obvhs's
    /// unary count shifted to its offset), as an f32 holding that integer exactly (below 2²⁴);
    /// 0 for inner children and empty slots. Distinct leaves' bits are disjoint, so their sum is
    /// their union: an SIMD select and a sum make a node's leaf bits without a loop.
    leaf_bits: [Vec4; 2],
    /// obvhs's `child_base_idx`, `primitive_base_idx` and `imask`.
    pub(super) child_base: u32,
    pub(super) primitive_base: u32,
    pub(super) imask: u32,
}

impl Node {
    /// Every node of the tree, its child boxes tight around the triangles below each child
    /// (`slot_box(s)`: the tree-space box of the triangle in primitive slot s, empty for one
    /// never hit). Empty child slots keep an empty box.
    ///
    /// The leaf children, a box per triangle and nearly all the work, are made node by node in
    /// parallel; the inner children then bottom-up, each the union of its node's child boxes.
    pub(super) fn of_tree(bvh: &CwBvh, slot_box: impl Fn(usize) -> Aabb + Sync) -> Vec<Node> {
        let mut nodes: Vec<Node> = bvh.nodes.iter().map(Node::empty_with_links).collect();
        let mut node_box: Vec<Aabb> = nodes
            .par_iter_mut()
            .zip(&bvh.nodes)
            .with_min_len(256)
            .map(|(node, n)| node.set_leaves(n, &slot_box))
            .collect();
        // Children before parents: the reverse of a depth-first order from the root.
        for &i in depth_first(bvh).iter().rev() {
            let node = &bvh.nodes[i];
            for child in (0..8).filter(|&c| node.child_meta[c] != 0 && node.imask & (1 << c) != 0) {
                let aabb = node_box[node.child_node_index(child) as usize];
                nodes[i].set(child, &aabb);
                node_box[i] = node_box[i].union(&aabb);
            }
        }
        nodes
    }

    /// The boxes and bits of the leaf children of obvhs's node `n` (this node's), and the union
    /// of those boxes.
    fn set_leaves(&mut self, n: &CwBvhNode, slot_box: &impl Fn(usize) -> Aabb) -> Aabb {
        let mut leaves = Aabb::INVALID;
        for child in (0..8).filter(|&c| n.child_meta[c] != 0 && n.imask & (1 << c) == 0) {
            let (first, count) = n.child_primitives(child);
            let meta = n.child_meta[child];
            self.leaf_bits[child / 4][child % 4] =
                (u32::from(meta >> 5) << (meta & 0b1_1111)) as f32;
            let aabb = (first..first + count)
                .map(|slot| slot_box(slot as usize))
                .fold(Aabb::INVALID, |a, b| a.union(&b));
            self.set(child, &aabb);
            leaves = leaves.union(&aabb);
        }
        leaves
    }

    /// No box: every ray misses it (its near plane is at +∞ or its far one at −∞).
    const EMPTY: Node = {
        let (lo, hi) = ([Vec4::INFINITY; 2], [Vec4::NEG_INFINITY; 2]);
        Node {
            rows: [lo, hi, lo, hi, lo, hi],
            leaf_bits: [Vec4::ZERO; 2],
            child_base: 0,
            primitive_base: 0,
            imask: 0,
        }
    };

    /// No boxes yet, and the links of obvhs's node `n`.
    fn empty_with_links(n: &CwBvhNode) -> Node {
        Node {
            child_base: n.child_base_idx,
            primitive_base: n.primitive_base_idx,
            imask: u32::from(n.imask),
            ..Node::EMPTY
        }
    }

    fn set(&mut self, child: usize, aabb: &Aabb) {
        for axis in 0..3 {
            self.rows[2 * axis][child / 4][child % 4] = aabb.min[axis];
            self.rows[2 * axis + 1][child / 4][child % 4] = aabb.max[axis];
        }
    }

    /// Child `child`'s box as (min, max) corners (min > max for an empty child slot).
    pub(super) fn child(&self, child: usize) -> (Vec3A, Vec3A) {
        let corner = |side: usize| {
            Vec3A::from_array(std::array::from_fn(|axis| {
                self.rows[2 * axis + side][child / 4][child % 4]
            }))
        };
        (corner(0), corner(1))
    }
}

/// The surface-area cost of walking `nodes`: per child box, its area times the work a ray that
/// enters it does there (one node test for an inner child, a triangle test per triangle of a
/// leaf), summed and divided by the root's area. If rays entered boxes in proportion to their
/// areas (the SAH's assumption) this would be a ray's expected work; a refit compares it with
/// the cost of the tree as built to tell when moved triangles have worn the tree out.
pub(super) fn walk_cost(nodes: &[Node]) -> f64 {
    let Some(root) = nodes.first() else { return 0.0 };
    let child_box =
        |node: &Node, c: usize| Some(node.child(c)).filter(|(lo, hi)| lo.cmple(*hi).all());
    let area = |(lo, hi): (Vec3A, Vec3A)| {
        let d = (hi - lo).as_dvec3();
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    };
    let node_work = |node: &Node| -> f64 {
        let tests = |c: usize| match node.imask & (1 << c) != 0 {
            true => 1,
            false => (node.leaf_bits[c / 4][c % 4] as u32).count_ones(),
        };
        (0..8).filter_map(|c| child_box(node, c).map(|b| area(b) * f64::from(tests(c)))).sum()
    };
    // Summed in fixed chunks, then the chunks in order: the same figure on any number of threads.
    let chunks: Vec<f64> =
        nodes.par_chunks(1024).map(|chunk| chunk.iter().map(node_work).sum()).collect();
    let work: f64 = chunks.iter().sum();
    let (lo, hi) = (0..8)
        .filter_map(|c| child_box(root, c))
        .fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |(lo, hi), (l, h)| (lo.min(l), hi.max(h)));
    let root_area = area((lo, hi));
    if root_area > 0.0 { work / root_area } else { 0.0 }
}

/// The tree's node indices, each parent before its children.
fn depth_first(bvh: &CwBvh) -> Vec<usize> {
    let mut order = Vec::with_capacity(bvh.nodes.len());
    let mut stack = if bvh.nodes.is_empty() { vec![] } else { vec![0] };
    while let Some(i) = stack.pop() {
        order.push(i);
        stack.extend(super::build::inner_children(&bvh.nodes[i]));
    }
    order
}

/// obvhs's node test skips children nearer than this (its private `EPSILON`); so does ours.
const NEAREST: f32 = 0.0001;

/// 1 + 2γ₃, rounded up: the far distance's allowance for rounding (pbrt-v4).
const FAR_SCALE: f32 = 1.0 + 2.0 * crate::tracer::ray::gamma(3);

/// Per-ray constants of the node test: origin and reciprocal direction in every lane, and per
/// axis the [`Node`] row of planes the ray meets first (the high planes where the
/// reciprocal direction is negative, −0 included) and the other row.
pub(super) struct Slabs {
    origin: [Vec4; 3],
    inv: [Vec4; 3],
    near: [usize; 3],
    far: [usize; 3],
}

impl Slabs {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> Slabs {
        let (o, inv) = (ray.origin, ray.inv_direction);
        let high_first = [inv.x, inv.y, inv.z].map(|v| usize::from(v.is_sign_negative()));
        Slabs {
            origin: [o.x, o.y, o.z].map(Vec4::splat),
            inv: [inv.x, inv.y, inv.z].map(Vec4::splat),
            near: [0, 1, 2].map(|axis| 2 * axis + high_first[axis]),
            far: [0, 1, 2].map(|axis| 2 * axis + 1 - high_first[axis]),
        }
    }
}

/// The hit mask obvhs's `intersect_ray` returns: hit inner children in the high byte, the
/// candidate triangles of hit leaf children in the low 24 bits.
///
/// obvhs builds it child by child; here the leaf bits are a masked SIMD sum ([`Node`]) and the
/// inner bits one table lookup: obvhs's slot of inner child c (its traversal priority) is
/// c XOR the ray's octant, a fixed permutation of the byte of hit children per octant.
/// `AVX`: the eight boxes in one 256-bit register (`accel_node_wide8.rs`), only in code compiled
/// for AVX2.
#[inline(always)]
pub(super) fn hits<const AVX: bool>(node: &Node, slabs: &Slabs, ray: &Ray, oct_inv4: u32) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if AVX {
        // SAFETY: AVX is true only in the copy of the walk compiled for AVX2 (`accel/avx2.rs`).
        let (children, leaves) = unsafe { wide8::entered(node, slabs, ray.tmax) };
        return hit_mask(node, children, leaves, oct_inv4);
    }
    let (lo, hi) = (entered(node, slabs, ray.tmax, 0), entered(node, slabs, ray.tmax, 1));
    let children = lo.bitmask() | hi.bitmask() << 4;
    let leaves = (Vec4::select(lo, node.leaf_bits[0], Vec4::ZERO)
        + Vec4::select(hi, node.leaf_bits[1], Vec4::ZERO))
    .element_sum() as u32;
    hit_mask(node, children, leaves, oct_inv4)
}

/// The hit mask from the entered children (bit c: child c) and the leaf bits they contribute.
#[inline(always)]
fn hit_mask(node: &Node, children: u32, leaves: u32, oct_inv4: u32) -> u32 {
    let inner = XOR_PERMUTED[(oct_inv4 & 7) as usize][(children & node.imask) as usize];
    u32::from(inner) << 24 | leaves
}

/// `XOR_PERMUTED[o][b]`: the byte whose bit c ^ o is bit c of b.
static XOR_PERMUTED: [[u8; 256]; 8] = {
    let mut table = [[0u8; 256]; 8];
    let mut o = 0;
    while o < 8 {
        let mut b = 0;
        while b < 256 {
            let mut c = 0;
            while c < 8 {
                if b >> c & 1 != 0 {
                    table[o][b] |= 1 << (c ^ o);
                }
                c += 1;
            }
            b += 1;
        }
        o += 1;
    }
    table
};

/// Lane i set: the ray enters child 4·`half` + i's box on [NEAREST, t_max].
#[inline(always)]
fn entered(node: &Node, slabs: &Slabs, t_max: f32, half: usize) -> BVec4A {
    let distance =
        |axis: usize, row: usize| (node.rows[row][half] - slabs.origin[axis]) * slabs.inv[axis];
    let ([near_x, near_y, near_z], [far_x, far_y, far_z]) = (slabs.near, slabs.far);
    let (nx, ny, nz) = (distance(0, near_x), distance(1, near_y), distance(2, near_z));
    let (fx, fy, fz) = (distance(0, far_x), distance(1, far_y), distance(2, far_z));
    let t_min = nx.max(ny).max(nz.max(Vec4::splat(NEAREST)));
    let t_far = fx.min(fy).min(fz) * FAR_SCALE;
    t_min.cmple(t_far.min(Vec4::splat(t_max)))
}

#[cfg(target_arch = "x86_64")]
mod wide8;

#[cfg(test)]
mod tests;
