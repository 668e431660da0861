//! Image textures: linear RGBA texels, bilinear lookup, glTF wrap modes, and the binding of a
//! texture to a material slot ([`TextureRef`]: UV set and `KHR_texture_transform`).
//!
//! Colour textures (base colour, emissive) are stored sRGB-decoded at load time, data textures
//! (metallic-roughness, normal) as stored, so lookups are a plain bilinear blend in linear space.
//! Texture coordinates follow glTF: (0, 0) is the top-left of the image, u to the right, v down.
//!
//! `KHR_texture_transform`: uv' = T·R·S·uv with T the `offset`, R the `rotation` (radians,
//! counter-clockwise in uv: u' = cos·u + sin·v, v' = −sin·u + cos·v) and S the `scale`; its
//! `texCoord` overrides the slot's UV set. Applied per lookup (two multiply-adds per axis).
use glam::{Vec2, Vec3, Vec4};

/// A texture bound to a material slot: which texture, which UV set, which transform.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: u32,
    /// UV set 0 or 1 (`KHR_texture_transform.texCoord` already applied).
    pub tex_coord: u32,
    pub transform: UvTransform,
}

impl TextureRef {
    /// A binding to UV set `tex_coord` without a transform.
    pub fn new(texture: u32, tex_coord: u32) -> TextureRef {
        TextureRef { texture, tex_coord, transform: UvTransform::IDENTITY }
    }

    /// The transformed texture coordinate of this slot, given both UV sets at a point.
    #[inline]
    pub fn uv(&self, uvs: &[Vec2; 2]) -> Vec2 {
        self.transform.apply(uvs[self.tex_coord.min(1) as usize])
    }

    #[inline]
    pub fn sample(&self, textures: &[Texture], uvs: &[Vec2; 2]) -> Vec4 {
        textures[self.texture as usize].sample(self.uv(uvs))
    }
}

/// The emissive texture of an area light ([`crate::tracer::light::Light::Triangle`]), with the
/// triangle's texture coordinates.
#[derive(Clone, Debug, PartialEq)]
pub struct EmissiveTexture {
    pub texture: TextureRef,
    /// Both UV sets at the triangle's corners.
    pub uvs: [[Vec2; 3]; 2],
    /// The texture's mean texel (linear RGB), for the light's power.
    pub mean: Vec3,
}

impl EmissiveTexture {
    /// The texel at barycentrics `b`.
    pub(crate) fn at(&self, textures: &[Texture], b: [f32; 3]) -> Vec3 {
        let uvs = self.uvs.map(|t| t[0] * b[0] + t[1] * b[1] + t[2] * b[2]);
        self.texture.sample(textures, &uvs).truncate()
    }
}

/// An affine map of texture coordinates: uv' = x·u + y·v + offset.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UvTransform {
    pub x: Vec2,
    pub y: Vec2,
    pub offset: Vec2,
}

impl UvTransform {
    pub const IDENTITY: UvTransform = UvTransform { x: Vec2::X, y: Vec2::Y, offset: Vec2::ZERO };

    /// `KHR_texture_transform`'s offset, rotation (radians) and scale.
    pub fn from_gltf(offset: Vec2, rotation: f32, scale: Vec2) -> UvTransform {
        let (s, c) = rotation.sin_cos();
        UvTransform { x: Vec2::new(c, -s) * scale.x, y: Vec2::new(s, c) * scale.y, offset }
    }

    #[inline]
    pub fn apply(&self, uv: Vec2) -> Vec2 {
        self.x * uv.x + self.y * uv.y + self.offset
    }
}

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

    /// Mean RGB over all texels (for choosing textured emitters by power).
    pub fn mean_rgb(&self) -> Vec3 {
        let sum: glam::DVec3 = self.texels.iter().map(|t| t.truncate().as_dvec3()).sum();
        (sum / self.texels.len().max(1) as f64).as_vec3()
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
    fn texture_transforms_follow_khr_texture_transform() {
        // The extension's example: offset (0, 1), rotation π/2, scale ½ uses the lower-left
        // quadrant of the image, rotated.
        let quadrant = UvTransform::from_gltf(
            Vec2::new(0.0, 1.0),
            std::f32::consts::FRAC_PI_2,
            Vec2::splat(0.5),
        );
        for (uv, want) in [
            ((0.0, 0.0), (0.0, 1.0)),
            ((1.0, 0.0), (0.0, 0.5)),
            ((1.0, 1.0), (0.5, 0.5)),
            ((0.0, 1.0), (0.5, 1.0)),
        ] {
            let got = quadrant.apply(Vec2::from(uv));
            assert!((got - Vec2::from(want)).length() < 1e-6, "{uv:?} → {got}, want {want:?}");
        }
        let t = UvTransform::from_gltf(
            Vec2::new(0.5, 0.25),
            std::f32::consts::FRAC_PI_2,
            Vec2::new(2.0, 3.0),
        );
        let uv = t.apply(Vec2::new(1.0, 0.0));
        assert!((uv - Vec2::new(0.5, 0.25 - 2.0)).length() < 1e-6, "{uv}");
        let uv = t.apply(Vec2::new(0.0, 1.0));
        assert!((uv - Vec2::new(0.5 + 3.0, 0.25)).length() < 1e-6, "{uv}");
        let r = TextureRef {
            texture: 0,
            tex_coord: 1,
            transform: UvTransform::from_gltf(Vec2::new(0.25, 0.0), 0.0, Vec2::ONE),
        };
        assert_eq!(r.uv(&[Vec2::ZERO, Vec2::new(0.5, 0.5)]), Vec2::new(0.75, 0.5));
        assert_eq!(UvTransform::IDENTITY.apply(Vec2::new(0.3, 0.7)), Vec2::new(0.3, 0.7));
    }

    #[test]
    fn srgb_decoding_matches_the_standard() {
        assert_eq!(srgb_to_linear(0.0), 0.0);
        assert!((srgb_to_linear(1.0) - 1.0).abs() < 1e-6);
        assert!((srgb_to_linear(0.5) - 0.21404).abs() < 1e-4);
    }
}
