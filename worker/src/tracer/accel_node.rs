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
//! Here each node also has its [`ChildBoxes`]: the exact union of the triangles' boxes below
//! each child, in f32, 192 bytes beside obvhs's 80. The test is a plain slab test, four
//! children per SIMD register, the near plane chosen by an index computed once per ray
//! ([`Slabs`]). Shadow rays cost 43 % fewer instructions, closest-hit rays 5 % fewer.
//!
//! Robustness: the far distance is scaled by 1 + 2γ₃ as in pbrt-v4's `Bounds3::IntersectP`, so
//! rounding in (plane − origin) · (1/d) never culls a box the ray enters, and a zero direction
//! component of either sign is a plain slab (obvhs's grid transform computes 0·∞ = NaN there
//! and culls boxes such rays enter). Which boxes are culled only changes the work done: the hit
//! is the closest (t, triangle index) whatever the walk ([`super::Accel::intersect_where`]).
//!
//! Elsewhere than x86_64, obvhs's own test is used.
#[cfg(test)]
use glam::Vec3A;
use obvhs::aabb::Aabb;
use obvhs::cwbvh::{CwBvh, node::CwBvhNode};
use obvhs::ray::Ray;
use obvhs::triangle::Triangle;

/// A node's child boxes in tree space: `planes[axis][0]` holds the eight low planes,
/// `planes[axis][1]` the high ones; lane i is child slot i.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(super) struct ChildBoxes {
    planes: [[[f32; ROW]; 2]; 3],
}

impl ChildBoxes {
    /// Every node's child boxes, tight around the triangles below each child (`tris` in tree
    /// space, indexed as `bvh.primitive_indices` holds them). Empty slots keep an empty box.
    pub(super) fn of_tree(bvh: &CwBvh, tris: &[Triangle]) -> Vec<ChildBoxes> {
        let mut boxes = vec![ChildBoxes::EMPTY; bvh.nodes.len()];
        let mut node_box = vec![Aabb::INVALID; bvh.nodes.len()];
        // Children before parents: the reverse of a depth-first order from the root.
        for &i in depth_first(bvh).iter().rev() {
            let node = &bvh.nodes[i];
            for child in (0..8).filter(|&c| node.child_meta[c] != 0) {
                let aabb = if node.imask & (1 << child) != 0 {
                    node_box[node.child_node_index(child) as usize]
                } else {
                    let (first, count) = node.child_primitives(child);
                    (first..first + count).map(|slot| tris[bvh.primitive_indices[slot as usize] as usize].aabb()).fold(Aabb::INVALID, |a, b| a.union(&b))
                };
                boxes[i].set(child, &aabb);
                node_box[i] = node_box[i].union(&aabb);
            }
        }
        boxes
    }

    /// No box: every ray misses it (its near plane is at +∞ or its far one at −∞).
    const EMPTY: ChildBoxes = ChildBoxes { planes: [[[f32::INFINITY; ROW], [f32::NEG_INFINITY; ROW]]; 3] };

    fn set(&mut self, child: usize, aabb: &Aabb) {
        for axis in 0..3 {
            self.planes[axis][0][child] = aabb.min[axis];
            self.planes[axis][1][child] = aabb.max[axis];
        }
    }

    /// Child `child`'s box as (min, max) corners.
    #[cfg(test)]
    pub(super) fn child(&self, child: usize) -> (Vec3A, Vec3A) {
        let corner = |side: usize| Vec3A::from_array(std::array::from_fn(|axis| self.planes[axis][side][child]));
        (corner(0), corner(1))
    }
}

/// The tree's node indices, each parent before its children.
fn depth_first(bvh: &CwBvh) -> Vec<usize> {
    let mut order = Vec::with_capacity(bvh.nodes.len());
    let mut stack = if bvh.nodes.is_empty() { vec![] } else { vec![0] };
    while let Some(i) = stack.pop() {
        order.push(i);
        let node = &bvh.nodes[i];
        stack.extend((0..8).filter(|&c| node.child_meta[c] != 0 && node.imask & (1 << c) != 0).map(|c| node.child_node_index(c) as usize));
    }
    order
}

/// f32s in a row of [`ChildBoxes`] planes (one plane per child slot).
const ROW: usize = 8;

/// obvhs's node test skips children nearer than this (its private `EPSILON`); so does ours.
const NEAREST: f32 = 0.0001;

/// 1 + 2γ₃, rounded up: the far distance's allowance for rounding (pbrt-v4).
const FAR_SCALE: f32 = 1.0 + 2.0 * crate::tracer::ray::gamma(3);

