//! Merged partial sums → the layers of the output image.
use crate::output::ImageLayers;
use tessera_worker::tracer::PixelSums;

pub fn layers(width: u32, height: u32, pixels: &[PixelSums]) -> ImageLayers {
    ImageLayers {
        width: width as usize,
        height: height as usize,
        rgb: pixels.iter().map(|p| p.mean().map(|v| v as f32)).collect(),
        variance: pixels.iter().map(|p| p.variance_of_mean().map(|v| v as f32)).collect(),
        samples: pixels.iter().map(|p| p.count as f32).collect(),
    }
}

/// The relMSE estimate: mean over pixels and channels of Var(mean) / (mean + 0.01)², the
/// variance of each pixel's mean estimated from its merged sums (0.01 keeps dark pixels from
/// dominating).
pub fn rel_mse(pixels: &[PixelSums]) -> f64 {
    let mut acc = 0.0;
    for p in pixels {
        let m = p.mean();
        let v = p.variance_of_mean();
        for c in 0..3 {
            let d = m[c] + 0.01;
            acc += v[c] / (d * d);
        }
    }
    acc / (3 * pixels.len().max(1)) as f64
}
