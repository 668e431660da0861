//! Deterministic sample generation for the path tracer.
//!
//! # Contract
//! Every number handed out is a pure function of
//! `(kind, job seed, pixel, sample index, dimension)`. Nothing depends on call
//! history, thread, or worker, so any worker can render any sample range of any
//! pixel and produce bit-identical results. A [`Sampler`] is a cheap value
//! (no tables, no allocation); create one per (pixel, sample) with
//! [`Sampler::start`] and draw from it.
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
use std::fmt;
use std::str::FromStr;

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
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownSamplerKind(pub String);

impl fmt::Display for UnknownSamplerKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names: Vec<_> = SamplerKind::ALL.iter().map(|k| k.name()).collect();
        write!(
            f,
            "unknown sampler `{}` (valid: {})",
            self.0,
            names.join(", ")
        )
    }
}

impl std::error::Error for UnknownSamplerKind {}

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
pub struct Sampler {
    kind: SamplerKind,
    seed: u64,
    pixel_hash: u64,
    sample_index: u32,
    /// `sample_index.reverse_bits()`, the form the Sobol index shuffle starts from.
    index_reversed: u32,
    dimension: u32,
    /// Test-only: every draw is 0 or ONE_MINUS_EPSILON, bit (dimension mod 64) of the pattern.
    #[cfg(test)]
    boundary: Option<u64>,
}

impl Sampler {
    /// A sampler for sample `sample_index` of pixel `(px, py)`, at dimension 0.
    pub fn start(kind: SamplerKind, seed: u64, px: u32, py: u32, sample_index: u32) -> Sampler {
        let pixel_hash = hash2(
            hash2(PIXEL_SALT, seed),
            (u64::from(px) << 32) | u64::from(py),
        );
        Sampler {
            kind,
            seed,
            pixel_hash,
            sample_index,
            index_reversed: sample_index.reverse_bits(),
            dimension: 0,
            #[cfg(test)]
            boundary: None,
        }
    }

