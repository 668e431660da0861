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

/// Mean over the image of the per-pixel relative variance of the mean (relMSE estimate),
/// with the usual 1e-2 guard against dark pixels.
pub fn rel_mse(pixels: &[PixelSums]) -> f64 {
    let mut acc = 0.0;
    for p in pixels {
        let m = p.mean();
        let v = p.variance_of_mean();
        for c in 0..3 {
            acc += v[c] / (m[c] * m[c] + 1e-2);
        }
    }
    acc / (3 * pixels.len().max(1)) as f64
}
