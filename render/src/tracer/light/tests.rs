use super::*;

fn tri_light(y: f32, radiance: f32) -> Light {
    // Facing −Y (towards the origin below it).
    let v = [Vec3::new(-1.0, y, -1.0), Vec3::new(1.0, y, -1.0), Vec3::new(-1.0, y, 1.0)];
    Light::triangle(0, &v, Vec3::splat(radiance), false).expect("non-degenerate")
}

#[test]
fn degenerate_triangles_are_not_lights() {
    let v = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
    assert!(Light::triangle(0, &v, Vec3::ONE, false).is_none());
    let needle = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1e-30, 0.0)];
    assert!(Light::triangle(0, &needle, Vec3::ONE, false).is_none());
}

#[test]
fn lights_are_chosen_in_proportion_to_power() {
    let lights = [tri_light(1.0, 1.0), tri_light(2.0, 3.0)];
    let set = LightSet::new(&lights, Vec3::ZERO, 10.0);
    assert!((set.pmf[0] - 0.25).abs() < 1e-6 && (set.pmf[1] - 0.75).abs() < 1e-6);
    let picks = (0..1000).filter(|i| {
        let s =
            set.sample(Vec3::ZERO, Vec3::Y, Vec2::new((*i as f32 + 0.5) / 1000.0, 0.3)).unwrap();
        s.li.x == 3.0
    });
    assert_eq!(picks.count(), 750);
}

#[test]
fn the_choice_hands_each_light_its_share_of_x_stretched_to_the_whole_range() {
    let lights = [tri_light(1.0, 1.0), tri_light(2.0, 3.0)];
    let set = LightSet::new(&lights, Vec3::ZERO, 10.0);
    let n = 4000;
    let mut stretched = [Vec::new(), Vec::new()];
    for k in 0..n {
        let (i, x) = set.choose((k as f32 + 0.5) / n as f32).expect("a light");
        stretched[i].push(x);
    }
    // Evenly spaced points in a light's interval stay evenly spaced over [0, 1): the
    // stratification of x carries over to each light's own sample.
    for xs in &stretched {
        let m = xs.len() as f32;
        for (j, x) in xs.iter().enumerate() {
            assert!((x - (j as f32 + 0.5) / m).abs() < 1e-4, "{j}th of {m}: {x}");
        }
    }
    assert_eq!((stretched[0].len(), stretched[1].len()), (1000, 3000));
}

#[test]
fn area_pdf_agrees_with_the_sampled_pdf() {
    let lights = [tri_light(1.0, 1.0), tri_light(2.0, 3.0)];
    let set = LightSet::new(&lights, Vec3::splat(0.5), 10.0);
    let p = Vec3::new(0.1, 0.0, -0.2);
    for k in 0..64 {
        let u = Vec2::new((k % 8) as f32 / 8.0 + 0.03, (k / 8) as f32 / 8.0 + 0.05);
        let Some(s) = set.sample(p, Vec3::Y, u) else { continue };
        let expected = match s.target {
            Target::Point { p: q, .. } => {
                let light = if s.li.x == 1.0 { 0 } else { 1 };
                set.pdf_area(light, p, Vec3::Y, q.p)
            }
            Target::Infinite => set.pdf_background(Vec3::Y, s.wi),
        };
        assert!((s.pdf - expected).abs() <= 1e-4 * expected, "{} vs {expected}", s.pdf);
    }
}

#[test]
fn one_sided_emitters_are_dark_from_behind() {
    let lights = [tri_light(-1.0, 1.0)];
    let set = LightSet::new(&lights, Vec3::ZERO, 10.0);
    // The light at y = −1 faces −Y, away from the origin.
    assert!(set.sample(Vec3::ZERO, Vec3::NEG_Y, Vec2::splat(0.2)).is_none());
}

#[test]
fn spot_falloff_is_full_inside_and_zero_outside_the_cone() {
    let (ci, co) = (0.3f32.cos(), 0.5f32.cos());
    assert_eq!(spot_falloff(1.0, ci, co), 1.0);
    assert_eq!(spot_falloff(0.6f32.cos(), ci, co), 0.0);
    let mid = spot_falloff(0.4f32.cos(), ci, co);
    assert!(mid > 0.0 && mid < 1.0);
}

#[test]
fn point_light_follows_the_inverse_square_law() {
    let l = Light::Point { position: Vec3::new(0.0, 2.0, 0.0), intensity: Vec3::splat(8.0) };
    let s = l
        .sample::<crate::tracer::kernel::AllEffects>(Vec3::ZERO, Vec3::Y, Vec2::ZERO, &[])
        .unwrap();
    assert_eq!(s.li, Vec3::splat(2.0));
    assert!(s.delta);
}
