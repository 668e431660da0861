//! Deterministic sample generation for the path tracer.
//!
//! # Contract
//! Every number handed out is a pure function of
//! `(kind, job seed, pixel, sample index, dimension)`. Nothing depends on call
//! history, thread, or worker, so any worker can render any sample range of any
//! pixel and produce bit-identical results. A [`Sampler`] is a cheap value
//! (no tables, no allocation); create one per (pixel, sample) with
//! [`Sampler::start`] and draw from it. A renderer that takes a pixel's samples one
//! after another keeps a [`PixelSeeds`] for the pixel and starts each sample with
//! [`Sampler::for_pixel`]: the same numbers, without hashing the pixel and each
//! dimension's seeds again for every sample.
//!
//! # Dimension layout
//! The dimension counter starts at 0. [`Sampler::get_1d`] consumes one
//! dimension `d`; [`Sampler::get_2d`] consumes the pair `(d, d + 1)` and seeds
//! the whole pair from `d`. The value at a dimension therefore depends on
//! whether it was drawn as 1D or 2D, so the integrator must use a fixed layout
//! (e.g. film 2D at 0, lens 2D at 2, then a fixed block per bounce).
//! `get_1d` at `d` equals `get_2d(..).x` at `d`. The counter wraps at 2^32.
//!
//! # Kinds
//! * [`SamplerKind::Independent`]: a 64-bit integer hash of
//!   (seed, px, py, index, dimension); white noise, the reference.
//! * [`SamplerKind::Sobol`]: Owen-scrambled Sobol after Burley 2020,
//!   "Practical Hash-based Owen Scrambling" (JCGT 9(4)). Each 1D draw uses
//!   Sobol dimension 0, each 2D draw Sobol dimensions (0, 1). Per pixel and
//!   dimension, the sample index is shuffled by a nested uniform (Owen)
//!   scramble and each coordinate is Owen-scrambled with its own seed, using
//!   Vegdahl's improved Laine–Karras hash. Consequences: within a pixel, every
//!   aligned block of 2^m samples (`k*2^m .. (k+1)*2^m`) of any 2D pair is a
//!   (0,m,2)-net and stratified in 1D, while distinct dimensions and pixels
//!   are decorrelated. Sample counts that are powers of two converge best.
//!
//! # Values
//! Both kinds keep the top 24 bits of a 32-bit value, so each number is
//! exactly `k * 2^-24` with `0 <= k < 2^24`: in `[0, ONE_MINUS_EPSILON]`,
//! never 1, and strata boundaries up to 2^-24 are respected exactly.

use glam::Vec2;
use std::cell::Cell;
use std::fmt;
use std::str::FromStr;

mod sobol;
use sobol::{laine_karras, sobol_dim1_of_reversed};

/// Largest f32 below 1 (`1 - 2^-24`): the upper bound of every sample.
pub const ONE_MINUS_EPSILON: f32 = f32::from_bits(0x3f7f_ffff);

/// Which sequence a [`Sampler`] draws from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SamplerKind {
    Independent,
    Sobol,
}

impl SamplerKind {
    pub const ALL: [SamplerKind; 2] = [SamplerKind::Independent, SamplerKind::Sobol];

    /// The lowercase name used in job files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            SamplerKind::Independent => "independent",
            SamplerKind::Sobol => "sobol",
        }
    }
}

impl fmt::Display for SamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// Error from parsing an unknown sampler name; lists the valid names.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown sampler `{0}` (valid: {names})", names = SamplerKind::ALL.map(|k| k.name()).join(", "))]
pub struct UnknownSamplerKind(pub String);

impl FromStr for SamplerKind {
    type Err = UnknownSamplerKind;

    /// Accepts the names from [`SamplerKind::name`], ignoring ASCII case.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        SamplerKind::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownSamplerKind(s.to_owned()))
    }
}

/// A dimension reserved by [`Sampler::defer_1d`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Deferred1d(u32);

/// Random numbers for one (pixel, sample index); see the module docs.
#[derive(Clone, Debug)]
pub struct Sampler<'p> {
    kind: SamplerKind,
    seed: u64,
    pixel_hash: u64,
    sample_index: u32,
    /// `sample_index.reverse_bits()`, the form the Sobol index shuffle starts from.
    index_reversed: u32,
    dimension: u32,
    /// The pixel's memo of per-dimension seeds, when the caller keeps one.
    pixel: Option<&'p PixelSeeds>,
    /// Test-only: every draw is 0 or ONE_MINUS_EPSILON, bit (dimension mod 64) of the pattern.
    #[cfg(test)]
    boundary: Option<u64>,
}