/// Per-ray constants of the node test: origin and reciprocal direction in every lane, and for
/// each axis which side's planes the ray meets first.
#[cfg(target_arch = "x86_64")]
pub(super) struct Slabs {
    origin: [std::arch::x86_64::__m128; 3],
    inv: [std::arch::x86_64::__m128; 3],
    /// Per axis, the offset in f32s of the row of planes the ray meets first in a
    /// [`ChildBoxes`] (the high planes where the reciprocal direction is negative, −0 included),
    /// and of the other row.
    near: [usize; 3],
    far: [usize; 3],
}

#[cfg(target_arch = "x86_64")]
impl Slabs {
    #[inline(always)]
    pub(super) fn new(ray: &Ray) -> Slabs {
        use std::arch::x86_64::_mm_set1_ps;
        let (o, inv) = (ray.origin, ray.inv_direction);
        // SAFETY: SSE2 is part of every x86_64 target; no memory is touched.
        let splat = |v: f32| unsafe { _mm_set1_ps(v) };
        let high_first = [inv.x, inv.y, inv.z].map(|v| usize::from(v.is_sign_negative()));
        Slabs {
            origin: [splat(o.x), splat(o.y), splat(o.z)],
            inv: [splat(inv.x), splat(inv.y), splat(inv.z)],
            near: [0, 1, 2].map(|axis| ROW * (2 * axis + high_first[axis])),
            far: [0, 1, 2].map(|axis| ROW * (2 * axis + 1 - high_first[axis])),
        }
    }
}

/// The hit mask obvhs's `intersect_ray` returns: hit inner children in the high byte, the
/// candidate triangles of hit leaf children in the low 24 bits.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn hits(node: &CwBvhNode, boxes: &ChildBoxes, slabs: &Slabs, ray: &Ray, oct_inv4: u32) -> u32 {
    let children = entered(boxes, slabs, ray.tmax, 0) | entered(boxes, slabs, ray.tmax, 4) << 4;
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    super::packet::set_bits(children).fold(0, |hit_mask, child| {
        let shift = 8 * child;
        hit_mask | ((child_bits8 >> shift) as u32 & 0xff) << ((bit_index8 >> shift) as u32 & 0xff)
    })
}

/// Bit i set: the ray enters child `first + i`'s box on [NEAREST, t_max] (i < 4).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn entered(boxes: &ChildBoxes, slabs: &Slabs, t_max: f32, first: usize) -> u32 {
    use std::arch::x86_64::*;
    let planes = boxes.planes.as_ptr().cast::<f32>();
    // SAFETY: SSE2 is part of every x86_64 target. Each load reads four f32s at `row + first`:
    // rows start at multiples of ROW (`Slabs::new` makes them, below 6·ROW) and `first` is 0 or
    // 4, so the four lie inside the 48 f32s of `planes`, 16-byte aligned (the struct is 64-byte
    // aligned).
    unsafe {
        let distance = |axis: usize, row: usize| {
            let plane = _mm_load_ps(planes.add(row + first));
            _mm_mul_ps(_mm_sub_ps(plane, slabs.origin[axis]), slabs.inv[axis])
        };
        let ([near_x, near_y, near_z], [far_x, far_y, far_z]) = (slabs.near, slabs.far);
        let (nx, ny, nz) = (distance(0, near_x), distance(1, near_y), distance(2, near_z));
        let (fx, fy, fz) = (distance(0, far_x), distance(1, far_y), distance(2, far_z));
        let t_min = _mm_max_ps(_mm_max_ps(nx, ny), _mm_max_ps(nz, _mm_set1_ps(NEAREST)));
        let t_far = _mm_mul_ps(_mm_min_ps(_mm_min_ps(fx, fy), fz), _mm_set1_ps(FAR_SCALE));
        _mm_movemask_ps(_mm_cmple_ps(t_min, _mm_min_ps(t_far, _mm_set1_ps(t_max)))) as u32
    }
}

#[cfg(not(target_arch = "x86_64"))]
pub(super) struct Slabs;

#[cfg(not(target_arch = "x86_64"))]
impl Slabs {
    #[inline(always)]
    pub(super) fn new(_: &Ray) -> Slabs {
        Slabs
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub(super) fn hits(node: &CwBvhNode, _: &ChildBoxes, _: &Slabs, ray: &Ray, oct_inv4: u32) -> u32 {
    node.intersect_ray(ray, oct_inv4)
}

#[cfg(test)]
#[path = "accel_node_tests.rs"]
mod tests;
