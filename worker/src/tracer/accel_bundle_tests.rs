use super::super::tests::{Rng, grid, triangle_soup};
use super::*;
use crate::tracer::accel::BvhKind;

/// Each ray of each bundle finds, bit for bit, what `intersect_where` finds for it alone.
fn assert_bundles_match(accel: &Accel, bundles: &[Vec<SceneRay>], t_max: f32, keep: impl Fn(u32, f32, f32) -> bool + Copy) -> usize {
    let mut hits = 0;
    for (b, rays) in bundles.iter().enumerate() {
        let mut found = vec![None; rays.len()];
        accel.intersect_bundle_where(rays, t_max, keep, &mut found);
        for (lane, ray) in rays.iter().enumerate() {
            assert_eq!(found[lane], accel.intersect_where(ray, t_max, keep), "bundle {b}, lane {lane}: {ray:?}, t_max {t_max}");
            hits += usize::from(found[lane].is_some());
        }
    }
    hits
}

/// Bundles of 1 to 8 rays: from one point through a small cone (a pixel's camera rays), or
/// from anywhere in any direction (rays that share no box).
fn bundles(rng: &mut Rng, count: usize, coherent: bool) -> Vec<Vec<SceneRay>> {
    (0..count)
        .map(|k| {
            let (origin, aim) = (rng.vec() * 14.0 - Vec3::splat(2.0), (rng.vec() - Vec3::splat(0.5)).normalize_or(Vec3::X));
            (0..=k % BUNDLE)
                .map(|_| match coherent {
                    true => SceneRay::new(origin, aim + (rng.vec() - Vec3::splat(0.5)) * 0.01),
                    false => SceneRay::new(rng.vec() * 14.0 - Vec3::splat(2.0), (rng.vec() - Vec3::splat(0.5)).normalize_or(Vec3::X)),
                })
                .collect()
        })
        .collect()
}

#[test]
fn every_ray_of_a_bundle_finds_what_it_finds_alone() {
    let tris = triangle_soup(&mut Rng(31), 4000);
    let mut rng = Rng(32);
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let accel = Accel::build(&tris, kind);
        for coherent in [true, false] {
            let bundles = bundles(&mut rng, 2000, coherent);
            let all = bundles.iter().map(Vec::len).sum::<usize>();
            let hits = assert_bundles_match(&accel, &bundles, f32::INFINITY, |_, _, _| true);
            assert!(hits > all / 10 && hits < all * 9 / 10, "{kind:?}, coherent {coherent}: {hits} of {all} rays hit");
            assert_bundles_match(&accel, &bundles, 3.0, |_, _, _| true);
        }
    }
}

#[test]
fn a_filter_and_the_baseline_node_test_give_each_ray_its_own_hit() {
    let tris = triangle_soup(&mut Rng(33), 4000);
    let mut accel = Accel::build(&tris, BvhKind::Wide);
    let bundles = bundles(&mut Rng(34), 1000, true);
    // An any-hit filter (as alpha masks are): rejected hits must not shorten the ray.
    let odd_only = |prim: u32, _: f32, _: f32| prim % 2 == 1;
    assert_bundles_match(&accel, &bundles, f32::INFINITY, odd_only);
    accel.avx2 = false;
    assert_bundles_match(&accel, &bundles, f32::INFINITY, odd_only);
    assert_bundles_match(&accel, &bundles, f32::INFINITY, |_, _, _| true);
}

#[test]
fn rays_of_a_bundle_through_shared_edges_take_the_single_rays_triangle() {
    let accel = Accel::build(&grid(8), BvhKind::Wide);
    let origin = Vec3::new(0.3, -0.7, 2.0);
    // Eight rays aimed at grid vertices and edge midpoints: ties the smaller index must win.
    let targets: Vec<Vec3> = (1..16).flat_map(|i| (1..16).map(move |j| Vec3::new(i as f32 / 16.0, j as f32 / 16.0, 0.0))).collect();
    let bundles: Vec<Vec<SceneRay>> = targets.chunks(BUNDLE).map(|c| c.iter().map(|&t| SceneRay::new(origin, t - origin)).collect()).collect();
    let all = bundles.iter().map(Vec::len).sum::<usize>();
    assert_eq!(assert_bundles_match(&accel, &bundles, f32::INFINITY, |_, _, _| true), all, "every ray hits the grid");
}

#[test]
fn rays_that_cannot_be_traced_and_empty_trees_find_nothing() {
    let accel = Accel::build(&triangle_soup(&mut Rng(35), 100), BvhKind::Wide);
    let inside = SceneRay::new(Vec3::splat(5.0), Vec3::X);
    let rays = [SceneRay::new(Vec3::splat(5.0), Vec3::ZERO), inside, SceneRay::new(Vec3::NAN, Vec3::X), inside];
    assert_bundles_match(&accel, &[rays.to_vec()], f32::INFINITY, |_, _, _| true);
    let none = [SceneRay::new(Vec3::ZERO, Vec3::ZERO); 3];
    let mut found = [Some(Hit { t: 1.0, prim: 0, b1: 0.0, b2: 0.0 }); 3];
    accel.intersect_bundle_where(&none, f32::INFINITY, |_, _, _| true, &mut found);
    assert_eq!(found, [None; 3]);
    let empty = Accel::build(&[], BvhKind::Wide);
    let mut four = [Some(Hit { t: 1.0, prim: 0, b1: 0.0, b2: 0.0 }); 4];
    empty.intersect_bundle_where(&rays, f32::INFINITY, |_, _, _| true, &mut four);
    assert_eq!(four, [None; 4]);
}
