//! Cases 11–15: boundary random numbers, accumulation, containment, roulette, merging.
use crate::tracer::RenderOptions;
use crate::tracer::bsdf::{Pbr, Phong};
use crate::tracer::chi2::Rng;
use crate::tracer::film::{PixelSums, TileSums};
use crate::tracer::integrator::tests::{assert_within_4_sigma, furnace, pooled, settings};
use crate::tracer::integrator::{Estimator, Integrator, PathSettings, Roulette};
use crate::tracer::light::Light;
use crate::tracer::material::{Material, MaterialModel};
use crate::tracer::render::render_tile;
use crate::tracer::sampler::{Sampler, SamplerKind};
use crate::tracer::scene::Scene;
use glam::Vec3;

/// The furnace with every material kind on its walls and every punctual light kind inside.
fn everything_furnace() -> Scene {
    let base = furnace(0.6, 0.2);
    let models = [
        MaterialModel::Phong(Phong::new(Vec3::splat(0.3), Vec3::splat(0.7), 1e6).unwrap()),
        MaterialModel::Pbr(Pbr::new(Vec3::ONE, 1.0, 0.0)),
        MaterialModel::Pbr(Pbr::new(Vec3::splat(0.5), 0.0, 0.03)),
    ];
    let mut materials = base.materials.clone();
    materials.extend(models.map(|model| Material { model, ..base.materials[0].clone() }));
    let mut mesh = base.mesh.clone();
    mesh.material.iter_mut().enumerate().for_each(|(i, m)| *m = (i % 4) as u32);
    let punctual = vec![
        Light::Point { position: Vec3::new(0.2, 0.3, -0.1), intensity: Vec3::ONE },
        Light::Spot {
            position: Vec3::ZERO,
            axis: Vec3::NEG_Y,
            intensity: Vec3::ONE,
            cos_inner: 0.9,
            cos_outer: 0.8,
        },
        Light::Directional { dir: Vec3::new(0.3, -1.0, 0.2).normalize(), irradiance: Vec3::ONE },
    ];
    Scene::new(mesh, materials, vec![], base.cameras.clone(), punctual)
}

/// Case 11. Paths whose every random number is 0 or 1 − 2⁻²⁴ (all zeros, all ones, and
/// alternating and pseudo-random patterns over the dimensions) end with finite radiance or
/// a clean rejection (NaN radiance, which rendering drops and counts), never an infinite
/// weight, for every estimator and every material and light kind. (All ones make the naive
/// estimator reflect forever with weight ×2.4 per bounce: that path is rejected.) Catches warps that reach
/// 1 − cos = 0 exactly (a 0/0 pdf) or sqrt of a slightly negative number.
#[test]
fn boundary_random_numbers_in_every_dimension_give_finite_paths() {
    let scene = everything_furnace();
    let camera = scene.cameras[0].raster(8, 8);
    let mut patterns = vec![0u64, u64::MAX, 0x5555_5555_5555_5555, 0xAAAA_AAAA_AAAA_AAAA];
    let mut rng = Rng::new(111);
    patterns.extend((0..60).map(|_| (rng.next_u32() as u64) << 32 | rng.next_u32() as u64));
    let mut rejected = 0;
    for est in Estimator::ALL {
        let integrator = Integrator::new(
            &scene,
            Vec3::splat(0.5),
            PathSettings { estimator: est, ..PathSettings::default() },
        );
        for &pattern in &patterns {
            for (px, py) in [(0, 0), (7, 7), (3, 5)] {
                let mut sampler = Sampler::boundary(pattern);
                let ray = camera.ray(px, py, sampler.get_2d());
                let s = integrator.li(ray, &mut sampler);
                assert!(s.max_weight.is_finite(), "{est:?} pattern {pattern:x}: {s:?}");
                assert!(
                    s.radiance.is_finite() || s.radiance.is_nan(),
                    "{est:?} pattern {pattern:x}: {s:?}"
                );
                rejected += !s.radiance.is_finite() as u32;
            }
        }
    }
    assert!(rejected <= 12, "rejections must stay the exception ({rejected})");
}

