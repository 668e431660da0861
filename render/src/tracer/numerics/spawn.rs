//! Cases 1, 3 and 4: rays leaving a surface, tiny gaps, near-axis rays.
use super::{log_uniform, unit_vector};
use crate::tracer::accel::{Accel, BvhKind, Hit, brute_force, triangle_normal};
use crate::tracer::chi2::Rng;
use crate::tracer::ray::{ErrPoint, Ray, SHADOW_EPSILON};
use glam::Vec3;

/// A random triangle: centre at distance 10^[−8, 8] from the origin, size 10^[−3, 0] of that
/// distance (so vertex coordinates range over 1e-8 … 1e8, and far triangles are small
/// relative to their coordinates, where rounding is worst).
fn random_triangle(rng: &mut Rng) -> [Vec3; 3] {
    let reach = log_uniform(rng, -8.0, 8.0);
    let centre = unit_vector(rng) * reach;
    let size = reach * log_uniform(rng, -3.0, 0.0);
    [0, 1, 2].map(|_| centre + unit_vector(rng) * size)
}

/// A hit on `tri` found by the BVH, with the hit point and its error bound as the integrator
/// builds them (barycentrics from the watertight test).
fn hit_point(accel: &Accel, tri: &[Vec3; 3], rng: &mut Rng) -> Option<(ErrPoint, Vec3)> {
    let n = triangle_normal(tri)?.as_vec3();
    let (b1, b2) = (0.05 + 0.6 * rng.f32(), 0.05 + 0.3 * rng.f32());
    let target = tri[0] * (1.0 - b1 - b2) + tri[1] * b1 + tri[2] * b2;
    let size = (tri[1] - tri[0]).length();
    let from = target + (n + unit_vector(rng) * 0.5) * size;
    let Hit { b1, b2, .. } = accel.intersect(&Ray::new(from, target - from), f32::INFINITY)?;
    Some((ErrPoint::from_barycentric(tri, 1.0 - b1 - b2, b1, b2), n))
}

/// Case 1. Catches a fixed-epsilon offset (a 1e-4 push along the normal re-hits the source
/// triangle about half the time once coordinates pass ~1e3, where the f32 spacing is larger).
#[test]
fn spawned_and_shadow_rays_never_rehit_their_triangle_from_1e_minus8_to_1e8() {
    let mut rng = Rng::new(101);
    let (mut hits, mut rays) = (0, 0);
    for _ in 0..100 {
        let tri = random_triangle(&mut rng);
        let accel = Accel::build(&[tri], BvhKind::Wide);
        let Some((p, n)) = hit_point(&accel, &tri, &mut rng) else { continue };
        hits += 1;
        let size = (tri[1] - tri[0]).length();
        for _ in 0..1000 {
            let w = unit_vector(&mut rng);
            let spawned = p.spawn(n, w);
            assert!(
                accel.intersect(&spawned, f32::INFINITY).is_none(),
                "{tri:?}: ray from {p:?} along {w} re-hit"
            );
            // A shadow ray to a point clearly on w's side (well above the plane's rounding).
            let to = p.p + w * size * log_uniform(&mut rng, -1.0, 2.0);
            let height =
                n.as_dvec3().dot(to.as_dvec3() - p.p.as_dvec3()) * (w.dot(n).signum() as f64);
            if height <= 1e-3 * size as f64 {
                continue;
            }
            let shadow = p.spawn_to(n, &ErrPoint::exact(to), Vec3::ZERO);
            assert!(
                !accel.occluded(&shadow, 1.0 - SHADOW_EPSILON),
                "{tri:?}: shadow ray from {p:?} to {to} re-hit"
            );
            rays += 1;
        }
    }
    assert!(hits >= 95 && rays > 50_000, "too few checks: {hits} hits, {rays} shadow rays");
}

