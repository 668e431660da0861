//! glTF textures → [`Texture`]s, decoded once per image and converted per colour space.
//!
//! A glTF texture is only an image and a sampler; whether its texels are sRGB colours or
//! linear data depends on the material slot that uses it (base colour and emissive: sRGB;
//! metallic-roughness and normal: linear). [`TexturePool`] decodes every image up front (so a
//! broken image is an error even if unused, and the pixel budget covers them all) and hands
//! out one tracer texture per (glTF texture, colour space) that materials actually use.
//!
//! `KHR_texture_transform` on a slot becomes the [`TextureRef`]'s [`UvTransform`]; its
//! `texCoord` overrides the slot's.
use super::{SceneError, uri};
use crate::tracer::texture::{Texture, TextureRef, UvTransform, Wrap, srgb_to_linear};
use glam::{Vec2, Vec4};
use std::collections::HashMap;
use std::path::Path;

/// Most texture pixels a scene may decode, all images together (a guard against decompression
/// bombs: a few kilobytes of PNG can declare gigapixels; 2²⁶ pixels are 1 GiB as f32 RGBA).
const MAX_TEXTURE_PIXELS: u64 = 1 << 26;

/// How a slot reads its texels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum ColourSpace {
    Srgb,
    Linear,
}

/// Decoded images (as stored, in [0, 1]) and the tracer textures made from them so far.
pub struct TexturePool {
    /// Per glTF texture: image index and wrap modes.
    sources: Vec<(usize, Wrap, Wrap)>,
    /// Per glTF image: width, height, texels as stored.
    images: Vec<(u32, u32, Vec<Vec4>)>,
    made: HashMap<(usize, ColourSpace), u32>,
    textures: Vec<Texture>,
}

impl TexturePool {
    /// Decodes every image of the document.
    pub fn load(
        doc: &gltf::Document,
        base: Option<&Path>,
        buffers: &[Vec<u8>],
    ) -> Result<TexturePool, SceneError> {
        let mut budget = MAX_TEXTURE_PIXELS;
        let images = doc
            .images()
            .map(|img| {
                decode_image(&img, base, buffers, &mut budget)
                    .map_err(|e| SceneError::new(format!("image {}: {e}", img.index())))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let sources = doc
            .textures()
            .map(|t| (t.source().index(), wrap(t.sampler().wrap_s()), wrap(t.sampler().wrap_t())))
            .collect();
        Ok(TexturePool { sources, images, made: HashMap::new(), textures: Vec::new() })
    }

    /// The tracer texture for glTF texture `index` read in `space`, made on first use.
    fn get(&mut self, index: usize, space: ColourSpace) -> Result<u32, String> {
        if let Some(&t) = self.made.get(&(index, space)) {
            return Ok(t);
        }
        let &(image, wrap_s, wrap_t) =
            self.sources.get(index).ok_or(format!("texture {index} does not exist"))?;
        let (width, height, stored) = self
            .images
            .get(image)
            .ok_or(format!("texture {index}: image {image} does not exist"))?;
        let texels = match space {
            ColourSpace::Linear => stored.clone(),
            ColourSpace::Srgb => stored
                .iter()
                .map(|p| {
                    Vec4::new(srgb_to_linear(p.x), srgb_to_linear(p.y), srgb_to_linear(p.z), p.w)
                })
                .collect(),
        };
        self.textures.push(Texture { width: *width, height: *height, texels, wrap_s, wrap_t });
        let t = self.textures.len() as u32 - 1;
        self.made.insert((index, space), t);
        Ok(t)
    }

    /// A material slot's binding: glTF texture `index` on UV set `tex_coord`, with the slot's
    /// `KHR_texture_transform` (if any).
    pub fn bind(
        &mut self,
        index: usize,
        tex_coord: u32,
        transform: Option<Transform>,
        space: ColourSpace,
    ) -> Result<TextureRef, String> {
        let texture = self.get(index, space)?;
        let t = transform.unwrap_or_default();
        let finite = t.offset.is_finite() && t.rotation.is_finite() && t.scale.is_finite();
        if !finite {
            return Err(format!("KHR_texture_transform {t:?} must be finite"));
        }
        let tex_coord = t.tex_coord.unwrap_or(tex_coord);
        if tex_coord > 1 {
            return Err(format!("texCoord {tex_coord}: only TEXCOORD_0 and TEXCOORD_1 are read"));
        }
        Ok(TextureRef {
            texture,
            tex_coord,
            transform: UvTransform::from_gltf(t.offset, t.rotation, t.scale),
        })
    }

    pub fn finish(self) -> Vec<Texture> {
        self.textures
    }
}

/// `KHR_texture_transform` as written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub offset: Vec2,
    pub rotation: f32,
    pub scale: Vec2,
    pub tex_coord: Option<u32>,
}

impl Default for Transform {
    fn default() -> Transform {
        Transform { offset: Vec2::ZERO, rotation: 0.0, scale: Vec2::ONE, tex_coord: None }
    }
}

impl Transform {
    /// From a `textureInfo` (the gltf crate parses the extension there).
    pub fn of_info(info: &gltf::texture::Info) -> Option<Transform> {
        let t = info.texture_transform()?;
        Some(Transform {
            offset: t.offset().into(),
            rotation: t.rotation(),
            scale: t.scale().into(),
            tex_coord: t.tex_coord(),
        })
    }

