//! 8-bit sRGB PNG previews of linear radiance.

use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};

/// Encodes a `width` x `height` preview (row-major, top row first).
///
/// Linear values go through the sRGB transfer function at exposure 1: no
/// auto-exposure, so a value of 1.0 is always white and previews of
/// different renders or passes compare directly. Values are clamped to
/// [0, 1]; NaN and ±Inf become 0 so a few broken pixels stay visible as black
/// dots instead of poisoning anything. Never panics: if the size is zero,
/// too large for PNG, or does not match `rgb.len()`, the result is empty.
pub fn encode_png_preview(width: usize, height: usize, rgb: &[[f32; 3]]) -> Vec<u8> {
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Vec::new();
    };
    if w == 0 || h == 0 || width.checked_mul(height) != Some(rgb.len()) {
        return Vec::new();
    }
    let pixels: Vec<u8> = rgb.iter().flatten().map(|&v| linear_to_srgb8(v)).collect();
    let mut png = Vec::new();
    match PngEncoder::new(&mut png).write_image(&pixels, w, h, ExtendedColorType::Rgb8) {
        Ok(()) => png,
        Err(_) => Vec::new(),
    }
}

/// The sRGB (IEC 61966-2-1) encoding of a linear value, rounded to 8 bits.
fn linear_to_srgb8(v: f32) -> u8 {
    if !v.is_finite() {
        return 0;
    }
    let v = v.clamp(0.0, 1.0);
    let encoded = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
    (encoded * 255.0).round() as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(png: &[u8]) -> image::RgbImage {
        image::load_from_memory_with_format(png, image::ImageFormat::Png)
            .expect("valid PNG")
            .to_rgb8()
    }

    #[test]
    fn preview_has_size_and_srgb_transfer() {
        // 3x2, top row first: checks orientation and the transfer curve.
        let rgb = [
            [0.5, 0.0, 1.0],
            [0.002, 0.2, 0.8],
            [2.0, -1.0, 1e-9],
            [0.0; 3],
            [1.0; 3],
            [0.05, 0.0, 0.0],
        ];
        let img = decode(&encode_png_preview(3, 2, &rgb));
        assert_eq!(img.dimensions(), (3, 2));
        assert_eq!(img.get_pixel(0, 0).0, [188, 0, 255]);
        // Linear segment: 0.002 * 12.92 * 255 = 6.6; 0.2 -> 0.4845 -> 124.
        assert_eq!(img.get_pixel(1, 0).0, [7, 124, 231]);
        assert_eq!(img.get_pixel(2, 0).0, [255, 0, 0]);
        assert_eq!(img.get_pixel(1, 1).0, [255; 3]);
        // 0.05 -> 0.2478 (vs 0.05 without the transfer) -> 63.
        assert_eq!(img.get_pixel(2, 1).0, [63, 0, 0]);
    }

    #[test]
    fn non_finite_pixels_become_black() {
        let rgb = [[f32::NAN, f32::INFINITY, f32::NEG_INFINITY], [f32::NAN, 0.5, 1.0]];
        let img = decode(&encode_png_preview(2, 1, &rgb));
        assert_eq!(img.get_pixel(0, 0).0, [0, 0, 0]);
        assert_eq!(img.get_pixel(1, 0).0, [0, 188, 255]);
    }

    #[test]
    fn bad_sizes_give_empty_output_not_panics() {
        assert!(encode_png_preview(0, 0, &[]).is_empty());
        assert!(encode_png_preview(2, 2, &[[0.5; 3]; 3]).is_empty());
        assert!(encode_png_preview(usize::MAX, 2, &[]).is_empty());
        assert!(!encode_png_preview(1, 1, &[[0.5; 3]]).is_empty());
    }
}
