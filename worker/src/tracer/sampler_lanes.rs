//! Eight 2D draws at once, each exactly what its own [`Sampler::get_2d`] returns.
//!
//! The first piece of a lockstep integrator (several paths advanced together, issue #9): the
//! Sobol draw's work is integer hashing, table lookups and bit reversals, which one path at a
//! time leaves to scalar instructions. Here each step runs over eight lanes — a lane is one
//! sampler, with its own pixel, sample index and dimension — written as plain loops over
//! arrays, which the compiler turns into vector instructions. On x86-64 a copy compiled for
//! AVX2 (eight 32-bit lanes, a lane-wise 32-bit multiply, byte shuffles for the reversals) is
//! chosen at run time when the CPU has it; the baseline (SSE2) copy is the fallback. Both
//! compute the same integer operations, so every lane's value has the same bits as the scalar
//! draw's on any CPU (checked in the tests, both copies).
//!
//! A draw is a chain of dependent multiplies (three Laine–Karras hashes, the y hash waiting on
//! table lookups), and a vector multiply takes about three times as long as a scalar one; eight
//! lanes of one draw mostly wait on that chain. [`get_2d_x2`] therefore runs a lane's two draws
//! as sixteen slots whose chains overlap. Measured on 2026-12-03 (`cargo bench -p
//! tessera-worker --bench kernels -- sampler/sobol_`, 64 draws from seeds a pixel has already
//! hashed, Xeon with AVX-512): scalar 632 ns, [`get_2d`] 539 ns (1.17×), [`get_2d_x2`] 377 ns
//! (1.68×), its baseline copy 560 ns (1.13×). Nothing renders through this module yet.
use super::sobol::{laine_karras, sobol_dim1_of_reversed};
use super::{MEMO_DIMENSIONS, Sampler, SamplerKind, sobol_seeds, to_unit};
use glam::Vec2;

/// Samplers drawn from together.
pub const LANES: usize = 8;

