//! Frames of the bundled animated Cornell box: the animation is found, frames differ, and a
//! frame whose BVH was refitted from another frame renders the same bits as one built anew.
use super::super::*;
use crate::tracer::RenderOptions;
use crate::tracer::integrator::PathSettings;
use crate::tracer::sampler::{SamplerKind, frame_seed};
use crate::tracer::{RenderSettings, Tile, TileSums, render_tile};

const FPS: f64 = 24.0;

fn animated() -> Sequence {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-animated.gltf");
    Sequence::parse(&std::fs::read(path).unwrap(), None).unwrap()
}

fn render(scene: &Scene, frame: u32) -> TileSums {
    let settings = RenderSettings {
        width: 48,
        height: 48,
        seed: frame_seed(5, frame),
        sampler: SamplerKind::Sobol,
        path: PathSettings { max_depth: 8, ..PathSettings::default() },
        background: glam::Vec3::ZERO,
        camera: None,
    };
    render_tile(
        scene,
        &settings,
        Tile { x0: 0, y0: 0, w: 48, h: 48 },
        0..4,
        &RenderOptions::default(),
    )
    .unwrap()
}

/// Bit patterns of every sum, so NaN-free float sums compare exactly.
fn bits(s: &TileSums) -> Vec<u64> {
    s.pixels
        .iter()
        .flat_map(|p| {
            p.sum
                .iter()
                .chain(&p.sum_sq)
                .chain([&p.sum_lum_sq])
                .map(|x| x.to_bits())
                .chain([p.count])
        })
        .collect()
}

#[test]
fn the_animated_cornell_box_has_its_animation() {
    let seq = animated();
    let info = seq.animations();
    assert_eq!(
        info,
        vec![AnimationInfo { name: Some("roll".into()), duration_s: 1.0, channels: 3 }]
    );
    assert_eq!(animation::resolve(&info, None), Ok(Some(0)));
    assert_eq!(animation::resolve(&info, Some("roll")), Ok(Some(0)));
    let parsed = parse(
        &std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-animated.gltf"))
            .unwrap(),
        None,
    )
    .unwrap();
    assert_eq!(resolve_animation(&parsed, Some("0")), Ok(Some(0)));
    assert!(
        resolve_animation(&parsed, Some("jump")).unwrap_err().0.contains("the scene has: roll")
    );
}

#[test]
fn frames_differ_where_the_ball_and_camera_move() {
    let seq = animated();
    let (f0, f7) =
        (seq.parsed_at(Some(0), 0.0).unwrap(), seq.parsed_at(Some(0), 7.0 / FPS).unwrap());
    assert_eq!(f0.triangles(), f7.triangles());
    // The box's walls, blocks and light stay; every triangle of the ball (its two materials,
    // the last ones before the default) moves.
    let ball_materials = f0.materials.len() - 3..f0.materials.len() - 1;
    let is_ball = |i: usize| ball_materials.contains(&(f0.mesh.material[i] as usize));
    assert_eq!((0..f0.triangles()).filter(|&i| is_ball(i)).count(), 960);
    for i in 0..f0.triangles() {
        assert_eq!(f0.mesh.positions[i] == f7.mesh.positions[i], !is_ball(i), "triangle {i}");
    }
    // The ball rolls in −x: its centre moves by 8 cm (0.14 m in 0.5 s, frame 7 at 0.29 s).
    let centre = |p: &Parsed| {
        let ball: Vec<glam::Vec3> =
            (0..p.triangles()).filter(|&i| is_ball(i)).flat_map(|i| p.mesh.positions[i]).collect();
        ball.iter().fold(glam::Vec3::ZERO, |a, v| a + *v) / ball.len() as f32
    };
    let (c0, c7) = (centre(&f0), centre(&f7));
    assert!((c0.x - c7.x - 0.14 * 7.0 / 12.0).abs() < 1e-3, "{c0} → {c7}");
    // The camera dollies forward (+z).
    let eye = |s: &Scene| s.cameras[0].to_world.transform_point3(glam::Vec3::ZERO);
    let (s0, s7) = (f0.build(), f7.build());
    assert!(eye(&s7).z > eye(&s0).z + 0.01, "{} → {}", eye(&s0), eye(&s7));
    // And the images differ.
    assert_ne!(bits(&render(&s0, 0)), bits(&render(&s7, 7)));
}

#[test]
fn a_refitted_frame_renders_the_bits_of_a_rebuilt_one() {
    let seq = animated();
    let frame1 = seq.scene_at(Some(0), 1.0 / FPS).unwrap();
    let (refitted, how) = seq.scene_after(&frame1, Some(0), 3.0 / FPS).unwrap();
    assert_eq!(how, Preparation::Refit);
    let rebuilt = seq.scene_at(Some(0), 3.0 / FPS).unwrap();
    assert_eq!(bits(&render(&refitted, 3)), bits(&render(&rebuilt, 3)));
    // A still (no animation) has nothing to refit from.
    let still = seq.parsed_at(None, 0.0).unwrap().build();
    let (_, how) = seq.scene_after(&still, Some(0), 0.0).unwrap();
    assert_eq!(how, Preparation::Build);
}

/// A frame whose triangles have moved far from where the previous frame's tree was built for
/// them is built, not refitted (the refit would wear the tree out), and the frame after it
/// refits the new tree.
#[test]
fn a_frame_that_would_wear_the_tree_out_is_built() {
    let seq = animated();
    let frame0 = seq.scene_at(Some(0), 0.0).unwrap();
    let mut far = seq.parsed_at(Some(0), 0.0).unwrap();
    // Every triangle's corners handed to another triangle: the same set of triangles, none
    // where the tree put it.
    let n = far.mesh.positions.len();
    let scrambled: Vec<_> = (0..n).map(|i| far.mesh.positions[(i * 617) % n]).collect();
    far.mesh.positions = scrambled;
    assert!(frame0.accel.refit(&far.mesh.positions).is_some_and(|a| a.worn()));
    let (built, how) = far.build_from(&frame0);
    assert_eq!(how, Preparation::Build);
    assert_eq!(built.accel.wear(), Some(1.0));
    let (_, how) = seq.parsed_at(Some(0), 0.0).unwrap().build_from(&frame0);
    assert_eq!(how, Preparation::Refit);
}
