use super::*;

/// A deterministic stream for tests (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
    fn vec(&mut self) -> Vec3 {
        Vec3::new(self.next(), self.next(), self.next())
    }
}

/// `n` random triangles of size ≈ 1 in a 10-unit cube.
fn triangle_soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.vec() * 10.0;
            [c + rng.vec() - 0.5, c + rng.vec() - 0.5, c + rng.vec() - 0.5]
        })
        .collect()
}

/// A unit square in z = 0 split into an n×n grid of quads, two triangles each.
fn grid(n: usize) -> Vec<[Vec3; 3]> {
    let mut tris = Vec::new();
    let s = 1.0 / n as f32;
    for i in 0..n {
        for j in 0..n {
            let p = |a: usize, b: usize| Vec3::new(a as f32 * s, b as f32 * s, 0.0);
            tris.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            tris.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    tris
}

#[test]
fn rays_through_shared_edges_and_vertices_never_leak() {
    let tris = grid(8);
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let accel = Accel::build(&tris, kind);
        // Aim exactly at grid vertices and edge midpoints, from oblique origins.
        for i in 0..=16 {
            for j in 0..=16 {
                let target = Vec3::new(i as f32 / 16.0, j as f32 / 16.0, 0.0);
                if target.x >= 1.0 || target.y >= 1.0 || target.x <= 0.0 || target.y <= 0.0 {
                    continue;
                }
                let origin = Vec3::new(0.3, -0.7, 2.0);
                let ray = Ray::new(origin, target - origin);
                let hit = accel.intersect(&ray, f32::INFINITY);
                assert!(hit.is_some(), "{kind:?}: ray to interior point {target} leaked through");
            }
        }
    }
}

#[test]
fn both_trees_agree_with_brute_force_on_random_rays() {
    let mut rng = Rng(7);
    let tris = triangle_soup(&mut rng, 500);
    let wide = Accel::build(&tris, BvhKind::Wide);
    let binary = Accel::build(&tris, BvhKind::Binary);
    let mut hits = 0;
    for _ in 0..2000 {
        let ray = Ray::new(rng.vec() * 10.0, rng.vec() * 2.0 - 1.0);
        let expected = brute_force(&tris, &ray);
        for accel in [&wide, &binary] {
            let got = accel.intersect(&ray, f32::INFINITY).map(|h| (h.t, h.prim));
            assert_eq!(got.map(|g| g.1), expected.map(|e| e.1), "ray {ray:?}");
            if let (Some(g), Some(e)) = (got, expected) {
                assert!((g.0 - e.0).abs() <= 1e-5 * e.0, "t {} vs {}", g.0, e.0);
            }
            assert_eq!(accel.occluded(&ray, f32::INFINITY), expected.is_some());
        }
        hits += expected.is_some() as u32;
    }
    assert!(hits > 200, "test rays should hit often enough to mean something ({hits})");
}

#[test]
fn barycentrics_reconstruct_the_hit_point() {
    let tri = [Vec3::new(-1.0, -1.0, 3.0), Vec3::new(2.0, -1.0, 3.0), Vec3::new(0.0, 2.0, 3.0)];
    let accel = Accel::build(&[tri], BvhKind::Wide);
    let ray = Ray::new(Vec3::new(0.1, 0.2, 0.0), Vec3::Z);
    let hit = accel.intersect(&ray, f32::INFINITY).expect("hit");
    let p = tri[0] * (1.0 - hit.b1 - hit.b2) + tri[1] * hit.b1 + tri[2] * hit.b2;
    assert!((p - ray.at(hit.t)).length() < 1e-5, "{p} vs {}", ray.at(hit.t));
    assert!((hit.t - 3.0).abs() < 1e-6);
    assert!(accel.intersect(&ray, 2.9).is_none(), "t_max must bound the search");
}

#[test]
fn axis_parallel_rays_hit_thin_far_geometry() {
    // A sliver 1e-3 wide, 1e4 away along x; rays with tiny y/z direction components.
    let tris =
        vec![[Vec3::new(1e4, -1e-3, -1.0), Vec3::new(1e4, 1e-3, -1.0), Vec3::new(1e4, 0.0, 1.0)]];
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let accel = Accel::build(&tris, kind);
        for dy in [0.0, 1e-9, -1e-9, 1e-8, -1e-8] {
            let ray = Ray::new(Vec3::ZERO, Vec3::new(1.0, dy, 0.0));
            assert_eq!(
                accel.intersect(&ray, f32::INFINITY).is_some(),
                brute_force(&tris, &ray).is_some()
            );
            assert!(accel.intersect(&ray, f32::INFINITY).is_some(), "{kind:?} dy={dy}");
        }
    }
}