/// `samplers[i].get_2d()` for every lane, computed eight at a time when every lane draws
/// Sobol points (otherwise one lane after another: the independent sampler is the reference,
/// not a kernel to make fast).
pub fn get_2d(samplers: &mut [Sampler<'_>; LANES]) -> [Vec2; LANES] {
    let [draw] = draws::<1, LANES>(samplers, Copy::Fastest);
    draw
}

/// Two [`get_2d`] in a row for every lane (`[first, second]`), computed sixteen at a time: the
/// two draws' hash chains are independent, so they overlap instead of waiting on each other.
pub fn get_2d_x2(samplers: &mut [Sampler<'_>; LANES]) -> [[Vec2; LANES]; 2] {
    draws::<2, { 2 * LANES }>(samplers, Copy::Fastest)
}

/// [`get_2d_x2`] by the baseline copy whatever the CPU (what a CPU without AVX2 runs; for
/// benchmarks).
pub fn get_2d_x2_baseline(samplers: &mut [Sampler<'_>; LANES]) -> [[Vec2; LANES]; 2] {
    draws::<2, { 2 * LANES }>(samplers, Copy::Baseline)
}

/// Which compiled copy of the vector code runs.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Copy {
    /// AVX2 where the CPU has it, else the baseline.
    Fastest,
    Baseline,
}

/// `K` consecutive 2D draws of every lane, as `N = K·LANES` slots (slot `k·LANES + lane`).
#[inline(always)]
fn draws<const K: usize, const N: usize>(samplers: &mut [Sampler<'_>; LANES], copy: Copy) -> [[Vec2; LANES]; K] {
    const { assert!(N == K * LANES) };
    if !samplers.iter().all(|s| s.kind == SamplerKind::Sobol && s.vector_draws_allowed()) {
        let mut out = [[Vec2::ZERO; LANES]; K];
        for (lane, s) in samplers.iter_mut().enumerate() {
            for draw in out.iter_mut() {
                draw[lane] = s.get_2d();
            }
        }
        return out;
    }
    let mut seeds = SobolSeeds::<N>::default();
    for (lane, s) in samplers.iter_mut().enumerate() {
        for k in 0..K {
            let (slot, d) = (k * LANES + lane, s.advance(2));
            let [shuffle, x, y] = match s.pixel {
                Some(pixel) if (d as usize) < MEMO_DIMENSIONS => pixel.sobol_seeds(d),
                _ => sobol_seeds(s.pixel_hash, d, true),
            };
            (seeds.shuffle[slot], seeds.x[slot], seeds.y[slot], seeds.index_reversed[slot]) = (shuffle, x, y, s.index_reversed);
        }
    }
    let [x, y] = sobol_2d(&seeds, copy);
    std::array::from_fn(|k| std::array::from_fn(|lane| Vec2::new(to_unit(x[k * LANES + lane]), to_unit(y[k * LANES + lane]))))
}

/// Each slot's three Sobol seeds (index shuffle, x scramble, y scramble) and sample index
/// (bit-reversed), slot by slot.
#[derive(Clone, Copy, Debug)]
struct SobolSeeds<const N: usize> {
    shuffle: [u32; N],
    x: [u32; N],
    y: [u32; N],
    index_reversed: [u32; N],
}

impl<const N: usize> Default for SobolSeeds<N> {
    fn default() -> Self {
        SobolSeeds { shuffle: [0; N], x: [0; N], y: [0; N], index_reversed: [0; N] }
    }
}

/// The scrambled Sobol pair (fixed point) of every slot, by copy `copy`.
fn sobol_2d<const N: usize>(seeds: &SobolSeeds<N>, copy: Copy) -> [[u32; N]; 2] {
    #[cfg(target_arch = "x86_64")]
    if copy == Copy::Fastest && std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2, checked on the line above.
        return unsafe { sobol_2d_avx2(seeds) };
    }
    let _ = copy;
    sobol_2d_lanes(seeds)
}

/// [`sobol_2d_lanes`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn sobol_2d_avx2<const N: usize>(seeds: &SobolSeeds<N>) -> [[u32; N]; 2] {
    sobol_2d_lanes(seeds)
}

/// `Sampler::sobol_bits(d, true)` lane by lane, one step over all lanes at a time so each step
/// is a vector instruction or a few.
#[inline(always)]
fn sobol_2d_lanes<const N: usize>(seeds: &SobolSeeds<N>) -> [[u32; N]; 2] {
    let mut shuffled = [0u32; N];
    for lane in 0..N {
        shuffled[lane] = laine_karras(seeds.index_reversed[lane], seeds.shuffle[lane]);
    }
    let (mut x, mut y) = ([0u32; N], [0u32; N]);
    for lane in 0..N {
        x[lane] = laine_karras(shuffled[lane].reverse_bits(), seeds.x[lane]).reverse_bits();
    }
    // The table lookups are gathers; kept apart so the hash below stays one vector loop.
    for lane in 0..N {
        y[lane] = sobol_dim1_of_reversed(shuffled[lane]);
    }
    for lane in 0..N {
        y[lane] = laine_karras(y[lane], seeds.y[lane]).reverse_bits();
    }
    [x, y]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracer::sampler::PixelSeeds;

    /// Lanes at scattered pixels, sample indices and dimensions (below and beyond the pixel
    /// memo, with and without one), against the same samplers drawing alone.
    #[test]
    fn every_lane_draws_the_bits_its_sampler_draws_alone() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let pixels: Vec<PixelSeeds> = (0..LANES as u32).map(|i| PixelSeeds::new(SamplerKind::Sobol, 42, i * 37, 5 + i)).collect();
        for round in 0..2000 {
            let mut lanes: [Sampler; LANES] = std::array::from_fn(|lane| {
                let index = next() as u32 >> (next() % 32);
                let mut s = if round % 3 == 0 {
                    Sampler::start(SamplerKind::Sobol, 42, lane as u32 * 37, 5 + lane as u32, index)
                } else {
                    Sampler::for_pixel(&pixels[lane], index)
                };
                s.dimension = (next() % 80) as u32 & !1;
                s
            });
            let mut alone = lanes.clone();
            let got = if round % 2 == 0 { vec![get_2d(&mut lanes)] } else { get_2d_x2(&mut lanes).to_vec() };
            for (k, draw) in got.iter().enumerate() {
                for lane in 0..LANES {
                    let want = alone[lane].get_2d();
                    assert_eq!(draw[lane].to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "round {round} draw {k} lane {lane}");
                }
            }
            for lane in 0..LANES {
                assert_eq!(lanes[lane].dimension(), alone[lane].dimension());
            }
        }
    }

    /// The baseline copy and the AVX2 copy (where the CPU has it) agree on every lane.
    #[test]
    fn both_copies_agree() {
        let mut v = 0x9e37_79b9u32;
        let mut next = move || {
            v ^= v << 13;
            v ^= v >> 17;
            v ^= v << 5;
            v
        };
        for _ in 0..20_000 {
            let mut slot = || -> [u32; 2 * LANES] { std::array::from_fn(|_| next()) };
            let seeds = SobolSeeds { shuffle: slot(), x: slot(), y: slot(), index_reversed: slot() };
            assert_eq!(sobol_2d(&seeds, Copy::Fastest), sobol_2d(&seeds, Copy::Baseline));
        }
    }

    #[test]
    fn independent_lanes_fall_back_to_each_sampler() {
        let mut lanes: [Sampler; LANES] = std::array::from_fn(|lane| Sampler::start(SamplerKind::Independent, 3, lane as u32, 1, 9));
        let mut alone = lanes.clone();
        let [first, second] = get_2d_x2(&mut lanes);
        for lane in 0..LANES {
            assert_eq!([first[lane], second[lane]], [alone[lane].get_2d(), alone[lane].get_2d()]);
        }
    }
}
