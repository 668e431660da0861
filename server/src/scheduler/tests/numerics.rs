//! Issue #5 at the coordinator: merging (case 15) and accumulation (case 12). The worker's
//! `tracer/numerics/accumulation.rs` checks the same properties inside one unit; these check the
//! scheduler's merge of many units, which is what the EXR is made from.
use super::super::tests::{config, drain};
use super::super::*;
use tessera_proto::{Lease, PartialSums, WirePixel};

/// A unit's sums with values of wildly different magnitudes (1e-6 … 1e6, pseudo-random per
/// pixel and batch), so f64 addition in a different order gives different bits.
fn awkward_sums(g: &Lease) -> PartialSums {
    let n = (g.samples[1] - g.samples[0]) as u64;
    let pixels = (0..g.tile.pixel_count() as u64)
        .map(|i| {
            let h = (i + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15)
                ^ (g.samples[0] as u64 + 7).wrapping_mul(0xD1B5_4A32_D192_ED03)
                ^ (g.tile.x0 as u64 * 31 + g.tile.y0 as u64);
            let v =
                10f64.powi((h % 13) as i32 - 6) * (1.0 + (h >> 40) as f64 / (1u64 << 24) as f64);
            WirePixel {
                sum: [v * n as f64, v, 0.1 * v],
                sum_sq: [v * v * n as f64; 3],
                sum_lum_sq: v * v,
                count: n,
            }
        })
        .collect();
    PartialSums { tile: g.tile, samples: g.samples, dropped: 0, max_weight: 1.0, pixels }
}

/// The job's merged frame as bits, after completing `order` of its leases.
fn merged_bits(order: &[usize]) -> (Vec<[u64; 7]>, Vec<Lease>) {
    let mut s = Scheduler::new(1000);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 32, 0)); // 10×6 in 4-pixel tiles, 8 batches of 4 samples: 48 units
    let grants = drain(&mut s, &w, 0);
    for &k in order {
        assert!(s.complete(&grants[k].lease_id, awkward_sums(&grants[k]), 1).is_ok());
    }
    let job = s.job("j").unwrap();
    assert_eq!(job.state, JobState::Done);
    let bits = job
        .frame_sums(0)
        .iter()
        .map(|p| {
            [p.sum[0], p.sum[1], p.sum[2], p.sum_sq[0], p.sum_sq[1], p.sum_sq[2], p.sum_lum_sq]
                .map(f64::to_bits)
        })
        .collect();
    (bits, grants)
}

/// A fixed-seed Fisher–Yates shuffle (xorshift64*).
fn shuffled(n: usize, seed: u64) -> Vec<usize> {
    let mut v: Vec<usize> = (0..n).collect();
    let mut x = seed;
    for i in (1..n).rev() {
        x ^= x >> 12;
        x ^= x << 25;
        x ^= x >> 27;
        v.swap(i, (x.wrapping_mul(0x2545_F491_4F6C_DD1D) % (i as u64 + 1)) as usize);
    }
    v
}

#[test]
fn shuffled_arrival_merges_to_the_same_bits_as_in_order_arrival() {
    let (in_order, grants) = merged_bits(&(0..48).collect::<Vec<_>>());
    for seed in [1, 2, 3, 0xDEAD_BEEF] {
        let order = shuffled(grants.len(), seed);
        assert_ne!(order, (0..48).collect::<Vec<_>>());
        assert_eq!(merged_bits(&order).0, in_order, "seed {seed}: arrival order changed the bits");
    }
    // The test can fail: adding the same batches in arrival order instead of batch order gives
    // other bits in some pixel, so a scheduler that merged on arrival would be caught.
    let naive_sum0 = |order: &[usize]| {
        let mut acc = std::collections::BTreeMap::<(u32, u32, usize), f64>::new();
        for &k in order {
            for (i, p) in awkward_sums(&grants[k]).pixels.iter().enumerate() {
                *acc.entry((grants[k].tile.x0, grants[k].tile.y0, i)).or_default() += p.sum[0];
            }
        }
        acc.into_values().map(f64::to_bits).collect::<Vec<_>>()
    };
    let batch_order: Vec<usize> = (0..48).collect();
    assert_ne!(
        naive_sum0(&shuffled(48, 1)),
        naive_sum0(&batch_order),
        "the awkward values must be order-sensitive"
    );
}