    /// Test-only: a sampler whose draw at dimension d is ONE_MINUS_EPSILON if bit d mod 64
    /// of `pattern` is set, else 0 — the boundary values, in every dimension.
    #[cfg(test)]
    pub fn boundary(pattern: u64) -> Sampler {
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
        if let (Some(x), Some(y)) = (self.boundary_value(d), self.boundary_value(d.wrapping_add(1))) {
            return Vec2::new(x, y);
        }
        let (x, y) = match self.kind {
            SamplerKind::Independent => (
                self.independent_bits(d),
                self.independent_bits(d.wrapping_add(1)),
            ),
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
    fn sobol_bits(&self, dim: u32, want_y: bool) -> (u32, u32) {
        // One 64-bit hash per (pixel, dim) supplies the shuffle seed and the
        // x seed; y's seed is re-hashed so the three are independent.
        let h = hash2(self.pixel_hash, SOBOL_SALT ^ u64::from(dim));
        // owen_scramble(sample_index, seed), with the index's reversal hoisted out
        // of the per-draw work (same bits; x86 has no bit-reversal instruction).
        let index = laine_karras(self.index_reversed, h as u32).reverse_bits();
        // owen_scramble(sobol_dim0(i)) reverses i twice; skip both reversals (same bits).
        let x = laine_karras(index, (h >> 32) as u32).reverse_bits();
        let y = if want_y {
            // owen_scramble(sobol_dim1(index)), its first reversal folded into the table.
            laine_karras(sobol_dim1_reversed(index), mix64(h) as u32).reverse_bits()
        } else {
            0
        };
        (x, y)
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

/// Sobol dimension 0 (van der Corput): the identity generator matrix, i.e.
/// the index with its bits mirrored about the binary point.
#[cfg_attr(not(test), allow(dead_code))] // the generator the tests check; sobol_bits inlines it
fn sobol_dim0(index: u32) -> u32 {
    index.reverse_bits()
}

/// Sobol dimension 1: the generator matrix applied a byte at a time through
/// [`SOBOL_DIM1_BYTES`] (4 lookups instead of a loop over up to 32 bits: this
/// ran in ~25 % of render time, the index being an Owen-scrambled, i.e.
/// random, 32-bit number). Same bits as [`sobol_dim1_by_bits`].
#[cfg_attr(not(test), allow(dead_code))] // the sampler uses the reversed table
fn sobol_dim1(index: u32) -> u32 {
    sobol_dim1_reversed(index).reverse_bits()
}

/// `sobol_dim1(index).reverse_bits()`: bit reversal is linear over GF(2), so the
/// tables hold reversed direction-vector sums and the lookups XOR as before.
fn sobol_dim1_reversed(index: u32) -> u32 {
    let t = &SOBOL_DIM1_BYTES;
    t[0][(index & 0xff) as usize] ^ t[1][(index >> 8 & 0xff) as usize] ^ t[2][(index >> 16 & 0xff) as usize] ^ t[3][(index >> 24) as usize]
}

/// `SOBOL_DIM1_BYTES[k][b]`: the XOR of the direction vectors selected by
/// byte value `b` in byte `k` of the index (the matrix is linear over GF(2),
/// so the four bytes' contributions XOR together), bit-reversed.
const SOBOL_DIM1_BYTES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            t[k][b] = sobol_dim1_by_bits((b as u32) << (8 * k)).reverse_bits();
            b += 1;
        }
        k += 1;
    }
    t
};

/// Sobol dimension 1 via its generator matrix, one direction vector per set
/// bit (builds the table; the reference the tests compare against).
const fn sobol_dim1_by_bits(index: u32) -> u32 {
    let mut bits = index;
    let mut result = 0;
    let mut k = 0;
    while bits != 0 {
        if bits & 1 != 0 {
            result ^= SOBOL_DIM1_DIRECTIONS[k];
        }
        bits >>= 1;
        k += 1;
    }
    result
}

/// Direction vectors of Sobol dimension 1: primitive polynomial x + 1 with
/// m_1 = 1 (Joe–Kuo row `2 1 0 1`). The recurrence m_k = 2m_{k-1} ^ m_{k-1}
/// becomes v_k = v_{k-1} ^ (v_{k-1} >> 1) in 32-bit fixed point (the Pascal
/// matrix mod 2): 0x80000000, 0xc0000000, 0xa0000000, 0xf0000000, ...
const SOBOL_DIM1_DIRECTIONS: [u32; 32] = {
    let mut v = [0u32; 32];
    v[0] = 1 << 31;
    let mut k = 1;
    while k < 32 {
        v[k] = v[k - 1] ^ (v[k - 1] >> 1);
        k += 1;
    }
    v
};

/// Base-2 Owen scramble of a fixed-point value (MSB = first digit), i.e.
/// Burley's `nested_uniform_scramble`: each bit is flipped by a hash of the
/// bits above it. Bit reversal turns that into "depends only on lower bits",
/// which the multiply-xor hash guarantees. The hash is Vegdahl's improved
/// Laine–Karras permutation (psychopath.io, 2021); its constants are
/// 0x3d20adea, 0x05526c56, 0x53a22864.
#[cfg_attr(not(test), allow(dead_code))] // the definition; sobol_bits folds its reversals
fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The hash of [`owen_scramble`] in the bit-reversed domain.
fn laine_karras(mut v: u32, seed: u32) -> u32 {
    v ^= v.wrapping_mul(0x3d20_adea);
    v = v.wrapping_add(seed);
    v = v.wrapping_mul((seed >> 16) | 1);
    v ^= v.wrapping_mul(0x0552_6c56);
    v ^= v.wrapping_mul(0x53a2_2864);
    v
}

#[cfg(test)]
#[path = "sampler_tests.rs"]
mod tests;
