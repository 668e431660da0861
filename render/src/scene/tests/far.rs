//! Case 2 of the hard-case suite (docs/numerics.md) through the loader: bundled scenes moved far from the origin by a parent
//! node's translation (as a file placing a model far away would) render as at the origin.
//! Catches computing world positions in f32: at 1e5 the Cornell box's light (0.1 mm below the
//! ceiling) merges with it, and at 1e6 the furnace's hit points round by 0.06 and leak light.
use super::super::load_bytes;
use crate::tracer::PixelSums;
use crate::tracer::integrator::tests::{assert_within_4_sigma, pooled, render, settings};
use crate::tracer::integrator::{Estimator, Roulette};
use crate::tracer::scene::Scene;
use glam::Vec3;
use serde_json::{Value, json};

/// The bundled scene `name` under a new root node translated by `offset`.
fn bundled_moved(name: &str, offset: [f64; 3]) -> Scene {
    let path = format!("{}/../scenes/{name}.gltf", env!("CARGO_MANIFEST_DIR"));
    let mut doc: Value =
        serde_json::from_slice(&std::fs::read(path).expect("bundled scene")).expect("JSON");
    let scene = doc["scene"].as_u64().unwrap_or(0) as usize;
    let roots = doc["scenes"][scene]["nodes"].clone();
    let nodes = doc["nodes"].as_array_mut().expect("nodes");
    nodes.push(json!({"name": "moved", "translation": offset, "children": roots}));
    let moved = nodes.len() - 1;
    doc["scenes"][scene]["nodes"] = json!([moved]);
    load_bytes(&serde_json::to_vec(&doc).expect("JSON"), None).expect("moved scene loads")
}

#[test]
fn far_scenes_are_rebased_and_near_ones_left_alone() {
    let here = bundled_moved("cornell-box", [0.0; 3]);
    let there = bundled_moved("cornell-box", [1e5, 1e5, -1e5]);
    assert_eq!(
        here.mesh.positions,
        super::super::load_path(std::path::Path::new(&format!(
            "{}/../scenes/cornell-box.gltf",
            env!("CARGO_MANIFEST_DIR")
        )))
        .unwrap()
        .mesh
        .positions
    );
    // Moved to the origin, the far copy keeps the light 0.1 mm under the ceiling.
    let ys = |s: &Scene| {
        let mut y: Vec<f32> = s.mesh.positions.iter().flatten().map(|p| p.y).collect();
        y.sort_by(f32::total_cmp);
        y.dedup();
        y
    };
    assert_eq!(ys(&here).len(), ys(&there).len(), "{:?} vs {:?}", ys(&here), ys(&there));
}

/// The furnace moved 1e4, 1e5 and 1e6 away renders Le/(1 − ρ) = 0.5 within 4σ.
#[test]
fn furnace_moved_up_to_1e6_away_renders_its_closed_form() {
    for offset in [1e4, 1e5, 1e6] {
        let scene = bundled_moved("furnace", [offset, -0.7 * offset, 0.3 * offset]);
        let got = pooled(&render(
            &scene,
            &settings(Estimator::Mis, Roulette::default(), 8, Vec3::ZERO),
            64,
        ));
        assert_within_4_sigma(&format!("furnace at {offset:e}"), got, 0.5);
    }
}

/// Frame mean per channel and its standard error.
fn frame_mean(pixels: &[PixelSums]) -> [(f64, f64); 3] {
    let n = pixels.len() as f64;
    [0, 1, 2].map(|c| {
        let mean = pixels.iter().map(|p| p.mean()[c]).sum::<f64>() / n;
        let var = pixels.iter().map(|p| p.variance_of_mean()[c]).sum::<f64>() / (n * n);
        (mean, var.sqrt())
    })
}

/// The Cornell box moved 1e5 away renders the same image mean as at the origin, within 4σ of
/// the difference (independent samples, so the per-pixel variances are honest).
#[test]
fn cornell_box_moved_1e5_away_matches_the_one_at_the_origin() {
    let here = bundled_moved("cornell-box", [0.0; 3]);
    let there = bundled_moved("cornell-box", [1e5, 1e5, -1e5]);
    let s = settings(Estimator::Mis, Roulette::default(), 24, Vec3::ZERO);
    let (a, b) = (frame_mean(&render(&here, &s, 64)), frame_mean(&render(&there, &s, 64)));
    for c in 0..3 {
        let ((ma, sa), (mb, sb)) = (a[c], b[c]);
        let sigma = sa.hypot(sb);
        assert!(ma > 0.01, "the box must be lit ({ma})");
        assert!((ma - mb).abs() <= 4.0 * sigma, "channel {c}: origin {ma} vs far {mb} (σ {sigma})");
    }
}