#[test]
fn tiny_scenes_find_hits_closer_than_obvhs_epsilon() {
    // Scene 1e-3 across: the occluder is 5e-5 above the receiver, below obvhs's fixed 1e-4.
    let s = 1e-3;
    let receiver = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(s, 0.0, 0.0), Vec3::new(0.0, s, 0.0)];
    let occluder = [Vec3::new(0.0, 0.0, 5e-5), Vec3::new(s, 0.0, 5e-5), Vec3::new(0.0, s, 5e-5)];
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let accel = Accel::build(&[receiver, occluder], kind);
        let ray = Ray::new(Vec3::new(2e-4, 2e-4, 1e-6), Vec3::Z);
        let hit = accel.intersect(&ray, f32::INFINITY).expect("occluder");
        assert_eq!(hit.prim, 1);
        assert!(accel.occluded(&ray, 1.0));
    }
}

/// Random triangles: the first `n` in a unit cube, each about 0.1 across.
fn soup(rng: &mut Rng, n: usize) -> Vec<[Vec3; 3]> {
    (0..n)
        .map(|_| {
            let c = rng.vec();
            [c, c + rng.vec() * 0.1, c + rng.vec() * 0.1]
        })
        .collect()
}

/// Hits of `rays` random rays, compared bit for bit between a refitted and a rebuilt tree.
fn assert_same_hits(a: &Accel, b: &Accel, rng: &mut Rng, rays: usize, what: &str) {
    for k in 0..rays {
        let o = rng.vec() * 3.0 - Vec3::splat(1.0);
        let d = (rng.vec() - Vec3::splat(0.5)).normalize_or(Vec3::X);
        let ray = Ray::new(o, d);
        assert_eq!(
            a.intersect(&ray, f32::INFINITY),
            b.intersect(&ray, f32::INFINITY),
            "{what}: ray {k}"
        );
        assert_eq!(a.occluded(&ray, 1.0), b.occluded(&ray, 1.0), "{what}: ray {k}");
    }
}

#[test]
fn a_refitted_tree_gives_the_hits_of_a_rebuilt_one() {
    let mut rng = Rng(17);
    let tris = soup(&mut rng, 3000);
    // Move the triangles a lot: rotate half of them, translate and scale the scene (the tree
    // space scale changes too), so the old topology fits the new geometry badly.
    let moved: Vec<[Vec3; 3]> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| {
            let m =
                if i % 2 == 0 { glam::Mat3::from_rotation_y(1.3) } else { glam::Mat3::IDENTITY };
            t.map(|v| m * v * 2.5 + Vec3::new(0.3, -0.2, 0.1))
        })
        .collect();
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let first = Accel::build_refittable(&tris, kind);
        let refit = first.refit(&moved).expect("same triangle set: refit");
        let rebuilt = Accel::build(&moved, kind);
        assert_same_hits(&refit, &rebuilt, &mut rng, 20_000, &format!("{kind:?}"));
        // A refit of a refit still works, back to the start.
        let back = refit.refit(&tris).expect("refit again");
        assert_same_hits(
            &back,
            &Accel::build(&tris, kind),
            &mut rng,
            5000,
            &format!("{kind:?} back"),
        );
        // Refitted back onto the triangles it was built for, a wide tree is the built one.
        if let (Tree::Wide(built), Tree::Wide(again)) = (&first.tree, &back.tree) {
            assert_eq!(built, again, "refitted back: the built tree's nodes");
            assert_eq!(first.prim_ids, back.prim_ids);
        } else {
            assert_eq!(kind, BvhKind::Binary, "the soup builds a wide tree");
        }
    }
    // Exact ties (rays through shared edges of a grid) go to the same triangle in both trees.
    let g = grid(16);
    let shifted: Vec<[Vec3; 3]> =
        g.iter().map(|t| t.map(|v| Vec3::new(v.y, v.x * 0.5, 0.25))).collect();
    let refit = Accel::build_refittable(&g, BvhKind::Wide).refit(&shifted).unwrap();
    let rebuilt = Accel::build(&shifted, BvhKind::Wide);
    for i in 0..=32 {
        for j in 0..=32 {
            let target = Vec3::new(i as f32 / 32.0, j as f32 / 64.0, 0.25);
            let ray = Ray::new(Vec3::new(0.3, 0.2, 2.0), target - Vec3::new(0.3, 0.2, 2.0));
            assert_eq!(
                refit.intersect(&ray, f32::INFINITY),
                rebuilt.intersect(&ray, f32::INFINITY),
                "edge ray {i},{j}"
            );
        }
    }
}

