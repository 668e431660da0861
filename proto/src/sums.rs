//! The binary form of a unit's partial sums (`application/x-tessera-sums`).
//!
//! Little-endian throughout; f64 is sent bit for bit, so the coordinator merges exactly what the
//! worker computed (JSON floats would round-trip through text).
//!
//! ```text
//! offset size  field
//!      0    4  magic "TSUM"
//!      4    2  version (1)
//!      6    2  reserved (0)
//!      8   16  tile x0, y0, w, h (u32 each)
//!     24    8  sample range start, end (u32 each)
//!     32    8  dropped non-finite samples (u64)
//!     40    8  largest path weight (f64)
//!     48  64·n per pixel, row-major: Σr, Σg, Σb, Σr², Σg², Σb², ΣY² (f64), count (u64)
//! ```
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

pub const MAGIC: &[u8; 4] = b"TSUM";
pub const VERSION: u16 = 1;
pub const HEADER_LEN: usize = 48;
pub const PIXEL_LEN: usize = 64;
pub const CONTENT_TYPE: &str = "application/x-tessera-sums";

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize, ToSchema)]
pub struct TileRect {
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
}

impl TileRect {
    pub fn pixel_count(&self) -> usize {
        self.w as usize * self.h as usize
    }
}

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WirePixel {
    pub sum: [f64; 3],
    pub sum_sq: [f64; 3],
    pub sum_lum_sq: f64,
    pub count: u64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PartialSums {
    pub tile: TileRect,
    pub samples: [u32; 2],
    pub dropped: u64,
    pub max_weight: f64,
    pub pixels: Vec<WirePixel>,
}

#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SumsError(pub String);

impl std::fmt::Display for SumsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SumsError {}

fn err<T>(msg: impl Into<String>) -> Result<T, SumsError> {
    Err(SumsError(msg.into()))
}

impl PartialSums {
    pub fn encode(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(HEADER_LEN + PIXEL_LEN * self.pixels.len());
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&VERSION.to_le_bytes());
        out.extend_from_slice(&0u16.to_le_bytes());
        for v in
            [self.tile.x0, self.tile.y0, self.tile.w, self.tile.h, self.samples[0], self.samples[1]]
        {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&self.dropped.to_le_bytes());
        out.extend_from_slice(&self.max_weight.to_le_bytes());
        // Fixed-size pixel records written in place: no capacity check per value.
        out.resize(HEADER_LEN + PIXEL_LEN * self.pixels.len(), 0);
        for (b, p) in out[HEADER_LEN..].chunks_exact_mut(PIXEL_LEN).zip(&self.pixels) {
            let values =
                [p.sum[0], p.sum[1], p.sum[2], p.sum_sq[0], p.sum_sq[1], p.sum_sq[2], p.sum_lum_sq];
            for (k, v) in values.iter().enumerate() {
                b[8 * k..8 * k + 8].copy_from_slice(&v.to_le_bytes());
            }
            b[56..64].copy_from_slice(&p.count.to_le_bytes());
        }
        out
    }

    /// Decodes and checks internal consistency: exact length, finite non-negative squares,
    /// and every sample of the range either counted in a pixel or dropped.
    pub fn decode(bytes: &[u8]) -> Result<PartialSums, SumsError> {
        if bytes.len() < HEADER_LEN {
            return err(format!(
                "body is {} bytes, shorter than the {HEADER_LEN}-byte header",
                bytes.len()
            ));
        }
        if &bytes[0..4] != MAGIC {
            return err("not Tessera partial sums (bad magic)");
        }
        let u16_at = |o: usize| u16::from_le_bytes(bytes[o..o + 2].try_into().expect("2 bytes"));
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
        let u64_at = |o: usize| u64::from_le_bytes(bytes[o..o + 8].try_into().expect("8 bytes"));
        let f64_at = |o: usize| f64::from_bits(u64_at(o));
        if u16_at(4) != VERSION {
            return err(format!("unsupported version {} (expected {VERSION})", u16_at(4)));
        }
        if u16_at(6) != 0 {
            return err(format!("reserved header bytes 6..8 are {} (must be 0)", u16_at(6)));
        }
        let tile = TileRect { x0: u32_at(8), y0: u32_at(12), w: u32_at(16), h: u32_at(20) };
        let samples = [u32_at(24), u32_at(28)];
        let (dropped, max_weight) = (u64_at(32), f64_at(40));
        let n = tile.pixel_count();
        let expected = n.checked_mul(PIXEL_LEN).and_then(|p| p.checked_add(HEADER_LEN));
        if expected != Some(bytes.len()) {
            return err(format!(
                "body is {} bytes; a {}×{} tile needs {:?}",
                bytes.len(),
                tile.w,
                tile.h,
                expected
            ));
        }
        if samples[1] <= samples[0] {
            return err(format!("empty sample range [{}, {})", samples[0], samples[1]));
        }
        if !(max_weight.is_finite() && max_weight >= 0.0) {
            return err("largest path weight is not a finite number ≥ 0");
        }
        let per_pixel = (samples[1] - samples[0]) as u64;
        // Checked branch-free as the pixels are read (a result is hundreds of kilobytes and the
        // coordinator decodes thousands a second); only a bad body is searched for its first bad pixel.
        let mut all_valid = true;
        let pixels: Vec<WirePixel> = bytes[HEADER_LEN..]
            .chunks_exact(PIXEL_LEN)
            .map(|b| {
                let p = wire_pixel(b);
                all_valid &= valid(&p, per_pixel);
                p
            })
            .collect();
        if !all_valid {
            let (i, p) = pixels
                .iter()
                .enumerate()
                .find(|(_, p)| !valid(p, per_pixel))
                .expect("a pixel is invalid");
            return err(match p.count > per_pixel {
                true => {
                    format!("pixel {i}: {} samples, more than the range's {per_pixel}", p.count)
                }
                false => format!("pixel {i}: sums must be finite and squares ≥ 0"),
            });
        }
        let counted = pixels.iter().try_fold(0u64, |a, p| a.checked_add(p.count));
        let in_unit = per_pixel.checked_mul(n as u64);
        let (Some(counted), Some(in_unit)) = (counted, in_unit) else {
            return err("sample counts overflow 64 bits");
        };
        if counted.checked_add(dropped) != Some(in_unit) {
            return err(format!(
                "{counted} samples counted + {dropped} dropped ≠ {in_unit} in the unit"
            ));
        }
        Ok(PartialSums { tile, samples, dropped, max_weight, pixels })
    }
}