    /// From the extension's JSON (on `normalTexture`, which the gltf crate leaves unparsed).
    pub fn of_json(v: &serde_json::Value) -> Result<Transform, String> {
        let pair = |key: &str, default: Vec2| -> Result<Vec2, String> {
            let Some(x) = v.get(key) else { return Ok(default) };
            let bad = || format!("KHR_texture_transform.{key} must be an array of 2 numbers");
            let a = x.as_array().filter(|a| a.len() == 2).ok_or_else(bad)?;
            let c: Vec<f32> = a.iter().filter_map(|x| x.as_f64()).map(|x| x as f32).collect();
            if c.len() == 2 { Ok(Vec2::new(c[0], c[1])) } else { Err(bad()) }
        };
        let rotation = match v.get("rotation") {
            None => 0.0,
            Some(r) => r.as_f64().ok_or("KHR_texture_transform.rotation must be a number")? as f32,
        };
        let tex_coord = match v.get("texCoord") {
            None => None,
            Some(t) => Some(
                t.as_u64()
                    .and_then(|t| u32::try_from(t).ok())
                    .ok_or("KHR_texture_transform.texCoord must be a non-negative integer")?,
            ),
        };
        Ok(Transform {
            offset: pair("offset", Vec2::ZERO)?,
            rotation,
            scale: pair("scale", Vec2::ONE)?,
            tex_coord,
        })
    }
}

fn wrap(w: gltf::texture::WrappingMode) -> Wrap {
    match w {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

fn decode_image(
    img: &gltf::Image,
    base: Option<&Path>,
    buffers: &[Vec<u8>],
    budget: &mut u64,
) -> Result<(u32, u32, Vec<Vec4>), String> {
    let encoded = match img.source() {
        gltf::image::Source::View { view, .. } => {
            let buf = buffers
                .get(view.buffer().index())
                .ok_or("buffer view refers to a missing buffer")?;
            let end = view.offset().checked_add(view.length()).ok_or("buffer view overflows")?;
            buf.get(view.offset()..end).ok_or("buffer view lies outside its buffer")?.to_vec()
        }
        gltf::image::Source::Uri { uri, .. } => uri::resolve(uri, base)?,
    };
    let reader = image::ImageReader::new(std::io::Cursor::new(&encoded))
        .with_guessed_format()
        .map_err(|e| format!("cannot read image: {e}"))?;
    let (w, h) = reader.into_dimensions().map_err(|e| format!("not a PNG or JPEG image: {e}"))?;
    if w == 0 || h == 0 {
        return Err(format!("image is {w}×{h}"));
    }
    if w as u64 * h as u64 > *budget {
        return Err(format!(
            "image is {w}×{h}; a scene's textures may hold at most {MAX_TEXTURE_PIXELS} pixels in all ({} left)",
            *budget
        ));
    }
    *budget -= w as u64 * h as u64;
    let decoded =
        image::load_from_memory(&encoded).map_err(|e| format!("cannot decode image: {e}"))?;
    let texels = decoded.to_rgba32f().pixels().map(|p| Vec4::from(p.0)).collect();
    Ok((w, h, texels))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn transforms_are_read_and_checked() {
        let t =
            Transform::of_json(&json!({"offset": [0.5, 0.0], "scale": [2.0, 2.0], "texCoord": 1}))
                .unwrap();
        assert_eq!(
            t,
            Transform {
                offset: Vec2::new(0.5, 0.0),
                rotation: 0.0,
                scale: Vec2::splat(2.0),
                tex_coord: Some(1)
            }
        );
        assert_eq!(Transform::of_json(&json!({})).unwrap(), Transform::default());
        for bad in [
            json!({"offset": [1.0]}),
            json!({"scale": "big"}),
            json!({"rotation": [1]}),
            json!({"texCoord": -1}),
        ] {
            let e = Transform::of_json(&bad).unwrap_err();
            assert!(e.contains("KHR_texture_transform."), "{e}");
        }
    }
}