/// A refit's wear: 1 for the tree as built and for a refit that only scales the scene (the
/// surface-area cost is relative to the root's area), above [`WORN`] once triangles have moved
/// far from where the tree was built for them, barely above 1 for a small wobble.
#[test]
fn a_refit_onto_scrambled_triangles_is_worn_and_a_wobble_is_not() {
    let mut rng = Rng(41);
    let tris = soup(&mut rng, 3000);
    let built = Accel::build_refittable(&tris, BvhKind::Wide);
    assert_eq!(built.wear(), Some(1.0));
    assert!(!built.worn());
    assert_eq!(Accel::build(&tris, BvhKind::Wide).wear(), None, "not refittable: no cost as built");
    let scaled: Vec<[Vec3; 3]> = tris.iter().map(|t| t.map(|v| v * 3.0)).collect();
    let wear = built.refit(&scaled).unwrap().wear().unwrap();
    assert!((wear - 1.0).abs() < 1e-4, "scaled by 3: wear {wear}");
    let wobbled: Vec<[Vec3; 3]> = tris
        .iter()
        .map(|t| {
            t.map(|v| {
                v + 0.002 * Vec3::new((v.y * 40.0).sin(), (v.z * 40.0).sin(), (v.x * 40.0).sin())
            })
        })
        .collect();
    let wobble = built.refit(&wobbled).unwrap();
    assert!(wobble.wear().unwrap() < 1.1 && !wobble.worn(), "wobbled: wear {:?}", wobble.wear());
    // Swap every triangle with one elsewhere in the soup: the topology now groups far-apart
    // triangles, and its boxes span the scene.
    let scrambled: Vec<[Vec3; 3]> =
        (0..tris.len()).map(|i| tris[(i * 1237) % tris.len()]).collect();
    let scramble = built.refit(&scrambled).unwrap();
    assert!(scramble.worn(), "scrambled: wear {:?}", scramble.wear());
    assert!(Accel::build_refittable(&scrambled, BvhKind::Wide).wear() == Some(1.0));
}

/// A refit's parts run in parallel (the packets, the leaf boxes, the wear's sum in fixed
/// chunks): the refitted tree and its wear are the same bits on one thread as on four.
#[test]
fn a_refit_is_the_same_on_one_thread_and_on_four() {
    let mut rng = Rng(59);
    let tris = soup(&mut rng, 30_000);
    let moved: Vec<[Vec3; 3]> = tris
        .iter()
        .map(|t| t.map(|v| v + 0.01 * Vec3::new((v.y * 30.0).sin(), (v.z * 30.0).sin(), 0.0)))
        .collect();
    let refit_on = |threads| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            (
                Accel::build_refittable(&tris, BvhKind::Wide).refit(&moved).unwrap(),
                Faces::of(&moved).normals,
            )
        })
    };
    let ((one, one_normals), (four, four_normals)) = (refit_on(1), refit_on(4));
    match (&one.tree, &four.tree) {
        (Tree::Wide(a), Tree::Wide(b)) => assert!(a == b, "the nodes differ"),
        _ => panic!("a wide tree was built"),
    }
    assert_eq!(one.wear().map(f64::to_bits), four.wear().map(f64::to_bits));
    assert_eq!(one_normals, four_normals);
    assert_same_hits(&one, &four, &mut rng, 500, "one thread against four");
}

