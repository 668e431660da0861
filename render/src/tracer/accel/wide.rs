//! The walk of obvhs's wide BVH, as its `ray_traverse` and `ray_traverse_miss` do (the steps of
//! its `traverse!` macro, its node test), with two differences:
//! - a node's candidate triangles go to the caller together, to be tested four at a time
//!   (`packet.rs`), not one by one;
//! - the traversal stack is not zeroed for every ray. obvhs builds a fresh 32-entry stack of
//!   `UVec2` per query, a 256-byte `memset` that cost ≈ 1.8 % of a Cornell box render (perf,
//!   2026-12-01).
//!
//! Depth: [`super::Accel`] only builds a wide tree shallower than [`STACK`] (see `wide_depth`),
//! so the stack never fills; were it to, pushes saturate as obvhs's do (no overflow).
use super::node::{Node, Slabs};
use super::stats::Tally;
use glam::{UVec2, Vec3A};
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
    oct_inv4: u32,
}

impl State {
    #[inline(always)]
    fn new(nodes: &[Node], dir: Vec3A) -> State {
        let root = if nodes.is_empty() { UVec2::ZERO } else { UVec2::new(0, 0x8000_0000) };
        State {
            stack: Stack::new(),
            current_group: root,
            primitive_group: UVec2::ZERO,
            oct_inv4: octant_inv4(dir),
        }
    }
}

/// The ray's octant as obvhs's node test wants it (its `ray_get_octant_inv4`, private there).
#[inline(always)]
pub(super) fn octant_inv4(dir: Vec3A) -> u32 {
    (if dir.x < 0.0 { 0 } else { 0x0404_0404 })
        | (if dir.y < 0.0 { 0 } else { 0x0202_0202 })
        | (if dir.z < 0.0 { 0 } else { 0x0101_0101 })
}

/// Walks the tree along `ray`, handing `leaf(ray, base, bits, tally)` the candidate triangles of
/// each node at once (slots `base + i` for the set bits i: every triangle of the node's leaf
/// children the ray enters) instead of one at a time as obvhs's `traverse!` does, so they can be
/// tested four to a packet. `leaf` may shorten `ray.tmax` (closest hit: later boxes are culled
/// against it) and returns true to stop the walk (any hit). Otherwise the steps of `traverse!`.
/// Each step is reported to `tally` (`()` for the tracer's queries: no code). `AVX`: the node
/// test for code compiled with AVX (`accel/avx2.rs`).
#[inline(always)]
pub(super) fn walk<const AVX: bool, T: Tally>(
    nodes: &[Node],
    mut ray: Ray,
    tally: &mut T,
    mut leaf: impl FnMut(&mut Ray, u32, u32, &mut T) -> bool,
) {
    tally.ray();
    let mut state = State::new(nodes, ray.direction);
    let slabs = Slabs::new(&ray);
    loop {
        if state.primitive_group.y != 0 {
            if leaf(&mut ray, state.primitive_group.x, state.primitive_group.y, tally) {
                return;
            }
            state.primitive_group = UVec2::ZERO;
        }
        if state.current_group.y & 0xff00_0000 != 0 {
            let hits_imask = state.current_group.y;
            let child_index_offset = obvhs::cwbvh::firstbithigh(hits_imask);
            state.current_group.y &= !(1u32 << child_index_offset);
            if state.current_group.y & 0xff00_0000 != 0 {
                state.stack.push(state.current_group);
            }
            let slot_index = (child_index_offset - 24) ^ (state.oct_inv4 & 0xff);
            let relative_index = (hits_imask & !(0xffff_ffffu32 << slot_index)).count_ones();
            let index = (state.current_group.x + relative_index) as usize;
            let node = &nodes[index];
            tally.node();
            let hitmask = super::node::hits::<AVX>(node, &slabs, &ray, state.oct_inv4);
            state.current_group = UVec2::new(node.child_base, (hitmask & 0xff00_0000) | node.imask);
            state.primitive_group = UVec2::new(node.primitive_base, hitmask & 0x00ff_ffff);
        } else {
            state.current_group = UVec2::ZERO;
        }
        if state.primitive_group.y == 0 && state.current_group.y & 0xff00_0000 == 0 {
            match state.stack.pop() {
                Some(group) => state.current_group = group,
                None => return,
            }
        }
    }
}
