//! A tile's checkpoint file: its merged f64 sums after batches 0..upto, bit for bit.
//!
//! Layout (little endian): magic `TSRTILE1`, tile index u32, upto u32, pixel count u32,
//! reserved u32, dropped u64, max_weight f64, then per pixel Σrgb, Σrgb², ΣY² (7 × f64) and the
//! count (u64), then a CRC-32 of everything before it. A file that is short, long, or fails its
//! checksum is refused, never half-read.
use tessera_render::tracer::PixelSums;

const MAGIC: &[u8; 8] = b"TSRTILE1";
const HEADER: usize = 8 + 4 * 4 + 8 + 8;
const PIXEL: usize = 8 * 8;

pub struct TileFile {
    pub tile: u32,
    pub upto: u32,
    pub dropped: u64,
    pub max_weight: f64,
    pub sums: Vec<PixelSums>,
}

/// The file name of a tile's checkpoint holding `upto` batches.
pub fn file_name(tile: u32, upto: u32) -> String {
    format!("t{tile}-b{upto}.sums")
}

pub fn encode(tile: u32, upto: u32, dropped: u64, max_weight: f64, sums: &[PixelSums]) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + sums.len() * PIXEL + 4);
    out.extend_from_slice(MAGIC);
    for v in [tile, upto, sums.len() as u32, 0] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&dropped.to_le_bytes());
    out.extend_from_slice(&max_weight.to_le_bytes());
    for p in sums {
        for v in p.sum.iter().chain(&p.sum_sq).chain([&p.sum_lum_sq]) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.extend_from_slice(&p.count.to_le_bytes());
    }
    let crc = crc32fast::hash(&out);
    out.extend_from_slice(&crc.to_le_bytes());
    out
}

pub fn decode(bytes: &[u8]) -> Result<TileFile, String> {
    if bytes.len() < HEADER + 4 || &bytes[..8] != MAGIC {
        return Err("not a tile checkpoint (bad magic or too short)".into());
    }
    let (body, crc) = bytes.split_at(bytes.len() - 4);
    if crc32fast::hash(body).to_le_bytes() != crc {
        return Err("checksum mismatch".into());
    }
    let u32_at = |o: usize| u32::from_le_bytes(body[o..o + 4].try_into().expect("4 bytes"));
    let u64_at = |o: usize| u64::from_le_bytes(body[o..o + 8].try_into().expect("8 bytes"));
    let (tile, upto, pixels) = (u32_at(8), u32_at(12), u32_at(16) as usize);
    if body.len() != HEADER + pixels * PIXEL {
        return Err(format!("length {} does not hold {pixels} pixels", bytes.len()));
    }
    let sums = (0..pixels)
        .map(|i| {
            let o = HEADER + i * PIXEL;
            let f = |k: usize| f64::from_bits(u64_at(o + 8 * k));
            PixelSums {
                sum: [f(0), f(1), f(2)],
                sum_sq: [f(3), f(4), f(5)],
                sum_lum_sq: f(6),
                count: u64_at(o + 56),
            }
        })
        .collect();
    Ok(TileFile { tile, upto, dropped: u64_at(24), max_weight: f64::from_bits(u64_at(32)), sums })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<PixelSums> {
        (0..5)
            .map(|i| PixelSums {
                sum: [i as f64, 0.1, -0.0],
                sum_sq: [1e300, 2.5, 3.0],
                sum_lum_sq: 0.3,
                count: i,
            })
            .collect()
    }

    #[test]
    fn round_trips_bit_for_bit() {
        let bytes = encode(7, 3, 2, 9.5, &sample());
        let t = decode(&bytes).unwrap();
        assert_eq!((t.tile, t.upto, t.dropped, t.max_weight), (7, 3, 2, 9.5));
        let bits = |v: &[PixelSums]| {
            v.iter()
                .flat_map(|p| {
                    p.sum.iter().chain(&p.sum_sq).map(|x| x.to_bits()).collect::<Vec<_>>()
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(bits(&t.sums), bits(&sample()));
        assert_eq!(t.sums.iter().map(|p| p.count).collect::<Vec<_>>(), vec![0, 1, 2, 3, 4]);
    }

    #[test]
    fn truncated_extended_or_flipped_files_are_refused() {
        let bytes = encode(1, 1, 0, 1.0, &sample());
        assert!(decode(&bytes[..bytes.len() - 1]).is_err());
        assert!(decode(&bytes[..20]).is_err());
        let mut longer = bytes.clone();
        longer.push(0);
        assert!(decode(&longer).is_err());
        for i in [0, 9, 40, bytes.len() / 2, bytes.len() - 1] {
            let mut bad = bytes.clone();
            bad[i] ^= 0x10;
            assert!(decode(&bad).is_err(), "flipped byte {i} went unnoticed");
        }
    }
}
