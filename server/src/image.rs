//! Merged partial sums → the layers of the output image.
use crate::output::ImageLayers;
use tessera_render::tracer::PixelSums;

pub fn layers(width: u32, height: u32, pixels: &[PixelSums]) -> ImageLayers {
    let mut img = ImageLayers::zeroed(width as usize, height as usize);
    for (i, p) in pixels.iter().enumerate() {
        set_pixel(&mut img, i, p);
    }
    img
}

/// Writes pixel `i`'s mean, variance of the mean and sample count from its sums (an untouched
/// pixel of a zeroed image is what sums of no samples give).
pub fn set_pixel(img: &mut ImageLayers, i: usize, p: &PixelSums) {
    img.rgb[i] = p.mean().map(|v| v as f32);
    img.variance[i] = p.variance_of_mean().map(|v| v as f32);
    img.samples[i] = p.count as f32;
}

/// The relMSE estimate of a `width`-wide block of pixels: mean over pixels and channels of
/// Var(mean) / (m + 0.01)², the variance of each pixel's mean estimated from its merged sums.
///
/// `m` is the mean of the pixel and its 3×3 neighbours (within the block), not the pixel's own:
/// a pixel's sample variance and its own mean rise together with every outlier, so dividing one by
/// the other underestimates the error at low spp (measured on the Cornell box at 16 spp: 0.64×
/// the true relMSE with the pixel's own mean, 0.89× with the neighbourhood's; tests/tests/accuracy.rs).
/// 0.01 keeps dark pixels from dominating.
pub fn rel_mse(pixels: &[PixelSums], width: usize) -> f64 {
    if pixels.is_empty() || width == 0 {
        return 0.0;
    }
    let height = pixels.len() / width;
    let pixels = &pixels[..width * height];
    // One plane per channel and separable 3-tap box sums: the coordinator runs this on every
    // merge of a noise-target job and over every tile for each history row, so it is written
    // for speed (about 4× the direct 3×3 loop); `tests::matches_the_direct_definition` pins it.
    let mut means = vec![[0.0f64; 3]; pixels.len()];
    let mut var = vec![[0.0f64; 3]; pixels.len()];
    for ((p, m), v) in pixels.iter().zip(&mut means).zip(&mut var) {
        (*m, *v) = mean_and_variance(p);
    }
    let rows = box3_rows(&means, width);
    let mut acc = 0.0;
    for y in 0..height {
        let (y0, y1) = (y.saturating_sub(1), (y + 2).min(height));
        let ky = (y1 - y0) as f64;
        for x in 0..width {
            let kx = (x.min(1) + 1 + usize::from(x + 1 < width)) as f64;
            let inv_k = 1.0 / (kx * ky);
            let mut m = [0.0; 3];
            for yy in y0..y1 {
                let r = rows[yy * width + x];
                (0..3).for_each(|c| m[c] += r[c]);
            }
            let v = var[y * width + x];
            for c in 0..3 {
                let d = m[c] * inv_k + 0.01;
                acc += v[c] / (d * d);
            }
        }
    }
    acc / (3 * width * height) as f64
}

/// [`PixelSums::mean`] and [`PixelSums::variance_of_mean`] with two divisions instead of twelve
/// (equal to rounding).
fn mean_and_variance(p: &PixelSums) -> ([f64; 3], [f64; 3]) {
    let n = p.count.max(1) as f64;
    let inv_n = 1.0 / n;
    let m = p.sum.map(|s| s * inv_n);
    if p.count < 2 {
        return (m, [0.0; 3]);
    }
    let inv_n1 = 1.0 / (n - 1.0);
    (m, std::array::from_fn(|c| (p.sum_sq[c] * inv_n - m[c] * m[c]).max(0.0) * inv_n1))
}

/// Each value plus its left and right neighbours within its row.
fn box3_rows(values: &[[f64; 3]], width: usize) -> Vec<[f64; 3]> {
    let mut out = values.to_vec();
    for row in out.chunks_exact_mut(width).zip(values.chunks_exact(width)) {
        let (o, v) = row;
        for x in 0..width {
            for c in 0..3 {
                if x > 0 {
                    o[x][c] += v[x - 1][c];
                }
                if x + 1 < width {
                    o[x][c] += v[x + 1][c];
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The estimator as its doc states it: a direct 3×3 neighbourhood per pixel.
    fn direct(pixels: &[PixelSums], width: usize) -> f64 {
        let height = pixels.len() / width;
        let mut acc = 0.0;
        for y in 0..height {
            for x in 0..width {
                let (mut m, mut k) = ([0.0; 3], 0.0);
                for yy in y.saturating_sub(1)..(y + 2).min(height) {
                    for xx in x.saturating_sub(1)..(x + 2).min(width) {
                        let n = pixels[yy * width + xx].mean();
                        (0..3).for_each(|c| m[c] += n[c]);
                        k += 1.0;
                    }
                }
                let v = pixels[y * width + x].variance_of_mean();
                (0..3).for_each(|c| acc += v[c] / (m[c] / k + 0.01).powi(2));
            }
        }
        acc / (3 * width * height) as f64
    }

    fn noisy_block(width: usize, height: usize) -> Vec<PixelSums> {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut draw = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f32 / (1u64 << 53) as f32 * 4.0
        };
        (0..width * height)
            .map(|i| {
                let mut p = PixelSums::default();
                // Counts 0, 1 and many: the < 2 samples cases have no variance.
                for _ in 0..(i % 7) {
                    p.add_sample(glam::Vec3::new(draw(), draw() * 0.1, draw() * draw()));
                }
                p
            })
            .collect()
    }

    #[test]
    fn matches_the_direct_definition() {
        for (w, h) in [(64, 64), (1, 5), (5, 1), (2, 2), (13, 7)] {
            let block = noisy_block(w, h);
            let (fast, slow) = (rel_mse(&block, w), direct(&block, w));
            assert!(slow > 0.0 || w * h < 3, "{w}×{h}: the test block must have noise");
            assert!((fast - slow).abs() <= 1e-12 * slow.abs(), "{w}×{h}: {fast} vs {slow}");
        }
    }
}
