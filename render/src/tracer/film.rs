//! Per-pixel partial sums: what a unit of work returns and what the coordinator merges.
//!
//! Sums, never averages: merging units over disjoint sample ranges is plain f64 addition, and
//! the mean and its variance come out at the end. f64 keeps the mean exact to ~1e-12 even after
//! 10⁹ samples, where f32 sums drift visibly. A non-finite sample is dropped and counted.
use crate::tracer::sampling::luminance;
use glam::Vec3;

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PixelSums {
    /// Σ radiance per channel.
    pub sum: [f64; 3],
    /// Σ radiance² per channel (for the per-channel variance).
    pub sum_sq: [f64; 3],
    /// Σ luminance² (for the luminance variance used by noise estimates).
    pub sum_lum_sq: f64,
    pub count: u64,
}

impl PixelSums {
    pub fn add_sample(&mut self, l: Vec3) {
        for c in 0..3 {
            let v = l[c] as f64;
            self.sum[c] += v;
            self.sum_sq[c] += v * v;
        }
        let y = luminance(l) as f64;
        self.sum_lum_sq += y * y;
        self.count += 1;
    }

    pub fn merge(&mut self, o: &PixelSums) {
        for c in 0..3 {
            self.sum[c] += o.sum[c];
            self.sum_sq[c] += o.sum_sq[c];
        }
        self.sum_lum_sq += o.sum_lum_sq;
        self.count += o.count;
    }

    pub fn mean(&self) -> [f64; 3] {
        let n = self.count.max(1) as f64;
        self.sum.map(|s| s / n)
    }

    /// Unbiased estimate of the variance of the pixel mean, per channel (0 with < 2 samples).
    pub fn variance_of_mean(&self) -> [f64; 3] {
        if self.count < 2 {
            return [0.0; 3];
        }
        let n = self.count as f64;
        let mut v = [0.0; 3];
        for c in 0..3 {
            let m = self.sum[c] / n;
            v[c] = ((self.sum_sq[c] / n - m * m).max(0.0) * n / (n - 1.0)) / n;
        }
        v
    }
}

/// A rectangle of pixels: columns x0..x0+w, rows y0..y0+h.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Tile {
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
}

impl Tile {
    pub fn pixel_count(&self) -> usize {
        self.w as usize * self.h as usize
    }
}

/// The partial sums of one tile over one sample range.
#[derive(Clone, Debug, PartialEq)]
pub struct TileSums {
    pub tile: Tile,
    /// Row-major within the tile.
    pub pixels: Vec<PixelSums>,
    /// Samples that came out NaN or infinite and were dropped.
    pub dropped: u64,
    /// Largest path throughput weight seen (Russian roulette and importance weights).
    pub max_weight: f32,
    /// Rays traced (camera, bounce and shadow rays), for throughput figures; not sent on the wire.
    pub rays: u64,
}

/// Sums of one tile handed to another tile's merge.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("tile mismatch: {ours:?} vs {theirs:?}")]
pub struct TileMismatch {
    pub ours: Tile,
    pub theirs: Tile,
}

impl TileSums {
    pub fn new(tile: Tile) -> TileSums {
        TileSums {
            tile,
            pixels: vec![PixelSums::default(); tile.pixel_count()],
            dropped: 0,
            max_weight: 0.0,
            rays: 0,
        }
    }

    /// Adds another range's sums for the same tile.
    pub fn merge(&mut self, other: &TileSums) -> Result<(), TileMismatch> {
        if other.tile != self.tile {
            return Err(TileMismatch { ours: self.tile, theirs: other.tile });
        }
        for (a, b) in self.pixels.iter_mut().zip(&other.pixels) {
            a.merge(b);
        }
        self.dropped += other.dropped;
        self.max_weight = self.max_weight.max(other.max_weight);
        self.rays += other.rays;
        Ok(())
    }

    /// Copies this tile's sums into a full frame buffer (`width` pixels per row).
    pub fn add_into_frame(&self, frame: &mut [PixelSums], width: u32) {
        for y in 0..self.tile.h {
            for x in 0..self.tile.w {
                let src = &self.pixels[(y * self.tile.w + x) as usize];
                frame[((self.tile.y0 + y) * width + self.tile.x0 + x) as usize].merge(src);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variance_of_mean_matches_the_textbook_formula() {
        let mut p = PixelSums::default();
        for v in [1.0, 2.0, 3.0, 4.0] {
            p.add_sample(Vec3::splat(v));
        }
        assert_eq!(p.mean(), [2.5; 3]);
        // Sample variance 5/3, divided by n = 4.
        assert!((p.variance_of_mean()[0] - 5.0 / 12.0).abs() < 1e-12);
    }

    #[test]
    fn f64_sums_keep_the_mean_where_f32_would_not() {
        let mut p = PixelSums::default();
        let mut f32_sum = 0.0f32;
        for i in 0..20_000_000u64 {
            let v = 0.1 + (i % 7) as f32 * 0.001;
            p.add_sample(Vec3::splat(v));
            f32_sum += v;
        }
        let exact = (0..7).map(|k| (0.1f32 + k as f32 * 0.001) as f64).sum::<f64>() / 7.0;
        assert!((p.mean()[0] - exact).abs() < 1e-6, "f64 mean {}", p.mean()[0]);
        assert!((f32_sum as f64 / 2e7 - exact).abs() > 1e-3, "f32 sums should have drifted");
    }
}