/// Case 12. 10⁸ samples in 10³ batches of 10⁵, each batch summed in its own `PixelSums` and
/// the batches merged: the mean is exact to 1e-9. The same stream summed in f32 is off by
/// far more (asserted, so the test shows what it guards against).
#[test]
fn hundred_million_samples_in_a_thousand_batches_keep_the_mean_to_1e_minus9() {
    let values: [f32; 7] = [0.1, 0.101, 0.37, 1.7, 0.003, 12.5, 0.25];
    let (batches, per_batch) = (1000u64, 100_000u64);
    let (mut total, mut f32_total, mut counts) = (PixelSums::default(), 0.0f32, [0u64; 7]);
    for b in 0..batches {
        let mut batch = PixelSums::default();
        for i in b * per_batch..(b + 1) * per_batch {
            let k = (i * 2_654_435_761 % 7) as usize;
            counts[k] += 1;
            batch.add_sample(Vec3::splat(values[k]));
            f32_total += values[k];
        }
        total.merge(&batch);
    }
    let n = (batches * per_batch) as f64;
    assert_eq!(total.count as f64, n);
    // Exact: every count·value product is exact in f64 (24 + 27 bits), and 7 terms round once each.
    let exact = (0..7).map(|k| counts[k] as f64 * values[k] as f64).sum::<f64>() / n;
    let mean = total.mean()[0];
    assert!((mean - exact).abs() <= 1e-9 * exact, "f64 sums: {mean} vs {exact}");
    let f32_mean = f32_total as f64 / n;
    assert!(
        (f32_mean - exact).abs() > 1e-4 * exact,
        "f32 sums should have drifted: {f32_mean} vs {exact}"
    );
}

/// Case 13 (tracer side; the job status and EXR side is the server's `tests_numerics`).
/// A speck of NaN emission, then one of infinite emission: the samples they poison are
/// dropped and counted (Σ count + dropped = samples rendered), and every pixel sum stays
/// finite. Catches summing before checking (one NaN makes the pixel, then the image, NaN).
#[test]
fn non_finite_samples_are_dropped_counted_and_contained() {
    for poison in [f32::NAN, f32::INFINITY] {
        let base = furnace(0.5, 0.1);
        let mut mesh = base.mesh.clone();
        // A small triangle floating in the middle of the camera's view, facing the camera.
        let eye = Vec3::new(0.1, 0.2, 0.3);
        let ahead = eye + (Vec3::new(1.0, 0.5, -2.0) - eye).normalize() * 0.5;
        mesh.push_flat(
            [ahead, ahead + Vec3::new(0.0, 0.01, 0.0), ahead + Vec3::new(0.01, 0.0, 0.0)],
            1,
        );
        let mut bad = base.materials[0].clone();
        bad.emission = Vec3::new(0.1, poison, 0.1);
        bad.double_sided = true;
        let scene = Scene::new(
            mesh,
            vec![base.materials[0].clone(), bad],
            vec![],
            base.cameras.clone(),
            vec![],
        );
        let s = settings(Estimator::Mis, Roulette::default(), 16, Vec3::ZERO);
        let spp = 16;
        let sums =
            render_tile(&scene, &s, s.full_frame(), 0..spp, &RenderOptions::default()).unwrap();
        let counted: u64 = sums.pixels.iter().map(|p| p.count).sum();
        assert!(sums.dropped > 0, "{poison}: the poisoned triangle must be hit");
        assert!(
            counted > sums.dropped,
            "{poison}: most samples survive ({} dropped)",
            sums.dropped
        );
        assert_eq!(counted + sums.dropped, 16 * 16 * spp as u64);
        assert!(sums.pixels.iter().all(|p| p.sum.iter().chain(&p.sum_sq).all(|v| v.is_finite())));
        assert!(sums.max_weight.is_finite());
    }
}

