use super::*;
use crate::tracer::chi2::Rng;
use crate::tracer::light::{LightSet, Target};

fn unit(rng: &mut Rng) -> Vec3 {
    loop {
        let v = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0 - 1.0;
        if (0.01..=1.0).contains(&v.length_squared()) {
            return v.normalize();
        }
    }
}

/// `count` small triangle lights scattered through a 10 m cube, facing every way, a quarter of
/// them two-sided; light i has radiance 1 + i/1000 (so a sample names its light).
fn scattered(count: usize, seed: u64) -> Vec<Light> {
    let mut rng = Rng::new(seed);
    (0..count)
        .map(|i| {
            let c = (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * 10.0;
            let n = unit(&mut rng);
            let t = n.any_orthonormal_vector();
            let (b, s) = (n.cross(t), 0.05 + 0.3 * rng.f32());
            let v = [c + t * s, c + b * s, c - (t + b) * s];
            Light::triangle(i as u32, &v, Vec3::splat(1.0 + i as f32 / 1000.0), i % 4 == 0)
                .expect("a real triangle")
        })
        .collect()
}

/// A 16 × 16 grid of 10 cm lamps 0.3 m above the plane y = 0, facing down, 0.5 m apart.
fn lamp_grid() -> Vec<Light> {
    let mut lights = Vec::new();
    for (k, (i, j)) in (0..16).flat_map(|i| (0..16).map(move |j| (i, j))).enumerate() {
        let c = Vec3::new(i as f32 * 0.5, 0.3, j as f32 * 0.5);
        let v = [c, c + Vec3::new(0.1, 0.0, 0.0), c + Vec3::new(0.0, 0.0, 0.1)];
        let l = Light::triangle(k as u32, &v, Vec3::splat(5.0), false).expect("a real triangle");
        assert!(matches!(l, Light::Triangle { n, .. } if n.y < 0.0), "lamps face down");
        lights.push(l);
    }
    lights
}

fn receivers(rng: &mut Rng, count: usize) -> Vec<(Vec3, Vec3)> {
    (0..count)
        .map(|k| {
            let p = (Vec3::new(rng.f32(), rng.f32(), rng.f32()) - 0.5) * 14.0;
            // Every fourth point has no normal (a medium, or a caller without one).
            (p, if k % 4 == 0 { Vec3::ZERO } else { unit(rng) })
        })
        .collect()
}

#[test]
fn the_setting_overrides_what_suits_the_scene_and_the_tree_holds_the_triangles_only() {
    let auto = LightSampler::Auto;
    assert!(auto.uses_tree(true) && !auto.uses_tree(false), "auto does what suits the scene");
    assert!(LightSampler::Tree.uses_tree(false) && !LightSampler::Power.uses_tree(true));
    for l in LightSampler::ALL {
        assert_eq!(l.name().parse::<LightSampler>(), Ok(l));
    }
    assert!("bvh".parse::<LightSampler>().unwrap_err().to_string().contains("auto, power, tree"));
    let mut lights = scattered(3, 1);
    lights.push(Light::Point { position: Vec3::ZERO, intensity: Vec3::ONE });
    let tree = LightTree::over(&lights).expect("a tree");
    assert_eq!(tree.len(), 3, "the point light is not in the tree");
    assert!(LightTree::over(&lights[3..]).is_none(), "no area lights, no tree");
}

#[test]
fn the_choice_probabilities_of_all_lights_sum_to_one_where_every_node_can_light_the_point() {
    // Below a grid of lamps that all face down, every node reaches every point.
    let lights = lamp_grid();
    let tree = LightTree::build(&lights);
    let mut rng = Rng::new(2);
    for k in 0..200 {
        let p = Vec3::new(rng.f32() * 10.0 - 1.0, rng.f32() * 0.25 - 1.0, rng.f32() * 10.0 - 1.0);
        let n = if k % 4 == 0 { Vec3::ZERO } else { (unit(&mut rng) + Vec3::Y * 1.1).normalize() };
        let sum: f64 = (0..lights.len()).map(|i| f64::from(tree.pmf(i, p, n))).sum();
        assert!((sum - 1.0).abs() < 1e-4, "at {p} with normal {n}: Σ pmf = {sum}");
    }
    // Where lights face every way, a walk can end at a node whose lights all face away, so
    // some probability is lost (a light sample that finds nothing), never gained.
    let lights = scattered(300, 3);
    let tree = LightTree::build(&lights);
    for (p, n) in receivers(&mut rng, 200) {
        let sum: f64 = (0..lights.len()).map(|i| f64::from(tree.pmf(i, p, n))).sum();
        assert!(sum < 1.0 + 1e-4 && sum > 0.5, "at {p} with normal {n}: Σ pmf = {sum}");
    }
}

#[test]
fn a_sample_carries_the_probability_that_pmf_gives_its_light() {
    let lights = scattered(300, 4);
    let tree = LightTree::build(&lights);
    let mut rng = Rng::new(5);
    let mut found = 0;
    for (p, n) in receivers(&mut rng, 100) {
        for _ in 0..20 {
            let Some((i, pmf, x)) = tree.sample(p, n, rng.f32()) else { continue };
            found += 1;
            assert_eq!(pmf.to_bits(), tree.pmf(i, p, n).to_bits(), "light {i} at {p}");
            assert!(pmf > 0.0 && (0.0..1.0).contains(&x), "pmf {pmf}, stretched u {x}");
        }
    }
    assert!(found > 1500, "{found} of 2000 draws found a light");
}

#[test]
fn evenly_spaced_numbers_pick_each_light_as_often_as_its_probability() {
    let lights = scattered(200, 6);
    let tree = LightTree::build(&lights);
    let (p, n) = (Vec3::new(0.3, -0.2, 0.1), Vec3::new(0.0, 1.0, 0.0));
    let draws = 1 << 18;
    let (mut count, mut none) = (vec![0u32; lights.len()], 0u32);
    for k in 0..draws {
        match tree.sample(p, n, (k as f32 + 0.5) / draws as f32) {
            Some((i, ..)) => count[i] += 1,
            None => none += 1,
        }
    }
    let lost = 1.0 - (0..lights.len()).map(|i| f64::from(tree.pmf(i, p, n))).sum::<f64>();
    assert!(
        (f64::from(none) - lost * f64::from(draws)).abs() <= 2.0 + 1e-3 * f64::from(draws),
        "{none} draws found nothing, expected {lost} of them"
    );
    // The choice maps [0, 1) onto one interval per light, of its probability's length, so
    // evenly spaced numbers hit each the expected number of times up to the ends.
    for (i, &c) in count.iter().enumerate() {
        let expected = f64::from(tree.pmf(i, p, n)) * f64::from(draws);
        assert!(
            (f64::from(c) - expected).abs() <= 2.0 + expected * 1e-4,
            "light {i}: {c} picks, expected {expected}"
        );
    }
}

#[test]
fn every_light_that_faces_a_point_can_be_picked_for_it() {
    let lights = scattered(300, 7);
    let tree = LightTree::build(&lights);
    let mut rng = Rng::new(8);
    let mut points = receivers(&mut rng, 1000);
    // Points a hair in front of a light's plane, beside it, where the cone test is tightest.
    for l in lights.iter().step_by(7) {
        let Light::Triangle { v, n, .. } = l else { unreachable!() };
        let side = (v[1] - v[0]).normalize();
        points.push((v[0] - side * 0.5 + *n * 1e-5, unit(&mut rng)));
        points.push((v[0] - side * 3.0 + *n * 1e-3, Vec3::ZERO));
    }
    let mut checked = 0;
    for (p, rn) in points {
        for (i, l) in lights.iter().enumerate() {
            let Light::Triangle { v, n, two_sided, .. } = l else { unreachable!() };
            let c = (v[0] + v[1] + v[2]) / 3.0;
            let faces = [v[0], v[1], v[2], c].iter().any(|&q| {
                let h = (p - q).dot(*n);
                h > 0.0 || *two_sided && h < 0.0
            });
            if faces {
                checked += 1;
                assert!(tree.pmf(i, p, rn) > 0.0, "light {i} faces {p} but cannot be picked");
            }
        }
    }
    assert!(checked > 10_000, "only {checked} light–point pairs checked");
}

/// Irradiance at `p` (normal `n`) from light samples alone, visibility ignored: (mean,
/// standard error) over `samples` independent draws.
fn irradiance(set: &LightSet, p: Vec3, n: Vec3, samples: usize, rng: &mut Rng) -> (f64, f64) {
    let (mut s, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..samples {
        let v = set
            .sample(p, n, rng.vec2())
            .map_or(0.0, |ls| f64::from(ls.li.x * n.dot(ls.wi).max(0.0) / ls.pdf));
        (s, s2) = (s + v, s2 + v * v);
    }
    let mean = s / samples as f64;
    (mean, ((s2 / samples as f64 - mean * mean).max(0.0) / samples as f64).sqrt())
}

#[test]
fn the_tree_estimates_the_same_irradiance_as_choosing_by_power_with_less_noise_under_a_lamp_grid() {
    let lights = lamp_grid();
    let tree = LightTree::over(&lights).expect("256 lamps get a tree");
    let by_power = LightSet::new(&lights, Vec3::ZERO, 10.0);
    let by_tree = LightSet::with_tree(&lights, Some(&tree), Vec3::ZERO, 10.0);
    let mut rng = Rng::new(9);
    for p in [
        Vec3::new(3.02, 0.0, 4.03),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(7.3, 0.0, 1.1),
        Vec3::new(-2.0, 0.0, 3.0),
    ] {
        let (power, power_err) = irradiance(&by_power, p, Vec3::Y, 200_000, &mut rng);
        let (tree, tree_err) = irradiance(&by_tree, p, Vec3::Y, 200_000, &mut rng);
        let z = (tree - power) / power_err.hypot(tree_err);
        assert!(
            z.abs() < 4.5,
            "at {p}: tree {tree:.5} ± {tree_err:.1e}, power {power:.5} ± {power_err:.1e} (z = {z:.2})"
        );
        // Under the grid a point is lit mostly by the lamps overhead, which the tree favours.
        if p.x >= 0.0 {
            assert!(
                tree_err < 0.5 * power_err,
                "at {p}: the tree's error {tree_err:.2e} against {power_err:.2e} by power"
            );
        }
    }
}

#[test]
fn area_densities_match_the_sampled_densities_through_the_tree() {
    let mut lights = scattered(150, 10);
    lights.push(Light::Point { position: Vec3::new(0.0, 6.0, 0.0), intensity: Vec3::splat(0.5) });
    let tree = LightTree::over(&lights).expect("a tree");
    let set = LightSet::with_tree(&lights, Some(&tree), Vec3::splat(0.002), 10.0);
    let mut rng = Rng::new(11);
    let (mut areas, mut others) = (0, 0);
    // The integrator always has a shading normal (the background is sampled around it).
    for (p, n) in receivers(&mut rng, 40).into_iter().filter(|(_, n)| *n != Vec3::ZERO) {
        for _ in 0..60 {
            let Some(s) = set.sample(p, n, rng.vec2()) else { continue };
            let expected = match s.target {
                Target::Point { p: q, ng } if ng != Vec3::ZERO => {
                    areas += 1;
                    let light = ((s.li.x - 1.0) * 1000.0).round() as u32;
                    set.pdf_area(light, p, n, q.p)
                }
                Target::Point { .. } => {
                    others += 1;
                    set.choice_pmf(lights.len() - 1, p, n)
                }
                Target::Infinite => {
                    others += 1;
                    set.pdf_background(n, s.wi)
                }
            };
            assert!(
                (s.pdf - expected).abs() <= 1e-4 * expected,
                "{} vs {expected}: {s:?} p {p} n {n} li {}",
                s.pdf,
                s.li.x
            );
        }
    }
    assert!(areas > 500 && others > 20, "{areas} area and {others} other samples");
}

#[test]
fn stretched_numbers_keep_their_order_within_a_light() {
    let lights = lamp_grid();
    let tree = LightTree::build(&lights);
    let (p, n) = (Vec3::new(2.0, 0.0, 2.0), Vec3::Y);
    let mut last: Vec<Option<f32>> = vec![None; lights.len()];
    for k in 0..4096 {
        let Some((i, _, x)) = tree.sample(p, n, (k as f32 + 0.5) / 4096.0) else { continue };
        assert!(last[i].is_none_or(|prev| x > prev), "light {i}: {x} after {:?}", last[i]);
        last[i] = Some(x);
    }
}

#[test]
fn specks_of_light_far_away_and_lights_bright_enough_to_overflow_are_still_sampled() {
    // A hundred triangles of 1e-12 m² under a point 1e4 m above them: the irradiance through the
    // tree is the closed form's (the bounds subtend 1e-10 rad; nothing underflows to zero).
    let s = (2e-12f32).sqrt();
    let specks: Vec<Light> = (0..100)
        .map(|i| {
            let c = Vec3::new((i % 10) as f32, 0.0, (i / 10) as f32);
            let v = [c, c + Vec3::new(0.0, 0.0, s), c + Vec3::new(s, 0.0, 0.0)];
            Light::triangle(i, &v, Vec3::splat(3.0), false).expect("a speck")
        })
        .collect();
    let tree = LightTree::over(&specks).expect("a tree");
    let set = LightSet::with_tree(&specks, Some(&tree), Vec3::ZERO, 1e4);
    let p = Vec3::new(4.5, 1e4, 4.5);
    let expected: f64 = specks
        .iter()
        .map(|l| {
            // Each speck's own area: its corners are rounded to f32 beside coordinates up to 9.
            let Light::Triangle { v, area, .. } = l else { unreachable!() };
            let d = p.as_dvec3() - ((v[0] + v[1] + v[2]) / 3.0).as_dvec3();
            let cos = d.y / d.length();
            3.0 * f64::from(*area) * cos * cos / d.length_squared()
        })
        .sum();
    let (got, err) = irradiance(&set, p, Vec3::NEG_Y, 20_000, &mut Rng::new(12));
    assert!(
        (got / expected - 1.0).abs() < 5e-3 && err < 1e-3 * expected,
        "{got:e} ± {err:e} vs {expected:e}"
    );
    // Radiance of 3e38: the importances overflow to ∞ near the lamps, and the choice goes on.
    let mut bright = lamp_grid();
    for l in &mut bright {
        let Light::Triangle { radiance, .. } = l else { unreachable!() };
        *radiance = Vec3::splat(3e38);
    }
    let tree = LightTree::over(&bright).expect("a tree");
    let p = Vec3::new(2.02, 0.29, 2.03);
    let overflows =
        |node: &Inner| node.importance(p, Vec3::Y).to_array().iter().sum::<f32>() == f32::INFINITY;
    assert!(tree.nodes.iter().any(overflows), "no node's importances overflow");
    for k in 0..64 {
        let (i, pmf, _) = tree.sample(p, Vec3::Y, (k as f32 + 0.5) / 64.0).expect("a light");
        assert!(
            pmf > 0.0 && pmf.is_finite() && pmf == tree.pmf(i, p, Vec3::Y),
            "light {i}: pmf {pmf}"
        );
    }
}

#[test]
fn the_tree_gives_each_point_under_a_lamp_grid_its_exact_irradiance() {
    use crate::tracer::integrator::tests::polygon_irradiance;
    let lights = lamp_grid();
    let tree = LightTree::over(&lights).expect("a tree");
    let set = LightSet::with_tree(&lights, Some(&tree), Vec3::ZERO, 10.0);
    let mut rng = Rng::new(13);
    for p in [
        Vec3::new(3.02, 0.0, 4.03),
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(7.3, 0.0, 1.1),
        Vec3::new(-2.0, 0.0, 3.0),
        Vec3::new(4.04, 0.299, 4.03),
    ] {
        let exact: f64 = lights
            .iter()
            .map(|l| {
                let Light::Triangle { v, .. } = l else { unreachable!() };
                polygon_irradiance(p, Vec3::Y, v, 5.0)
            })
            .sum();
        let (got, err) = irradiance(&set, p, Vec3::Y, 2_000_000, &mut rng);
        let z = (got - exact) / err;
        eprintln!(
            "at {p}: {got:.6} ± {err:.1e} vs exact {exact:.6} ({:+.4} %, z {z:+.2})",
            (got / exact - 1.0) * 100.0
        );
        assert!(z.abs() < 4.5, "at {p}: {got} ± {err:.1e} vs exact {exact} (z = {z:.2})");
    }
}