#[test]
fn refit_refuses_another_triangle_set() {
    let mut rng = Rng(3);
    let tris = soup(&mut rng, 50);
    assert!(Accel::build(&tris, BvhKind::Wide).refit(&tris).is_none(), "built without refit data");
    let accel = Accel::build_refittable(&tris, BvhKind::Wide);
    assert!(accel.refit(&tris[..49]).is_none(), "one triangle fewer");
    let mut far = tris.clone();
    far[7][1].x = f32::INFINITY; // not finite: left out of the tree
    let without = Accel::build_refittable(&far, BvhKind::Wide);
    assert!(without.refit(&tris).is_none(), "a triangle left out is one no more");
    assert!(accel.refit(&tris).is_some());
}

/// Triangles that become degenerate (collapsed to a point, or to a needle) between frames stay
/// in the refitted tree and are never hit, as a tree built for the new frame leaves them out;
/// refitted back, they are hit again.
#[test]
fn a_refit_keeps_triangles_that_became_degenerate_and_never_hits_them() {
    let mut rng = Rng(23);
    let tris = soup(&mut rng, 2000);
    let mut moved = tris.clone();
    for i in (0..tris.len()).step_by(7) {
        let [a, b, _] = tris[i];
        moved[i] = if i % 2 == 0 { [a; 3] } else { [a, b, a + (b - a) * 0.5] };
    }
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let refit = Accel::build_refittable(&tris, kind)
            .refit(&moved)
            .expect("degenerate now: still refitted");
        let rebuilt = Accel::build(&moved, kind);
        assert_same_hits(&refit, &rebuilt, &mut rng, 20_000, &format!("{kind:?}"));
        // Rays aimed at the collapsed triangles' former interiors.
        for i in (0..tris.len()).step_by(7) {
            let [a, b, c] = tris[i];
            let ray = Ray::new(Vec3::splat(-1.0), (a + b + c) / 3.0 - Vec3::splat(-1.0));
            let hit = refit.intersect(&ray, f32::INFINITY);
            assert!(
                hit.is_none_or(|h| !(h.prim as usize).is_multiple_of(7)),
                "{kind:?}: hit collapsed triangle {hit:?}"
            );
            assert_eq!(hit, rebuilt.intersect(&ray, f32::INFINITY));
        }
        let back = Accel::build_refittable(&moved, kind)
            .refit(&tris)
            .expect("degenerate no more: still refitted");
        assert_same_hits(
            &back,
            &Accel::build(&tris, kind),
            &mut rng,
            20_000,
            &format!("{kind:?} back"),
        );
    }
}

/// A direction component of −0.0 is a zero like +0.0: its reciprocal is −MAX, so a slab test
/// that picked the near plane by `d < 0` (false for −0.0) would take the far one and miss.
#[test]
fn negative_zero_direction_components_hit_like_positive_zeros() {
    let tris = grid(4);
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        let accel = Accel::build(&tris, kind);
        for (i, j) in [(1, 1), (3, 5), (6, 2), (5, 7)] {
            let target = Vec3::new(i as f32 / 8.0 + 0.01, j as f32 / 8.0 + 0.02, 0.0);
            for dir in [
                Vec3::new(-0.0, -0.0, -1.0),
                Vec3::new(0.0, -0.0, -1.0),
                Vec3::new(-0.0, 0.0, -1.0),
            ] {
                let ray = Ray::new(target + Vec3::Z, dir);
                let hit = accel.intersect(&ray, f32::INFINITY);
                assert!(
                    hit.is_some_and(|h| (h.t - 1.0).abs() < 1e-6),
                    "{kind:?}: ray {ray:?} missed"
                );
                assert!(accel.occluded(&ray, 2.0), "{kind:?}: shadow ray {ray:?} passed");
            }
        }
    }
}

