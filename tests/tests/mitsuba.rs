//! The Cornell box against an independent renderer: Mitsuba 3's reference image
//! (tests/reference/, made by make_cornell_reference.py) must agree with ours.
use crate::harness::{channel, independent_settings, region_mean, repo_root};
use tessera_server::bundled;
use tessera_server::output::decode_exr;
use tessera_worker::tracer::{Estimator, render_tile};

#[test]
fn cornell_box_matches_mitsuba_within_error_bars() {
    let bytes = std::fs::read(repo_root().join("tests/reference/cornell-box-mitsuba.exr")).expect("reference EXR");
    let (reference, _) = decode_exr(&bytes).expect("decode reference");
    let (w, h) = (reference.width as u32, reference.height as u32);
    let scene = bundled::load("cornell-box").unwrap();
    let s = independent_settings((w, h), 5, Estimator::Mis);
    let ours = render_tile(&scene, &s, s.full_frame(), 0..256).unwrap().pixels;
    let n = (w * h) as f64;
    for c in 0..3 {
        let ref_px: Vec<(f64, f64)> =
            reference.rgb.iter().zip(&reference.variance).map(|(m, v)| (m[c] as f64, v[c] as f64)).collect();
        let our_px = channel(&ours, c);
        let ref_mean = ref_px.iter().map(|p| p.0).sum::<f64>() / n;
        let our_mean = our_px.iter().map(|p| p.0).sum::<f64>() / n;
        let rel = (our_mean - ref_mean).abs() / ref_mean;
        eprintln!("channel {c}: image mean {our_mean:.6} vs Mitsuba {ref_mean:.6} ({:+.3}%)", (our_mean / ref_mean - 1.0) * 100.0);
        assert!(rel < 0.005, "channel {c}: image mean {our_mean} vs Mitsuba {ref_mean} ({:.3}%)", rel * 100.0);
        let r = 16;
        for ry in 0..(h as usize / r) {
            for rx in 0..(w as usize / r) {
                let (mo, so) = region_mean(&our_px, w as usize, rx * r, ry * r, r, r);
                let (mr, sr) = region_mean(&ref_px, w as usize, rx * r, ry * r, r, r);
                let sigma = (so * so + sr * sr).sqrt();
                assert!((mo - mr).abs() <= 4.0 * sigma + 1e-9, "channel {c} region ({rx},{ry}): {mo} vs Mitsuba {mr} (σ {sigma})");
            }
        }
    }
}
