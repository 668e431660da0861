//! Any bytes → `PartialSums::decode`: Ok only for bodies that re-encode to themselves and keep
//! the decoder's promises; otherwise a reason.
#![no_main]
use tessera_proto::PartialSums;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    match PartialSums::decode(data) {
        Ok(p) => {
            assert_eq!(p.encode(), data);
            let counted: u64 = p.pixels.iter().map(|q| q.count).sum();
            assert_eq!(counted + p.dropped, (p.samples[1] - p.samples[0]) as u64 * p.pixels.len() as u64);
            assert!(p.pixels.iter().all(|q| q.sum.iter().chain(&q.sum_sq).all(|v| v.is_finite())));
        }
        Err(e) => assert!(!e.0.is_empty()),
    }
});