/// Rays along an axis (both other components ±0) through a tree several levels deep find what
/// testing every triangle finds. obvhs's node test turned 0·∞ into NaN for such rays and culled
/// boxes they enter.
#[test]
fn axis_rays_with_zero_components_of_either_sign_find_the_brute_force_hit() {
    let tris = triangle_soup(&mut Rng(11), 4000);
    for kind in [BvhKind::Wide, BvhKind::Binary] {
        axis_rays_match_brute_force(&tris, kind);
    }
}

fn axis_rays_match_brute_force(tris: &[[Vec3; 3]], kind: BvhKind) {
    let accel = Accel::build(tris, kind);
    let mut rng = Rng(12);
    let mut found = 0;
    for k in 0..3000 {
        let o = rng.vec() * 12.0 - Vec3::ONE;
        let (z0, z1) = (if k & 1 == 0 { 0.0 } else { -0.0 }, if k & 2 == 0 { 0.0 } else { -0.0 });
        let s = if k & 4 == 0 { 1.0 } else { -1.0 };
        let dir = [Vec3::new(s, z0, z1), Vec3::new(z0, s, z1), Vec3::new(z0, z1, s)][k % 3];
        let ray = Ray::new(o, dir);
        let want = brute_force(tris, &ray);
        let got = accel.intersect(&ray, f32::INFINITY).map(|h| (h.t, h.prim));
        assert_eq!(got, want, "{kind:?}, ray {k}: {ray:?}");
        assert_eq!(
            accel.occluded(&ray, f32::INFINITY),
            want.is_some(),
            "{kind:?}, ray {k}: {ray:?}"
        );
        found += usize::from(want.is_some());
    }
    assert!(found > 500, "{kind:?}: only {found} rays hit");
}

/// The copy of the queries compiled for AVX2 (`accel/avx2.rs`) finds bit for bit the hits of
/// the baseline copy, on random rays and on axis rays with zero components of either sign.
#[test]
fn the_avx2_queries_find_the_baseline_hits() {
    if !avx2::detected() {
        eprintln!("this CPU has no AVX2 (or TESSERA_NO_AVX2 is set): nothing to compare");
        return;
    }
    let tris = triangle_soup(&mut Rng(21), 4000);
    let (mut baseline, avx) =
        (Accel::build(&tris, BvhKind::Wide), Accel::build(&tris, BvhKind::Wide));
    baseline.avx2 = false;
    assert!(avx.avx2);
    let mut rng = Rng(22);
    let mut hits = 0;
    for k in 0..20_000 {
        let o = rng.vec() * 12.0 - Vec3::ONE;
        let d = if k % 4 == 3 {
            let (z0, z1) =
                (if k & 8 == 0 { 0.0 } else { -0.0 }, if k & 16 == 0 { 0.0 } else { -0.0 });
            [Vec3::new(1.0, z0, z1), Vec3::new(z0, -1.0, z1), Vec3::new(z0, z1, 1.0)][k % 3]
        } else {
            (rng.vec() - Vec3::splat(0.5)).normalize_or(Vec3::X)
        };
        let ray = Ray::new(o, d);
        let t_max = if k % 2 == 0 { f32::INFINITY } else { rng.next() * 6.0 };
        let want = baseline.intersect(&ray, t_max);
        assert_eq!(avx.intersect(&ray, t_max), want, "ray {k}: {ray:?}");
        assert_eq!(avx.occluded(&ray, t_max), baseline.occluded(&ray, t_max), "ray {k}: {ray:?}");
        hits += usize::from(want.is_some());
    }
    assert!(hits > 2000 && hits < 18_000, "{hits} of 20000 rays hit");
}
