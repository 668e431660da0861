//! Image textures: linear RGBA texels, bilinear lookup, glTF wrap modes.
//!
//! Colour textures (base colour, emissive) are stored sRGB-decoded at load time, so lookups are a
//! plain bilinear blend in linear space. Texture coordinates follow glTF: (0, 0) is the top-left
//! of the image, u to the right, v down.
use glam::{Vec2, Vec4};

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    MirroredRepeat,
    ClampToEdge,
}

#[derive(Clone, Debug)]
pub struct Texture {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first, linear values.
    pub texels: Vec<Vec4>,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
}

impl Texture {
    /// Bilinear lookup at texture coordinate `uv`.
    pub fn sample(&self, uv: Vec2) -> Vec4 {
        let x = uv.x * self.width as f32 - 0.5;
        let y = uv.y * self.height as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let t = |dx: i64, dy: i64| self.texel(x0 + dx, y0 + dy);
        let top = t(0, 0) * (1.0 - fx) + t(1, 0) * fx;
        let bottom = t(0, 1) * (1.0 - fx) + t(1, 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    fn texel(&self, x: i64, y: i64) -> Vec4 {
        let x = wrap(x, self.width, self.wrap_s);
        let y = wrap(y, self.height, self.wrap_t);
        self.texels[y * self.width as usize + x]
    }
}

fn wrap(i: i64, n: u32, mode: Wrap) -> usize {
    let n = n as i64;
    let i = match mode {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::ClampToEdge => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
    };
    i as usize
}

/// sRGB transfer function → linear.
pub fn srgb_to_linear(c: f32) -> f32 {
    if c <= 0.04045 { c / 12.92 } else { ((c + 0.055) / 1.055).powf(2.4) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn checker(wrap: Wrap) -> Texture {
        let texels = vec![Vec4::ZERO, Vec4::ONE, Vec4::ONE, Vec4::ZERO];
        Texture { width: 2, height: 2, texels, wrap_s: wrap, wrap_t: wrap }
    }

    #[test]
    fn texel_centres_return_texels_and_midpoints_blend() {
        let t = checker(Wrap::ClampToEdge);
        assert_eq!(t.sample(Vec2::new(0.25, 0.25)), Vec4::ZERO);
        assert_eq!(t.sample(Vec2::new(0.75, 0.25)), Vec4::ONE);
        assert_eq!(t.sample(Vec2::new(0.5, 0.25)), Vec4::splat(0.5));
    }

    #[test]
    fn wrap_modes_follow_gltf() {
        assert_eq!(wrap(-1, 4, Wrap::Repeat), 3);
        assert_eq!(wrap(5, 4, Wrap::ClampToEdge), 3);
        assert_eq!(wrap(4, 4, Wrap::MirroredRepeat), 3);
        assert_eq!(wrap(-1, 4, Wrap::MirroredRepeat), 0);
        let t = checker(Wrap::Repeat);
        assert_eq!(t.sample(Vec2::new(1.25, 0.25)), t.sample(Vec2::new(0.25, 0.25)));
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.21404).abs() < 1e-4);
    }
}
