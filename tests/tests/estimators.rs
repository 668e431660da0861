//! All four estimators render the same Cornell box; MIS does it with the least variance.
use crate::harness::{channel, independent_settings, region_mean};
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::{Estimator, PixelSums, render_tile};
use tessera_server::bundled;

const SIZE: u32 = 32;

fn render(est: Estimator, spp: u32) -> Vec<PixelSums> {
    let scene = bundled::load("cornell-box").unwrap();
    let s = independent_settings((SIZE, SIZE), 11, est);
    render_tile(&scene, &s, s.full_frame(), 0..spp, &RenderOptions::default()).unwrap().pixels
}

/// Mean over pixels of the per-sample variance (variance of the mean × count), channel-averaged.
fn per_sample_variance(pixels: &[PixelSums]) -> f64 {
    let mut acc = 0.0;
    for p in pixels {
        acc += p.variance_of_mean().iter().sum::<f64>() * p.count as f64 / 3.0;
    }
    acc / pixels.len() as f64
}

#[test]
fn all_estimators_agree_on_the_cornell_box_and_mis_has_the_lowest_variance() {
    let spp = 512;
    let images: Vec<(Estimator, Vec<PixelSums>)> =
        Estimator::ALL.into_iter().map(|e| (e, render(e, spp))).collect();
    let reference = &images.iter().find(|(e, _)| *e == Estimator::Mis).unwrap().1;
    let regions = 4;
    let r = (SIZE / regions) as usize;
    for (est, img) in &images {
        for c in 0..3 {
            let (a, b) = (channel(img, c), channel(reference, c));
            for ry in 0..regions as usize {
                for rx in 0..regions as usize {
                    let (ma, sa) = region_mean(&a, SIZE as usize, rx * r, ry * r, r, r);
                    let (mb, sb) = region_mean(&b, SIZE as usize, rx * r, ry * r, r, r);
                    let sigma = (sa * sa + sb * sb).sqrt();
                    assert!(
                        (ma - mb).abs() <= 4.0 * sigma + 1e-9,
                        "{est:?} channel {c} region ({rx},{ry}): {ma} vs mis {mb} (σ {sigma})"
                    );
                }
            }
        }
    }
    let var = |e: Estimator| per_sample_variance(&images.iter().find(|(x, _)| *x == e).unwrap().1);
    let mis = var(Estimator::Mis);
    for e in [Estimator::Naive, Estimator::Bsdf, Estimator::Light] {
        assert!(mis < var(e), "mis variance {mis} should be below {e:?}'s {}", var(e));
    }
}