/// Case 3. A scene 1e-3 across whose occluder floats 5e-5 above the receiver: rays leaving
/// the receiver find the occluder first, at the right distance, and shadow rays to a light
/// above it are blocked, in both trees. Catches building the tree in world units (obvhs's
/// wide BVH skips boxes closer than an absolute 1e-4).
#[test]
fn tiny_gaps_block_shadow_rays_and_keep_nearest_hits_in_both_trees() {
    let (s, gap) = (1e-3f32, 5e-5f32);
    let square = |z: f32, half: f32| {
        let c = |x: f32, y: f32| Vec3::new(x * half, y * half, z);
        [[c(-1.0, -1.0), c(1.0, -1.0), c(1.0, 1.0)], [c(-1.0, -1.0), c(1.0, 1.0), c(-1.0, 1.0)]]
    };
    let tris: Vec<[Vec3; 3]> = [square(0.0, s / 2.0), square(gap, 3.0 * s)].concat();
    let mut rng = Rng::new(103);
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let accel = Accel::build(&tris, kind);
        for _ in 0..2000 {
            let (b1, b2) = (0.3 * rng.f32(), 0.3 * rng.f32());
            let p = ErrPoint::from_barycentric(&tris[0], 1.0 - b1 - b2, b1, b2);
            // Up to ~80° from the normal the occluder (3e-3 wide) covers the ray.
            let mut w = unit_vector(&mut rng);
            w.z = w.z.abs().max(0.2);
            let w = w.normalize();
            let hit = accel.intersect(&p.spawn(Vec3::Z, w), f32::INFINITY);
            let hit = hit.unwrap_or_else(|| {
                panic!("{kind:?}: ray from {p:?} along {w} missed the occluder")
            });
            assert!(hit.prim >= 2, "{kind:?}: nearest hit is the receiver itself ({hit:?})");
            let expected = (gap - p.p.z) / w.z;
            assert!(
                (hit.t - expected).abs() <= 1e-3 * expected,
                "{kind:?}: t {} vs {expected}",
                hit.t
            );
            let light = ErrPoint::exact(p.p + Vec3::new(0.0, 0.0, s));
            assert!(
                accel.occluded(&p.spawn_to(Vec3::Z, &light, Vec3::ZERO), 1.0 - SHADOW_EPSILON),
                "{kind:?}"
            );
        }
    }
}

/// Case 4. Slivers 1e-3 wide at 1e4 along each axis, hit by rays whose minor direction
/// components are 0, ±1e-9 and ±1e-7: the BVH finds exactly what a loop over all triangles
/// finds. Catches obvhs's `Ray::new`, which clamps 1/d for |d| < ~1.2e-7 and then misses.
#[test]
fn axis_parallel_rays_match_brute_force_on_thin_far_slivers() {
    let mut tris = Vec::new();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            for k in 0..4 {
                // Slivers at depths 1e4 + k, offset across the ray by k·4e-4.
                let at = |major: f32, a: f32, b: f32| {
                    let mut v = Vec3::ZERO;
                    v[axis] = major;
                    v[(axis + 1) % 3] = a;
                    v[(axis + 2) % 3] = b;
                    v
                };
                let (d, o) = (sign * (1e4 + k as f32), k as f32 * 4e-4);
                tris.push([at(d, o - 5e-4, -1.0), at(d, o + 5e-4, -1.0), at(d, o, 1.0)]);
            }
        }
    }
    let smalls = [0.0f32, 1e-9, -1e-9, 1e-7, -1e-7];
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let accel = Accel::build(&tris, kind);
        let mut found = 0;
        for axis in 0..3 {
            for sign in [-1.0f32, 1.0] {
                for (da, db) in smalls.iter().flat_map(|&a| smalls.map(|b| (a, b))) {
                    for offset in [-2e-4f32, 0.0, 3e-4, 8e-4, 1.3e-3] {
                        let mut dir = Vec3::ZERO;
                        dir[axis] = sign;
                        dir[(axis + 1) % 3] = da;
                        dir[(axis + 2) % 3] = db;
                        let mut origin = Vec3::ZERO;
                        origin[(axis + 1) % 3] = offset;
                        let ray = Ray::new(origin, dir);
                        let expected = brute_force(&tris, &ray);
                        let got = accel.intersect(&ray, f32::INFINITY).map(|h| (h.t, h.prim));
                        assert_eq!(got.map(|g| g.1), expected.map(|e| e.1), "{kind:?}: {ray:?}");
                        assert_eq!(
                            accel.occluded(&ray, f32::INFINITY),
                            expected.is_some(),
                            "{kind:?}: {ray:?}"
                        );
                        found += expected.is_some() as u32;
                    }
                }
            }
        }
        assert!(
            found > 300,
            "the rays must hit the slivers often enough to mean something ({found})"
        );
    }
}
