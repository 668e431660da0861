//! Up to eight closest-hit rays walking the wide tree together: a bundle.
//!
//! Why: a camera ray's walk costs a closest-hit query's fixed ≈ 170 instructions (the ray's
//! constants, broadcast and mostly spilled) and ≈ 90 per node, of which the node test proper is
//! a third; the rest is the walk's bookkeeping (docs/performance.md, session 31). A pixel's
//! camera rays, jittered within the pixel, enter nearly the same boxes, so eight of them can
//! share one walk: each node is fetched and its bookkeeping done once for the bundle, and only
//! the node test and the triangle tests are done per ray.
//!
//! What each ray finds does not depend on the bundle: every ray runs the same node test
//! (`node::entered_children`) and the same triangle test against its own `t_max` as it would
//! walking alone, and the closest hit is the closest (t, triangle index) whatever the order in
//! which boxes are visited ([`super::Accel::intersect_where`]). A bundle of one ray is a walk.
//!
//! Order: inner children are visited in the order the single walk uses for the first ray's
//! octant; a child is visited with the rays that entered its box, and each ray's box test
//! there uses its `t_max` as shortened by then.
use super::node::{Node, Slabs, entered_children};
use super::packet::{WatertightRay, for_packets};
use super::wide::octant_inv4;
use super::{Accel, Candidate, Hit, Tree};
use crate::tracer::ray::Ray as SceneRay;
use glam::Vec3;
use obvhs::ray::Ray;
use std::mem::MaybeUninit;

/// Rays in a bundle at most (one lane bit each in a byte).
pub const BUNDLE: usize = 8;

/// A tree shallower than `wide::STACK` (32) pushes at most seven children per level.
const STACK: usize = 7 * super::wide::STACK + 1;

impl Accel {
    /// The closest hit with 0 < t < t_max of each of `rays` (at most [`BUNDLE`]) into `hits`:
    /// for each ray, exactly what [`Accel::intersect_where`] finds for it alone, found by one
    /// walk of the tree for all of them (the module docs).
    pub fn intersect_bundle_where(&self, rays: &[SceneRay], t_max: f32, keep: impl Fn(u32, f32, f32) -> bool, hits: &mut [Option<Hit>]) {
        assert!(rays.len() <= BUNDLE && hits.len() == rays.len(), "a bundle of {} rays for {} hits", rays.len(), hits.len());
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has the features `closest_bundle_avx2` enables.
            return unsafe { self.closest_bundle_avx2(rays, t_max, keep, hits) };
        }
        self.closest_bundle::<false>(rays, t_max, keep, hits)
    }

    #[inline(always)]
    pub(super) fn closest_bundle<const AVX: bool>(&self, rays: &[SceneRay], t_max: f32, keep: impl Fn(u32, f32, f32) -> bool, hits: &mut [Option<Hit>]) {
        let Tree::Wide(nodes) = &self.tree else {
            for (ray, hit) in rays.iter().zip(hits) {
                *hit = self.closest::<AVX>(ray, t_max, &keep, &mut ());
            }
            return;
        };
        let prepared: [_; BUNDLE] = std::array::from_fn(|lane| rays.get(lane).and_then(|r| self.tree_ray(r, t_max)));
        let active = prepared.iter().enumerate().fold(0u8, |a, (lane, p)| a | u8::from(p.is_some()) << lane);
        let Some(&(idle, _)) = prepared.iter().flatten().next() else {
            hits.fill(None);
            return;
        };
        let mut tree_rays: [Ray; BUNDLE] = std::array::from_fn(|lane| prepared[lane].as_ref().map_or(idle, |p| p.0));
        let watertight: [WatertightRay; BUNDLE] =
            std::array::from_fn(|lane| prepared[lane].as_ref().map_or_else(|| WatertightRay::new(Vec3::ZERO, Vec3::Z), |p| p.1));
        let mut best: [Option<Candidate>; BUNDLE] = [None; BUNDLE];
        walk::<AVX>(nodes, &mut tree_rays, active, |lane, r, base, bits| {
            for_packets(base, bits, |packet, lanes| {
                for (l, t, b1, b2) in self.tris.test(&watertight[lane], packet, lanes, r.tmax).iter() {
                    self.consider(&mut best[lane], &keep, &mut r.tmax, (packet * 4 + l, t, b1, b2));
                }
                false
            });
        });
        for (hit, best) in hits.iter_mut().zip(best) {
            *hit = best.map(|c| self.hit(c));
        }
    }
}

/// Walks `nodes` with `rays[lane]` for the lanes set in `active`, calling `leaf(lane, ray, base,
/// bits)` with the candidate triangles of every node's leaf children that ray enters (slots
/// `base + i` for the set bits i), as `wide::walk` does for one ray; `leaf` may shorten
/// `ray.tmax`. `AVX`: the node test for code compiled with AVX (`accel_avx2.rs`).
#[inline(always)]
pub(super) fn walk<const AVX: bool>(nodes: &[Node], rays: &mut [Ray; BUNDLE], active: u8, mut leaf: impl FnMut(usize, &mut Ray, u32, u32)) {
    if nodes.is_empty() || active == 0 {
        return;
    }
    let slabs: [Slabs; BUNDLE] = std::array::from_fn(|lane| Slabs::new(&rays[lane]));
    let order = octant_inv4(rays[active.trailing_zeros() as usize].direction) & 7;
    let mut stack = [MaybeUninit::<(u32, u8)>::uninit(); STACK];
    let mut len = 0;
    let (mut index, mut lanes) = (0u32, active);
    loop {
        let node = &nodes[index as usize];
        // Byte c of `entering`: the lanes whose rays enter inner child c.
        let mut entering = 0u64;
        for lane in lane_bits(lanes) {
            let (children, leaves) = entered_children::<AVX>(node, &slabs[lane], rays[lane].tmax);
            if leaves != 0 {
                leaf(lane, &mut rays[lane], node.primitive_base, leaves);
            }
            entering |= spread(children & node.imask) << lane;
        }
        // Pushed so that the single walk's first child for the octant is popped first.
        for k in 0..8 {
            let c = k ^ order;
            let byte = (entering >> (8 * c)) as u8;
            if byte != 0 {
                let child = node.child_base + (node.imask & !(u32::MAX << c)).count_ones();
                stack[len] = MaybeUninit::new((child, byte));
                len = (len + 1).min(STACK - 1);
            }
        }
        if len == 0 {
            return;
        }
        len -= 1;
        // SAFETY: slots below the old `len` were written above.
        (index, lanes) = unsafe { stack[len].assume_init() };
    }
}

/// Bit c of `children` moved to bit 8c: the lane-0 bit of byte c.
#[inline(always)]
fn spread(children: u32) -> u64 {
    SPREAD[(children & 0xff) as usize]
}

/// `SPREAD[b]`: bit c of b at bit 8c.
static SPREAD: [u64; 256] = {
    let mut table = [0u64; 256];
    let mut b = 0;
    while b < 256 {
        let mut c = 0;
        while c < 8 {
            if b >> c & 1 != 0 {
                table[b] |= 1 << (8 * c);
            }
            c += 1;
        }
        b += 1;
    }
    table
};

/// The set lanes of `lanes`, lowest first.
#[inline(always)]
fn lane_bits(mut lanes: u8) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (lanes != 0).then(|| {
            let lane = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            lane
        })
    })
}

#[cfg(test)]
#[path = "accel_bundle_tests.rs"]
mod tests;