/// Case 14. A furnace of albedo 0.95 (paths of ~20 bounces): roulette on (both kinds) and off
/// give the same mean within 3σ of the difference, all within 4σ of Le/(1 − ρ), and the
/// reported largest sample weight stays ≤ 1. Catches roulette that survives with a fixed
/// probability q whatever the throughput: unbiased, but weights grow as (ρ/q)^depth.
#[test]
fn roulette_on_and_off_agree_at_albedo_095_and_weights_stay_bounded() {
    let (rho, le) = (0.95, 0.05);
    let scene = furnace(rho, le);
    let run = |rr| {
        let s = settings(Estimator::Mis, rr, 8, Vec3::ZERO);
        let sums =
            render_tile(&scene, &s, s.full_frame(), 0..256, &RenderOptions::default()).unwrap();
        (pooled(&sums.pixels), sums.max_weight)
    };
    let (off, w_off) = run(Roulette::Off);
    assert_within_4_sigma("roulette off", off, (le / (1.0 - rho)) as f64);
    assert!(w_off <= 1.0, "without roulette the furnace's weights are ρ^k ≤ 1: {w_off}");
    for rr in [
        Roulette::default(),
        Roulette::Throughput { min_depth: 1 },
        Roulette::Threshold { threshold: 0.5, p: 0.5 },
    ] {
        let (on, w_on) = run(rr);
        let sigma = off.1.hypot(on.1);
        assert!(
            (on.0 - off.0).abs() <= 3.0 * sigma,
            "{rr:?}: {} vs off {} (σ {sigma})",
            on.0,
            off.0
        );
        assert!(w_on <= 1.0 + 1e-6 && w_on > 0.0, "{rr:?}: largest sample weight {w_on}");
    }
}

/// Case 15. Sample range 0..96 rendered in one pass equals the same range split in batches of
/// 8 merged in a shuffled order, to f64 rounding; and the batches' sample sequences are
/// disjoint (no two samples of a pixel share their first random numbers). Catches a worker
/// that numbers samples from 0 within each batch (every batch would repeat the first).
#[test]
fn shuffled_batches_merge_to_one_pass_with_disjoint_samples() {
    let scene = furnace(0.6, 0.2);
    let s = settings(Estimator::Mis, Roulette::default(), 6, Vec3::ZERO);
    let whole = render_tile(&scene, &s, s.full_frame(), 0..96, &RenderOptions::default()).unwrap();
    let mut order: Vec<u32> = (0..12).collect();
    let mut rng = Rng::new(115);
    for i in (1..order.len()).rev() {
        order.swap(i, rng.next_u32() as usize % (i + 1));
    }
    assert_ne!(order, (0..12).collect::<Vec<_>>());
    let mut merged = TileSums::new(s.full_frame());
    let mut batch_sums = Vec::new();
    for &b in &order {
        let part =
            render_tile(&scene, &s, s.full_frame(), b * 8..(b + 1) * 8, &RenderOptions::default())
                .unwrap();
        merged.merge(&part).unwrap();
        batch_sums.push(part.pixels[0].sum);
    }
    for (a, b) in whole.pixels.iter().zip(&merged.pixels) {
        assert_eq!(a.count, b.count);
        for c in 0..3 {
            assert!(
                (a.sum[c] - b.sum[c]).abs() <= 1e-12 * a.sum[c].abs(),
                "{} vs {}",
                a.sum[c],
                b.sum[c]
            );
            assert!((a.sum_sq[c] - b.sum_sq[c]).abs() <= 1e-12 * a.sum_sq[c].abs());
        }
    }
    batch_sums.sort_by(|a, b| a[0].total_cmp(&b[0]));
    batch_sums.dedup();
    assert_eq!(batch_sums.len(), 12, "two batches rendered the same samples");
    for kind in SamplerKind::ALL {
        let mut firsts: Vec<(u32, u32)> = (0..96)
            .map(|i| {
                let mut sampler = Sampler::start(kind, s.seed, 2, 3, i);
                let u = sampler.get_2d();
                (u.x.to_bits(), u.y.to_bits())
            })
            .collect();
        firsts.sort_unstable();
        firsts.dedup();
        assert_eq!(firsts.len(), 96, "{kind:?}: repeated samples across batches");
    }
}
