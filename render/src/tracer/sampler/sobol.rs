//! Owen-scrambled Sobol points in base 2 (dimensions 0 and 1), after Burley 2020, "Practical
//! Hash-based Owen Scrambling" (JCGT 9(4)); the scramble's hash is Vegdahl's improved
//! Laine–Karras permutation. [`crate::tracer::sampler`] draws from them; all values are 32-bit
//! fixed point with the most significant bit worth 1/2.

/// Sobol dimension 0 (van der Corput): the identity generator matrix, i.e.
/// the index with its bits mirrored about the binary point.
#[cfg_attr(not(test), allow(dead_code))] // the generator the tests check; sobol_bits inlines it
pub(super) fn sobol_dim0(index: u32) -> u32 {
    index.reverse_bits()
}

/// Sobol dimension 1: the generator matrix applied a byte at a time through
/// [`SOBOL_DIM1_BYTES`] (4 lookups instead of a loop over up to 32 bits: this
/// ran in ~25 % of render time, the index being an Owen-scrambled, i.e.
/// random, 32-bit number). Same bits as [`sobol_dim1_by_bits`].
#[cfg_attr(not(test), allow(dead_code))] // the sampler uses the reversed form
pub(super) fn sobol_dim1(index: u32) -> u32 {
    sobol_dim1_of_reversed(index.reverse_bits()).reverse_bits()
}

/// `sobol_dim1(r.reverse_bits()).reverse_bits()`: bit reversal is linear over GF(2), so the
/// tables take the index reversed and hold reversed direction-vector sums, and the lookups
/// XOR as before. The sampler's index shuffle produces the index reversed: y's bits then need
/// no reversal of it, which takes one step off the longest chain of a 2D draw.
pub(super) fn sobol_dim1_of_reversed(r: u32) -> u32 {
    let t = &SOBOL_DIM1_BYTES;
    t[0][(r & 0xff) as usize]
        ^ t[1][(r >> 8 & 0xff) as usize]
        ^ t[2][(r >> 16 & 0xff) as usize]
        ^ t[3][(r >> 24) as usize]
}

/// `SOBOL_DIM1_BYTES[k][b]`: the XOR of the direction vectors selected by byte value `b` in
/// byte `k` of the reversed index (the matrix is linear over GF(2), so the four bytes'
/// contributions XOR together), bit-reversed.
const SOBOL_DIM1_BYTES: [[u32; 256]; 4] = {
    let mut t = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            t[k][b] = sobol_dim1_by_bits(((b as u32) << (8 * k)).reverse_bits()).reverse_bits();
            b += 1;
        }
        k += 1;
    }
    t
};

/// Sobol dimension 1 via its generator matrix, one direction vector per set
/// bit (builds the table; the reference the tests compare against).
pub(super) const fn sobol_dim1_by_bits(index: u32) -> u32 {
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
pub(super) const SOBOL_DIM1_DIRECTIONS: [u32; 32] = {
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
pub(super) fn owen_scramble(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The hash of [`owen_scramble`] in the bit-reversed domain.
pub(super) fn laine_karras(mut v: u32, seed: u32) -> u32 {
    v ^= v.wrapping_mul(0x3d20_adea);
    v = v.wrapping_add(seed);
    v = v.wrapping_mul((seed >> 16) | 1);
    v ^= v.wrapping_mul(0x0552_6c56);
    v ^= v.wrapping_mul(0x53a2_2864);
    v
}
