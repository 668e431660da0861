//! The node test of `super` (node/mod.rs) on all eight children at once, in 256-bit AVX registers.
//! Each lane does what a lane of the 128-bit test does, operand for operand (the same `min` and
//! `max` operand order, which decides what a NaN gives), so both tests cull the same boxes.
//!
//! Why `#[inline(always)]` and not `#[target_feature(enable = "avx")]`: a function with a target
//! feature was not inlined into the AVX2 walk (a call per node, measured), while this body,
//! inlined through the generic walk into `accel/avx2.rs`'s `#[target_feature]` functions, is
//! compiled there with their features, and its intrinsics inlined with it.
use super::{FAR_SCALE, NEAREST, Node, Slabs};
use std::arch::x86_64::*;

/// (entered children, bit c for child c; the sum of their leaf bits) for the ray of `slabs`.
///
/// # Safety
/// The CPU must have AVX, and the caller must be compiled with it.
#[inline(always)]
pub(super) unsafe fn entered(node: &Node, slabs: &Slabs, t_max: f32) -> (u32, u32) {
    // SAFETY (the loads): `Node` is 64-byte aligned, and each row and `leaf_bits` is eight f32
    // at a multiple of 32 bytes; the intrinsics need AVX, which the caller guarantees.
    unsafe {
        let row = |r: usize| _mm256_load_ps(node.rows[r].as_ptr().cast::<f32>());
        let distance = |axis: usize, r: usize| {
            _mm256_mul_ps(
                _mm256_sub_ps(row(r), _mm256_set1_ps(slabs.origin[axis].x)),
                _mm256_set1_ps(slabs.inv[axis].x),
            )
        };
        let ([near_x, near_y, near_z], [far_x, far_y, far_z]) = (slabs.near, slabs.far);
        let (nx, ny, nz) = (distance(0, near_x), distance(1, near_y), distance(2, near_z));
        let (fx, fy, fz) = (distance(0, far_x), distance(1, far_y), distance(2, far_z));
        let t_min =
            _mm256_max_ps(_mm256_max_ps(nx, ny), _mm256_max_ps(nz, _mm256_set1_ps(NEAREST)));
        let t_far =
            _mm256_mul_ps(_mm256_min_ps(_mm256_min_ps(fx, fy), fz), _mm256_set1_ps(FAR_SCALE));
        let mask = _mm256_cmp_ps::<_CMP_LE_OS>(t_min, _mm256_min_ps(t_far, _mm256_set1_ps(t_max)));
        let leaf = _mm256_and_ps(mask, _mm256_load_ps(node.leaf_bits.as_ptr().cast::<f32>()));
        // Disjoint integers below 2²⁴: every partial sum is exact, in any order.
        let four = _mm_add_ps(_mm256_castps256_ps128(leaf), _mm256_extractf128_ps::<1>(leaf));
        let two = _mm_add_ps(four, _mm_movehl_ps(four, four));
        let one = _mm_add_ss(two, _mm_shuffle_ps::<0b01>(two, two));
        (_mm256_movemask_ps(mask) as u32, _mm_cvtss_f32(one) as u32)
    }
}