fn wire_pixel(b: &[u8]) -> WirePixel {
    let f = |k: usize| f64::from_le_bytes(b[8 * k..8 * k + 8].try_into().expect("8 bytes"));
    let count = u64::from_le_bytes(b[56..64].try_into().expect("8 bytes"));
    WirePixel { sum: [f(0), f(1), f(2)], sum_sq: [f(3), f(4), f(5)], sum_lum_sq: f(6), count }
}

/// Finite sums, squares ≥ 0, at most the unit's samples per pixel.
fn valid(p: &WirePixel, per_pixel: u64) -> bool {
    let finite =
        p.sum.iter().chain(&p.sum_sq).fold(p.sum_lum_sq.is_finite(), |ok, v| ok & v.is_finite());
    let squares = p.sum_sq.iter().fold(p.sum_lum_sq >= 0.0, |ok, v| ok & (*v >= 0.0));
    finite & squares & (p.count <= per_pixel)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> PartialSums {
        let tile = TileRect { x0: 64, y0: 0, w: 3, h: 2 };
        let pixels = (0..6)
            .map(|i| WirePixel {
                sum: [i as f64 * 0.1, 0.2, 1e-300],
                sum_sq: [0.5, 0.25, 0.0],
                sum_lum_sq: 0.3,
                count: if i == 0 { 3 } else { 4 },
            })
            .collect();
        PartialSums { tile, samples: [16, 20], dropped: 1, max_weight: 2.5, pixels }
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let s = sample();
        let bytes = s.encode();
        assert_eq!(bytes.len(), HEADER_LEN + 6 * PIXEL_LEN);
        assert_eq!(PartialSums::decode(&bytes).unwrap(), s);
    }

    #[test]
    fn malformed_bodies_are_refused_with_reasons() {
        let good = sample().encode();
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (good[..40].to_vec(), "shorter than"),
            (good[..good.len() - 1].to_vec(), "needs"),
            ([b"XSUM", &good[4..]].concat(), "bad magic"),
            (
                {
                    let mut b = good.clone();
                    b[4] = 9;
                    b
                },
                "unsupported version",
            ),
            (
                {
                    let mut b = good.clone();
                    b[6] = 1;
                    b
                },
                "reserved",
            ),
            (
                {
                    let mut b = good.clone();
                    b[48..56].copy_from_slice(&f64::NAN.to_le_bytes());
                    b
                },
                "finite",
            ),
            (
                {
                    let mut b = good.clone();
                    b[48 + 24..48 + 32].copy_from_slice(&(-1f64).to_le_bytes());
                    b
                },
                "squares",
            ),
            (
                {
                    let mut b = good.clone();
                    b[32] = 0;
                    b
                },
                "counted",
            ),
            (
                {
                    let mut b = good.clone();
                    b[48 + 56] = 9;
                    b
                },
                "more than",
            ),
            (
                {
                    let mut b = good.clone();
                    b[28..32].copy_from_slice(&16u32.to_le_bytes());
                    b
                },
                "empty sample range",
            ),
            (
                {
                    let mut b = good.clone();
                    b[16..20].copy_from_slice(&u32::MAX.to_le_bytes());
                    b
                },
                "needs",
            ),
        ];
        for (bytes, why) in cases {
            let e = PartialSums::decode(&bytes).unwrap_err();
            assert!(e.0.contains(why), "{e} should mention {why:?}");
        }
    }
}
