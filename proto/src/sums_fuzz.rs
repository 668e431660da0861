//! Fuzzing `PartialSums::decode` with proptest: valid encodings mutated (bit flips, truncation,
//! splices, header fields and f64s overwritten with edge values). Every mutant decodes or is
//! refused with a reason; one that decodes re-encodes to the same bytes and keeps the decoder's
//! promises (finite sums, counted + dropped = the unit's samples). Fixed seed, a second or so.
use super::sums::*;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

#[derive(Clone, Debug)]
enum Mutation {
    Flip(Index, u8),
    Truncate(Index),
    Extend(Vec<u8>),
    Splice(Index, Index, usize),
    U32(Index, u32),
    F64(Index, f64),
}

const EDGE_F64: &[f64] =
    &[f64::NAN, f64::INFINITY, f64::NEG_INFINITY, -0.0, -1.0, f64::MAX, f64::MIN_POSITIVE, 5e-324];
const EDGE_U32: &[u32] =
    &[0, 1, 2, 3, 4, 7, 8, 15, 16, 64, 0x7fff_ffff, 0x8000_0000, u32::MAX - 1, u32::MAX];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<Index>(), 0u8..8).prop_map(|(i, b)| Mutation::Flip(i, b)),
        any::<Index>().prop_map(Mutation::Truncate),
        prop::collection::vec(any::<u8>(), 1..80).prop_map(Mutation::Extend),
        (any::<Index>(), any::<Index>(), 1usize..72)
            .prop_map(|(a, b, n)| Mutation::Splice(a, b, n)),
        // Header words (tile, samples, dropped) are u32-aligned: aim there most.
        (any::<Index>(), prop::sample::select(EDGE_U32)).prop_map(|(i, v)| Mutation::U32(i, v)),
        (any::<Index>(), prop::sample::select(EDGE_F64)).prop_map(|(i, v)| Mutation::F64(i, v)),
    ]
}

fn apply(b: &mut Vec<u8>, m: &Mutation) {
    let n = b.len();
    match m {
        _ if n < 8 => {}
        Mutation::Flip(i, bit) => b[i.index(n)] ^= 1 << bit,
        Mutation::Truncate(i) => b.truncate(i.index(n)),
        Mutation::Extend(extra) => b.extend_from_slice(extra),
        Mutation::Splice(from, to, len) => {
            let (from, to) = (from.index(n), to.index(n));
            let len = (*len).min(n - from).min(n - to);
            b.copy_within(from..from + len, to);
        }
        Mutation::U32(i, v) => {
            let at = i.index(n / 4) * 4;
            b[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        Mutation::F64(i, v) => {
            let at = i.index(n / 8) * 8;
            b[at..at + 8].copy_from_slice(&v.to_le_bytes());
        }
    }
}

fn valid(w: u32, h: u32, samples: [u32; 2], dropped: u64) -> PartialSums {
    let per = (samples[1] - samples[0]) as u64;
    let mut pixels = vec![
        WirePixel {
            sum: [0.5, 1.0, 2.0],
            sum_sq: [0.25, 1.0, 4.0],
            sum_lum_sq: 1.0,
            count: per
        };
        (w * h) as usize
    ];
    pixels[0].count -= dropped;
    PartialSums {
        tile: TileRect { x0: 64, y0: 8, w, h },
        samples,
        dropped,
        max_weight: 3.5,
        pixels,
    }
}

#[test]
fn mutated_results_decode_or_are_refused_with_a_reason() {
    let seeds = [valid(1, 1, [0, 1], 0), valid(3, 2, [16, 20], 1), valid(8, 8, [4, 8], 2)];
    let config = Config { cases: 100_000, failure_persistence: None, ..Config::default() };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    let strategy = (0..seeds.len(), prop::collection::vec(mutation(), 1..4));
    let (decoded, t0) = (std::cell::Cell::new(0u32), std::time::Instant::now());
    let result = runner.run(&strategy, |(s, muts)| {
        let mut bytes = seeds[s].encode();
        muts.iter().for_each(|m| apply(&mut bytes, m));
        match std::panic::catch_unwind(|| PartialSums::decode(&bytes)) {
            Err(_) => return Err(TestCaseError::fail(format!("decode panicked on {bytes:02x?}"))),
            Ok(Err(e)) => prop_assert!(!e.0.is_empty()),
            Ok(Ok(p)) => {
                decoded.set(decoded.get() + 1);
                prop_assert_eq!(p.encode(), bytes.clone(), "decode ∘ encode is the identity");
                let finite = p.pixels.iter().all(|q| {
                    q.sum.iter().chain(&q.sum_sq).chain([&q.sum_lum_sq]).all(|v| v.is_finite())
                });
                prop_assert!(finite && p.max_weight.is_finite());
                let counted: u64 = p.pixels.iter().map(|q| q.count).sum();
                prop_assert_eq!(
                    counted + p.dropped,
                    (p.samples[1] - p.samples[0]) as u64 * p.pixels.len() as u64
                );
            }
        }
        Ok(())
    });
    result.unwrap();
    eprintln!("100000 mutants in {:.2?}, {} still decoded", t0.elapsed(), decoded.get());
}