/// What every sample of one pixel shares: the pixel's hash and, filled in as they are first
/// drawn, the Sobol seeds of its first [`MEMO_DIMENSIONS`] dimensions. They are functions of
/// (kind, job seed, pixel, dimension) alone, and a pixel's samples are rendered one after
/// another, so its later samples look them up instead of hashing again (the same bits).
#[derive(Debug)]
pub struct PixelSeeds {
    kind: SamplerKind,
    seed: u64,
    pixel_hash: u64,
    /// Bit d set: `sobol[d]` holds dimension d's seeds.
    known: Cell<u64>,
    sobol: [Cell<[u32; 3]>; MEMO_DIMENSIONS],
}

/// Dimensions whose seeds a [`PixelSeeds`] keeps: ten bounces of the path tracer's layout.
pub const MEMO_DIMENSIONS: usize = 64;

impl PixelSeeds {
    pub fn new(kind: SamplerKind, seed: u64, px: u32, py: u32) -> PixelSeeds {
        PixelSeeds {
            kind,
            seed,
            pixel_hash: pixel_hash(seed, px, py),
            known: Cell::new(0),
            sobol: [const { Cell::new([0; 3]) }; MEMO_DIMENSIONS],
        }
    }

    /// Dimension `dim`'s Sobol seeds (`dim` < [`MEMO_DIMENSIONS`]), hashed on first use.
    fn sobol_seeds(&self, dim: u32) -> [u32; 3] {
        let bit = 1u64 << dim;
        if self.known.get() & bit == 0 {
            self.sobol[dim as usize].set(sobol_seeds(self.pixel_hash, dim, true));
            self.known.set(self.known.get() | bit);
        }
        self.sobol[dim as usize].get()
    }
}

fn pixel_hash(seed: u64, px: u32, py: u32) -> u64 {
    hash2(hash2(PIXEL_SALT, seed), (u64::from(px) << 32) | u64::from(py))
}

/// The seeds of a Sobol draw at `dim`: the index shuffle's, x's and (if wanted) y's. One 64-bit
/// hash per (pixel, dim) supplies the first two; y's is re-hashed so the three are independent.
fn sobol_seeds(pixel_hash: u64, dim: u32, want_y: bool) -> [u32; 3] {
    let h = hash2(pixel_hash, SOBOL_SALT ^ u64::from(dim));
    [h as u32, (h >> 32) as u32, if want_y { mix64(h) as u32 } else { 0 }]
}

impl Sampler<'static> {
    /// A sampler for sample `sample_index` of pixel `(px, py)`, at dimension 0.
    pub fn start(
        kind: SamplerKind,
        seed: u64,
        px: u32,
        py: u32,
        sample_index: u32,
    ) -> Sampler<'static> {
        Sampler::new(kind, seed, pixel_hash(seed, px, py), sample_index, None)
    }
}

impl<'p> Sampler<'p> {
    /// The same sampler as [`Sampler::start`] for the pixel of `pixel`, drawing its seeds from
    /// the pixel's memo.
    pub fn for_pixel(pixel: &'p PixelSeeds, sample_index: u32) -> Sampler<'p> {
        Sampler::new(pixel.kind, pixel.seed, pixel.pixel_hash, sample_index, Some(pixel))
    }

    fn new(
        kind: SamplerKind,
        seed: u64,
        pixel_hash: u64,
        sample_index: u32,
        pixel: Option<&'p PixelSeeds>,
    ) -> Sampler<'p> {
        Sampler {
            kind,
            seed,
            pixel_hash,
            sample_index,
            index_reversed: sample_index.reverse_bits(),
            dimension: 0,
            pixel,
            #[cfg(test)]
            boundary: None,
        }
    }

