//! The wide-BVH node test: obvhs's `CwBvhNode::intersect_ray_simd`, the same arithmetic on the
//! same lanes (so the same hits, bit for bit), with its two costs cut on x86_64:
//! - each node's quantized child planes (u8) became f32 by 24 scalar conversions and inserts
//!   ("the most expensive part", says obvhs); here eight bytes widen to two vectors of four with
//!   SSE2 unpacks and one conversion each;
//! - the hit children were gathered by a branch per child slot (a coin flip per node on
//!   incoherent rays); here only the set bits of the hit mask are visited.
//!
//! Elsewhere obvhs's own test is used.
use glam::Vec3A;
use obvhs::cwbvh::node::CwBvhNode;
use obvhs::ray::Ray;

/// obvhs's node test skips children nearer than this (its private `EPSILON`).
#[cfg(target_arch = "x86_64")]
const NEAREST: f32 = 0.0001;

/// The hit mask obvhs's `intersect_ray` returns: hit inner children in the high byte, the
/// candidate triangles of hit leaf children in the low 24 bits.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub(super) fn hits(node: &CwBvhNode, ray: &Ray, oct_inv4: u32) -> u32 {
    use std::arch::x86_64::*;
    let dir_inv = node.compute_extent() * ray.inv_direction;
    let origin = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    // SAFETY: SSE2 is part of every x86_64 target; the loads read 8 bytes of 8-byte arrays.
    let children = unsafe {
        let zero = _mm_setzero_si128();
        // Children 0–3 and 4–7 of one plane, as f32 (exact: integers below 256).
        let planes = |q: &[u8; 8]| {
            let words = _mm_unpacklo_epi8(_mm_loadl_epi64(q.as_ptr().cast()), zero);
            (_mm_cvtepi32_ps(_mm_unpacklo_epi16(words, zero)), _mm_cvtepi32_ps(_mm_unpackhi_epi16(words, zero)))
        };
        // Entry and exit distances along one axis, near plane first for the ray's direction.
        let axis = |lo: &[u8; 8], hi: &[u8; 8], negative: bool, d: f32, o: f32| {
            let (lo, hi) = (planes(lo), planes(hi));
            let (near, far) = if negative { (hi, lo) } else { (lo, hi) };
            let (d, o) = (_mm_set1_ps(d), _mm_set1_ps(o));
            let t = |q: __m128| _mm_add_ps(_mm_mul_ps(q, d), o);
            ((t(near.0), t(near.1)), (t(far.0), t(far.1)))
        };
        let x = axis(&node.child_min_x, &node.child_max_x, ray.direction.x < 0.0, dir_inv.x, origin.x);
        let y = axis(&node.child_min_y, &node.child_max_y, ray.direction.y < 0.0, dir_inv.y, origin.y);
        let z = axis(&node.child_min_z, &node.child_max_z, ray.direction.z < 0.0, dir_inv.z, origin.z);
        let (nearest, farthest) = (_mm_set1_ps(NEAREST), _mm_set1_ps(ray.tmax));
        let half = |tn: (__m128, __m128, __m128), tf: (__m128, __m128, __m128)| {
            let t_min = _mm_max_ps(_mm_max_ps(tn.0, _mm_max_ps(tn.1, tn.2)), nearest);
            let t_max = _mm_min_ps(_mm_min_ps(tf.0, _mm_min_ps(tf.1, tf.2)), farthest);
            _mm_movemask_ps(_mm_cmple_ps(t_min, t_max)) as u32
        };
        half((x.0.0, y.0.0, z.0.0), (x.1.0, y.1.0, z.1.0)) | half((x.0.1, y.0.1, z.0.1), (x.1.1, y.1.1, z.1.1)) << 4
    };
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    super::packet::set_bits(children).fold(0, |hit_mask, child| {
        let shift = 8 * child;
        hit_mask | ((child_bits8 >> shift) as u32 & 0xff) << ((bit_index8 >> shift) as u32 & 0xff)
    })
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
pub(super) fn hits(node: &CwBvhNode, ray: &Ray, oct_inv4: u32) -> u32 {
    node.intersect_ray(ray, oct_inv4)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::chi2::Rng;
    use obvhs::{BvhBuildParams, cwbvh::builder::build_cwbvh_from_tris, triangle::Triangle};
    use std::time::Duration;

    #[test]
    fn every_node_answers_as_obvhs_own_test() {
        let mut rng = Rng::new(1);
        let mut v = || Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 100.0;
        let tris: Vec<Triangle> = (0..3000)
            .map(|_| {
                let c = v();
                Triangle { v0: c, v1: c + v() * 0.05, v2: c + v() * 0.05 }
            })
            .collect();
        let bvh = build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut Duration::default());
        let (mut tested, mut entered) = (0, 0);
        for k in 0..2000 {
            let o = v() * 1.4 - Vec3A::splat(20.0);
            let d = (v() - Vec3A::splat(50.0)).normalize_or(Vec3A::X);
            let tmax = if k % 2 == 0 { f32::INFINITY } else { 40.0 };
            let ray = Ray::new(o, d, 0.0, tmax);
            let oct = super::super::wide::octant_inv4(d);
            for node in &bvh.nodes {
                let mask = hits(node, &ray, oct);
                assert_eq!(mask, node.intersect_ray(&ray, oct), "ray {k}");
                tested += 1;
                entered += usize::from(mask != 0);
            }
        }
        // Both answers were exercised.
        assert!(tested > 100_000 && entered > 1000 && entered < tested, "{entered} of {tested}");
    }
}
