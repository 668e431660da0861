use super::*;

/// Two triangles: a square of side `side` centred at `c`, its normal along `normal` (±y).
fn square(c: Vec3, side: f32, down: bool) -> [[Vec3; 3]; 2] {
    let (x, z) = (Vec3::X * side * 0.5, Vec3::Z * side * 0.5);
    let [a, b, cc, d] = [c - x - z, c + x - z, c + x + z, c - x + z];
    // Counter-clockwise seen from where the normal points.
    match down {
        true => [[a, b, cc], [a, cc, d]],
        false => [[a, cc, b], [a, d, cc]],
    }
}

/// A floor (`floor` m square at y = 0, facing up, the first two triangles) under lamps
/// (`side` m squares facing down at height `height`) centred at `at`; the lamps' triangles
/// follow the floor's. Returns the triangles and the lamps as lights.
fn room(floor: f32, at: &[Vec3], side: f32, height: f32) -> (Vec<[Vec3; 3]>, Vec<Light>) {
    room_of_halves(floor, at, side, height, 2)
}

/// [`room`] with each lamp the first `halves` (1 or 2) triangles of its square.
fn room_of_halves(
    floor: f32,
    at: &[Vec3],
    side: f32,
    height: f32,
    halves: usize,
) -> (Vec<[Vec3; 3]>, Vec<Light>) {
    let mut positions: Vec<[Vec3; 3]> = square(Vec3::ZERO, floor, false).to_vec();
    let mut lights = Vec::new();
    for &c in at {
        for v in square(c + Vec3::Y * height, side, true).into_iter().take(halves) {
            let l = Light::triangle(positions.len() as u32, &v, Vec3::splat(10.0), false)
                .expect("a real triangle");
            assert!(matches!(l, Light::Triangle { n, .. } if n.y < 0.0), "lamps face down");
            positions.push(v);
            lights.push(l);
        }
    }
    (positions, lights)
}

/// What `auto` does with a tree over `lights`.
fn suits(lights: &[Light], positions: &[[Vec3; 3]], scatters: impl Fn(usize) -> bool) -> bool {
    LightTree::over(lights).is_some_and(|t| t.suits(lights, positions, scatters))
}

fn floor_only(t: usize) -> bool {
    t < 2
}

#[test]
fn lamps_far_apart_each_light_their_own_patch_and_the_tree_sees_it() {
    // Two one-triangle lamps 100 m apart, 0.5 m above a 200 m floor: every receiver that
    // counts is lit by one lamp alone (f = (F, 0)), so choosing either with probability ½ has
    // relative variance F²/½ ÷ F² − 1 = 1, and the tree, which sends the sample to the near
    // lamp, nearly 0. Near one lamp the other gives less than (0.5 / 50)² × (1 / 50²) of what it
    // gives, so the relative variance by power is 1 to within 1e-3.
    let (positions, lights) = room_of_halves(
        200.0,
        &[Vec3::new(-50.0, 0.0, 0.0), Vec3::new(50.0, 0.0, 0.0)],
        0.2,
        0.5,
        1,
    );
    let tree = LightTree::over(&lights).expect("a tree");
    let spread = Spread::measure(&tree, &lights, &positions, floor_only);
    assert!((spread.by_power - 1.0).abs() < 1e-3, "{spread:?}");
    assert!(spread.by_tree < 0.05, "{spread:?}");
    assert!(spread.favours_tree() && suits(&lights, &positions, floor_only));
}

#[test]
fn four_lamps_over_a_room_suit_the_tree_one_lamp_does_not() {
    let corners =
        [(-3.0, -3.0), (3.0, -3.0), (-3.0, 3.0), (3.0, 3.0)].map(|(x, z)| Vec3::new(x, 0.0, z));
    let (positions, lights) = room(10.0, &corners, 0.3, 2.5);
    assert!(
        suits(&lights, &positions, floor_only),
        "{:?}",
        Spread::measure(&LightTree::over(&lights).unwrap(), &lights, &positions, floor_only)
    );
    // One lamp of two triangles: both give any receiver nearly the same, whichever way it is chosen.
    let (positions, lights) = room(10.0, &[Vec3::ZERO], 0.3, 2.5);
    let spread =
        Spread::measure(&LightTree::over(&lights).unwrap(), &lights, &positions, floor_only);
    assert!(spread.by_power < MIN_EXCESS && !spread.favours_tree(), "{spread:?}");
    assert!(!suits(&lights, &positions, floor_only));
}

#[test]
fn lights_that_light_nothing_or_are_alone_choose_by_power_and_many_by_the_tree() {
    let corners =
        [(-3.0, -3.0), (3.0, -3.0), (-3.0, 3.0), (3.0, 3.0)].map(|(x, z)| Vec3::new(x, 0.0, z));
    let (positions, lights) = room(10.0, &corners, 0.3, 2.5);
    let tree = LightTree::over(&lights).unwrap();
    assert_eq!(Spread::measure(&tree, &lights, &positions, |_| false), Spread::NOTHING_LIT);
    assert!(!suits(&lights, &positions, |_| false), "no surface to light");
    assert!(!suits(&lights[..1], &positions, floor_only), "one light: nothing to choose");
    // From MIN_LIGHTS on the tree is used without measuring, even where nothing is lit.
    let grid: Vec<Vec3> =
        (0..LightTree::MIN_LIGHTS / 2).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
    let (positions, lights) = room(10.0, &grid, 0.3, 2.5);
    assert_eq!(lights.len(), LightTree::MIN_LIGHTS);
    assert!(suits(&lights, &positions, |_| false));
}