    /// Test-only: a sampler whose draw at dimension d is ONE_MINUS_EPSILON if bit d mod 64
    /// of `pattern` is set, else 0 — the boundary values, in every dimension.
    #[cfg(test)]
    pub fn boundary(pattern: u64) -> Sampler<'static> {
        Sampler { boundary: Some(pattern), ..Sampler::start(SamplerKind::Independent, 0, 0, 0, 0) }
    }

    #[cfg(test)]
    fn boundary_value(&self, d: u32) -> Option<f32> {
        self.boundary.map(|p| if p >> (d % 64) & 1 == 1 { ONE_MINUS_EPSILON } else { 0.0 })
    }

    /// The next 1D value, in `[0, ONE_MINUS_EPSILON]`; consumes one dimension.
    pub fn get_1d(&mut self) -> f32 {
        let d = self.advance(1);
        self.value_1d(d)
    }

    /// Reserves the next dimension for a 1D value that may not be needed (a lobe choice on a
    /// one-lobe BSDF, a roulette draw on a path roulette cannot stop): the layout, hence every
    /// other draw, is the same whether or not [`Sampler::deferred`] is called, and an unused
    /// value costs nothing.
    pub fn defer_1d(&mut self) -> Deferred1d {
        Deferred1d(self.advance(1))
    }

    /// The value of a reserved dimension: exactly what `get_1d` would have returned there.
    pub fn deferred(&self, d: Deferred1d) -> f32 {
        self.value_1d(d.0)
    }

    fn value_1d(&self, d: u32) -> f32 {
        #[cfg(test)]
        if let Some(v) = self.boundary_value(d) {
            return v;
        }
        match self.kind {
            SamplerKind::Independent => to_unit(self.independent_bits(d)),
            SamplerKind::Sobol => to_unit(self.sobol_bits(d, false).0),
        }
    }

    /// The next 2D value, each coordinate in `[0, ONE_MINUS_EPSILON]`;
    /// consumes two dimensions.
    pub fn get_2d(&mut self) -> Vec2 {
        let d = self.advance(2);
        #[cfg(test)]
        if let (Some(x), Some(y)) = (self.boundary_value(d), self.boundary_value(d.wrapping_add(1)))
        {
            return Vec2::new(x, y);
        }
        let (x, y) = match self.kind {
            SamplerKind::Independent => {
                (self.independent_bits(d), self.independent_bits(d.wrapping_add(1)))
            }
            SamplerKind::Sobol => self.sobol_bits(d, true),
        };
        Vec2::new(to_unit(x), to_unit(y))
    }

    /// The dimension the next draw will start at.
    pub fn dimension(&self) -> u32 {
        self.dimension
    }

    pub fn kind(&self) -> SamplerKind {
        self.kind
    }

    pub fn seed(&self) -> u64 {
        self.seed
    }

    pub fn sample_index(&self) -> u32 {
        self.sample_index
    }

    fn advance(&mut self, count: u32) -> u32 {
        let d = self.dimension;
        self.dimension = d.wrapping_add(count);
        d
    }

    fn independent_bits(&self, dim: u32) -> u32 {
        let word = (u64::from(self.sample_index) << 32) | u64::from(dim);
        (hash2(self.pixel_hash, word) >> 32) as u32
    }

    /// Scrambled Sobol coordinates (fixed point, MSB = 1/2) for the pair
    /// seeded at `dim`; `y` is only computed when asked for.
    #[inline(always)] // want_y is a constant at each call
    fn sobol_bits(&self, dim: u32, want_y: bool) -> (u32, u32) {
        let [shuffle, seed_x, seed_y] = match self.pixel {
            Some(pixel) if (dim as usize) < MEMO_DIMENSIONS => pixel.sobol_seeds(dim),
            _ => sobol_seeds(self.pixel_hash, dim, want_y),
        };
        // owen_scramble(sample_index, shuffle), with the index's reversal hoisted out
        // of the per-draw work (same bits; x86 has no bit-reversal instruction).
        let index_reversed = laine_karras(self.index_reversed, shuffle);
        // owen_scramble(sobol_dim0(index)) reverses index twice; skip both reversals (same bits).
        let x = laine_karras(index_reversed.reverse_bits(), seed_x);
        if !want_y {
            return (x.reverse_bits(), 0);
        }
        // owen_scramble(sobol_dim1(index)), both reversals around the matrix folded into the table.
        let y = laine_karras(sobol_dim1_of_reversed(index_reversed), seed_y);
        // Both final reversals as one of 64 bits: it swaps the halves and reverses each.
        let both = ((u64::from(y) << 32) | u64::from(x)).reverse_bits();
        ((both >> 32) as u32, both as u32)
    }
}

/// The seed of frame `frame` of an animation rendered with job seed `seed`: `seed` itself for
/// frame 0 (a still renders as before), otherwise a hash of both, so consecutive frames get
/// decorrelated noise (the same noise pattern frozen on a moving image reads as a dirty lens).
pub fn frame_seed(seed: u64, frame: u32) -> u64 {
    if frame == 0 { seed } else { hash2(seed ^ FRAME_SALT, u64::from(frame)) }
}

const FRAME_SALT: u64 = 0x4652_414d_4553_4545; // "FRAMESEE"
const PIXEL_SALT: u64 = 0x5445_5353_4552_4131; // "TESSERA1": versions the stream
const SOBOL_SALT: u64 = 0x736f_626f_6c00_0000; // keeps Sobol seeds apart from Independent
const GOLDEN_GAMMA: u64 = 0x9e37_79b9_7f4a_7c15;

/// SplitMix64 finalizer: a bijection with full avalanche.
fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Hash-combine: two finalizer rounds, so structured inputs (counters,
/// coordinates) never leave visible structure in the output; for a fixed `h`
/// it is a bijection of `v`, so distinct inputs never collide.
fn hash2(h: u64, v: u64) -> u64 {
    mix64(h ^ mix64(v.wrapping_add(GOLDEN_GAMMA)))
}

/// Top 24 bits as an exact float: `k * 2^-24 <= ONE_MINUS_EPSILON`.
fn to_unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / 16_777_216.0)
}

#[cfg(test)]
mod tests;
