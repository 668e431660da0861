//! Closest-hit and any-hit walks of obvhs's wide BVH, as its `ray_traverse` and
//! `ray_traverse_miss` do (its `traverse!` macro, its node test), with one difference: the
//! traversal stack is not zeroed for every ray. obvhs builds a fresh 32-entry stack of `UVec2`
//! per query, a 256-byte `memset` that cost ≈ 1.8 % of a Cornell box render (perf, 2026-12-01).
//!
//! Depth: [`super::Accel`] only builds a wide tree shallower than [`STACK`] (see `wide_depth`),
//! so the stack never fills; were it to, pushes saturate as obvhs's do (no overflow).
use glam::{UVec2, Vec3A};
use obvhs::cwbvh::CwBvh;
use obvhs::faststack::FastStack;
use obvhs::ray::Ray;
use std::mem::MaybeUninit;

/// obvhs's `TRAVERSAL_STACK_SIZE` (private there).
pub(super) const STACK: usize = 32;

/// A traversal stack whose slots are written before they are read, so they need no zeroing.
struct Stack {
    slots: [MaybeUninit<UVec2>; STACK],
    /// Slots `0..len` are initialised.
    len: usize,
}

impl Stack {
    #[inline(always)]
    fn new() -> Stack {
        Stack { slots: [const { MaybeUninit::uninit() }; STACK], len: 0 }
    }
}

impl FastStack<UVec2> for Stack {
    #[inline(always)]
    fn push(&mut self, v: UVec2) {
        self.slots[self.len] = MaybeUninit::new(v);
        self.len = (self.len + 1).min(STACK - 1);
    }
    #[inline(always)]
    fn pop_fast(&mut self) -> UVec2 {
        self.pop().unwrap_or(UVec2::ZERO)
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<UVec2> {
        self.len = self.len.checked_sub(1)?;
        // SAFETY: slots below the old `len` were written by `push` (the invariant of `len`).
        Some(unsafe { self.slots[self.len].assume_init() })
    }
    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.len == 0
    }
    #[inline(always)]
    fn clear(&mut self) {
        self.len = 0;
    }
}

/// The fields obvhs's `traverse!` macro reads and writes.
struct State {
    stack: Stack,
    current_group: UVec2,
    primitive_group: UVec2,
    primitive_id: u32,
    hitmask: u32,
    oct_inv4: u32,
}

impl State {
    #[inline(always)]
    fn new(bvh: &CwBvh, dir: Vec3A) -> State {
        let root = if bvh.nodes.is_empty() { UVec2::ZERO } else { UVec2::new(0, 0x8000_0000) };
        State { stack: Stack::new(), current_group: root, primitive_group: UVec2::ZERO, primitive_id: 0, hitmask: 0, oct_inv4: octant_inv4(dir) }
    }
}

/// The ray's octant as obvhs's node test wants it (its `ray_get_octant_inv4`, private there).
#[inline(always)]
fn octant_inv4(dir: Vec3A) -> u32 {
    (if dir.x < 0.0 { 0 } else { 0x0404_0404 }) | (if dir.y < 0.0 { 0 } else { 0x0202_0202 }) | (if dir.z < 0.0 { 0 } else { 0x0101_0101 })
}

/// Closest hit: `hit(ray, slot)` returns a candidate's t (∞ for none); the ray shortens to each
/// t below its tmax. The last such t, if any.
#[inline(always)]
pub(super) fn closest(bvh: &CwBvh, ray: Ray, mut hit: impl FnMut(&Ray, usize) -> f32) -> Option<f32> {
    let mut walk = ray;
    let mut state = State::new(bvh, ray.direction);
    let mut node;
    obvhs::traverse!(bvh, node, state, node.intersect_ray(&walk, state.oct_inv4), {
        let t = hit(&walk, state.primitive_id as usize);
        if t < walk.tmax {
            walk.tmax = t;
        }
    });
    (walk.tmax < ray.tmax).then_some(walk.tmax)
}

/// Any hit: true when `hit(ray, slot)` returns a t below tmax for some candidate.
#[inline(always)]
pub(super) fn any(bvh: &CwBvh, ray: Ray, mut hit: impl FnMut(&Ray, usize) -> f32) -> bool {
    let mut state = State::new(bvh, ray.direction);
    let mut node;
    let mut found = false;
    'walk: {
        obvhs::traverse!(bvh, node, state, node.intersect_ray(&ray, state.oct_inv4), {
            if hit(&ray, state.primitive_id as usize) < ray.tmax {
                found = true;
                break 'walk;
            }
        });
    }
    found
}
