use super::*;
use crate::tracer::chi2::Rng;
use obvhs::{BvhBuildParams, cwbvh::builder::build_cwbvh_from_tris, triangle::Triangle};
use std::time::Duration;

/// 3000 small random triangles in a 100-unit cube, as obvhs's wide tree.
fn random_tree(rng: &mut Rng) -> obvhs::cwbvh::CwBvh {
    let mut v = || Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 100.0;
    let tris: Vec<Triangle> = (0..3000)
        .map(|_| {
            let c = v();
            Triangle { v0: c, v1: c + v() * 0.05, v2: c + v() * 0.05 }
        })
        .collect();
    build_cwbvh_from_tris(&tris, BvhBuildParams::medium_build(), &mut Duration::default())
}

/// Whether `ray` enters the box (lo, hi) on [NEAREST, tmax], in f64 from the f32 inputs.
fn enters(ray: &Ray, lo: Vec3A, hi: Vec3A) -> bool {
    let (mut t0, mut t1) = (f64::from(NEAREST), f64::from(ray.tmax));
    for a in 0..3 {
        let (o, d) = (f64::from(ray.origin[a]), f64::from(ray.direction[a]));
        let (l, h) = (f64::from(lo[a]), f64::from(hi[a]));
        if d == 0.0 {
            if o < l || o > h {
                return false;
            }
            continue;
        }
        let (a0, a1) = ((l - o) / d, (h - o) / d);
        t0 = t0.max(a0.min(a1));
        t1 = t1.min(a0.max(a1));
    }
    t0 <= t1
}

#[test]
fn decoded_boxes_enclose_the_quantized_ones_by_at_most_an_ulp() {
    let bvh = random_tree(&mut Rng::new(3));
    for node in &bvh.nodes {
        let boxes = ChildBoxes::decode(node);
        let e = node.compute_extent();
        for child in 0..8 {
            let (lo, hi) = boxes.child(child);
            let q_lo = Vec3A::new(node.child_min_x[child] as f32, node.child_min_y[child] as f32, node.child_min_z[child] as f32);
            let q_hi = Vec3A::new(node.child_max_x[child] as f32, node.child_max_y[child] as f32, node.child_max_z[child] as f32);
            for a in 0..3 {
                let exact_lo = f64::from(node.p[a]) + f64::from(q_lo[a]) * f64::from(e[a]);
                let exact_hi = f64::from(node.p[a]) + f64::from(q_hi[a]) * f64::from(e[a]);
                assert!(f64::from(lo[a]) <= exact_lo && f64::from(lo[a].next_up()) > exact_lo, "low plane {a} of child {child}");
                assert!(f64::from(hi[a]) >= exact_hi && f64::from(hi[a].next_down()) < exact_hi, "high plane {a} of child {child}");
            }
        }
    }
}

/// The test never culls a child box the ray enters (exact test in f64 on the decoded box), and
/// answers as obvhs's own test on the quantized boxes for rays with no zero component.
#[test]
fn every_entered_child_is_kept_and_answers_match_obvhs() {
    let mut rng = Rng::new(1);
    let bvh = random_tree(&mut rng);
    let boxes: Vec<ChildBoxes> = bvh.nodes.iter().map(ChildBoxes::decode).collect();
    let (mut tested, mut entered, mut differ) = (0, 0, 0);
    for k in 0..2000 {
        let o = Vec3A::new(rng.f32(), rng.f32(), rng.f32()) * 140.0 - Vec3A::splat(20.0);
        let d = (Vec3A::new(rng.f32(), rng.f32(), rng.f32()) - Vec3A::splat(0.5)).normalize_or(Vec3A::X);
        // Every fourth ray along an axis, with zeros of both signs in the other components.
        let d = if k % 4 == 3 { Vec3A::new(-0.0, 0.0, d.z.signum()) } else { d };
        let tmax = if k % 2 == 0 { f32::INFINITY } else { 40.0 };
        let mut ray = Ray::new(o, d, 0.0, tmax);
        ray.inv_direction = Vec3A::ONE / d;
        ray.inv_direction = Vec3A::select(ray.inv_direction.is_finite_mask(), ray.inv_direction, Vec3A::splat(f32::MAX).copysign(ray.inv_direction));
        let oct = super::super::wide::octant_inv4(d);
        let slabs = Slabs::new(&ray);
        for (node, b) in bvh.nodes.iter().zip(&boxes) {
            let mask = hits(node, b, &slabs, &ray, oct);
            let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct);
            for child in 0..8 {
                let bits = ((child_bits8 >> (8 * child)) as u32 & 0xff) << ((bit_index8 >> (8 * child)) as u32 & 0xff);
                if bits == 0 {
                    continue; // an empty slot
                }
                let (lo, hi) = b.child(child);
                let kept = mask & bits == bits;
                assert!(kept || !enters(&ray, lo, hi), "ray {k}: child {child} culled though entered");
                tested += 1;
                entered += usize::from(kept);
            }
            // obvhs's grid transform makes 0·∞ = NaN on rays with zero components, and then
            // culls boxes they enter (709 children in this run): compared on the others only.
            if k % 4 != 3 {
                differ += usize::from(mask != node.intersect_ray(&ray, oct));
            }
        }
    }
    // Both answers were exercised, and obvhs agrees but for rounding at box faces.
    assert!(tested > 100_000 && entered > 1000 && entered < tested, "{entered} of {tested}");
    assert!(differ * 1000 < tested, "{differ} node answers differ from obvhs's in {tested} children");
}