#[test]
fn batches_cover_disjoint_sample_ranges() {
    // Random numbers are addressed by sample index, so disjoint indices are disjoint sequences.
    let mut s = Scheduler::new(1000);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 30, 0)); // 8 batches of 4, the last one clipped to 2
    let mut seen = std::collections::HashSet::new();
    for g in drain(&mut s, &w, 0) {
        for i in g.samples[0]..g.samples[1] {
            assert!(
                seen.insert((g.tile.x0, g.tile.y0, i)),
                "sample {i} of tile {:?} issued twice",
                g.tile
            );
        }
    }
    assert_eq!(seen.len(), 6 * 30, "every sample index of every tile, once");
}

/// 1e8 samples of one pixel in 1e3 batches of 1e5. Sample values are multiples of 2⁻¹⁰ below
/// 1, so every batch sum and the exact total are integers × 2⁻¹⁰ (exact in u64 arithmetic).
#[test]
fn a_hundred_million_samples_in_a_thousand_batches_keep_the_mean_to_1e_9() {
    const BATCHES: u32 = 1000;
    const PER_BATCH: u32 = 100_000;
    let mut cfg = config("big", BATCHES * PER_BATCH, 0);
    (cfg.params.width, cfg.params.height, cfg.tile_size, cfg.batch_spp) = (1, 1, 8, PER_BATCH);
    let mut s = Scheduler::new(1000);
    let w = s.register_worker("a", 2, 0);
    s.submit(cfg);
    let grants = drain(&mut s, &w, 0);
    assert_eq!(grants.len(), BATCHES as usize);
    // Batch b's samples are (b·7919 + i) mod 1000 + 1, in units of 2⁻¹⁰, for i in 0..1e5.
    let batch_units =
        |b: u64| -> u64 { (0..PER_BATCH as u64).map(|i| (b * 7919 + i) % 1000 + 1).sum() };
    let unit = 2f64.powi(-10);
    let (mut exact_units, mut f32_total) = (0u64, 0f32);
    for (b, g) in grants.iter().enumerate() {
        let units = batch_units(b as u64);
        exact_units += units;
        let sum = units as f64 * unit;
        f32_total += sum as f32;
        let p =
            WirePixel { sum: [sum; 3], sum_sq: [sum; 3], sum_lum_sq: sum, count: PER_BATCH as u64 };
        let sums = PartialSums {
            tile: g.tile,
            samples: g.samples,
            dropped: 0,
            max_weight: 1.0,
            pixels: vec![p],
        };
        assert!(s.complete(&g.lease_id, sums, 1).unwrap().merged);
    }
    let merged = s.job("big").unwrap().frame_sums(0)[0];
    assert_eq!(merged.count, 100_000_000);
    let exact = exact_units as f64 * unit / 1e8;
    let mean = merged.sum[0] / merged.count as f64;
    assert!(((mean - exact) / exact).abs() <= 1e-9, "mean {mean} vs exact {exact}");
    // f32 accumulation of the same batch sums fails the bound: the test can tell.
    let f32_mean = f32_total as f64 / 1e8;
    assert!(((f32_mean - exact) / exact).abs() > 1e-9, "f32 mean {f32_mean} vs {exact}");
    eprintln!(
        "mean {mean:.15} exact {exact:.15} (f64 rel. err {:.1e}, f32 {:.1e})",
        ((mean - exact) / exact).abs(),
        ((f32_mean - exact) / exact).abs()
    );
}
