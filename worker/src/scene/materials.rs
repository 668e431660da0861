//! glTF materials and textures → [`Material`] and [`Texture`].
use super::{SceneError, uri};
use crate::tracer::bsdf::{Pbr, Phong};
use crate::tracer::material::{Glass, Material, MaterialModel, TextureRef};
use crate::tracer::texture::{Texture, Wrap, srgb_to_linear};
use glam::{Vec3, Vec4};
use std::path::Path;

/// The project's extension carrying the seed's Phong/Lafortune BRDF:
/// `"TESSERA_materials_phong": {"kd": [r, g, b], "ks": [r, g, b], "n": exponent}` with kd + ks ≤ 1.
pub const PHONG_EXTENSION: &str = "TESSERA_materials_phong";

/// Most texture pixels a scene may decode, all images together (a guard against decompression
/// bombs: a few kilobytes of PNG can declare gigapixels; 2²⁶ pixels are 1 GiB as f32 RGBA).
const MAX_TEXTURE_PIXELS: u64 = 1 << 26;

pub fn default_material() -> Material {
    // glTF 2.0 default: base colour 1, metallic 1, roughness 1.
    let pbr = Pbr::new(Vec3::ONE, 1.0, 1.0);
    Material { model: MaterialModel::Pbr(pbr), ..Material::lambert("default", Vec3::ONE) }
}

pub fn load_materials(doc: &gltf::Document, texture_count: usize) -> Result<Vec<Material>, SceneError> {
    doc.materials().map(|m| material(&m, texture_count)).collect()
}

fn material(m: &gltf::Material, texture_count: usize) -> Result<Material, SceneError> {
    let i = m.index().unwrap_or(0);
    let at = |what: String| SceneError::new(format!("material {i}: {what}"));
    let pbr = m.pbr_metallic_roughness();
    let emission = Vec3::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0);
    if !emission.is_finite() || emission.min_element() < 0.0 {
        return Err(at(format!("emission {emission} must be finite and ≥ 0")));
    }
    let base_color_texture = match pbr.base_color_texture() {
        Some(info) if info.texture().index() >= texture_count => return Err(at("base colour texture does not exist".into())),
        Some(info) => Some(TextureRef { texture: info.texture().index() as u32, tex_coord: info.tex_coord() }),
        None => None,
    };
    let model = match m.extension_value(PHONG_EXTENSION) {
        Some(v) => MaterialModel::Phong(phong(v).map_err(at)?),
        None => MaterialModel::Pbr(metallic_roughness(m, &pbr).map_err(at)?),
    };
    let name = m.name().map_or_else(|| format!("material{i}"), str::to_string);
    let alpha = pbr.base_color_factor()[3];
    let alpha_cutoff = match m.alpha_mode() {
        gltf::material::AlphaMode::Mask => Some(m.alpha_cutoff().unwrap_or(0.5)),
        _ => None,
    };
    if !(0.0..=1.0).contains(&alpha) || alpha_cutoff.is_some_and(|c| !(c.is_finite() && c >= 0.0)) {
        return Err(at(format!("alpha {alpha} must be in [0, 1] and alphaCutoff finite and ≥ 0")));
    }
    let glass = glass(m, &pbr).map_err(at)?;
    Ok(Material { name, model, base_color_texture, emission, double_sided: m.double_sided(), alpha, alpha_cutoff, glass })
}

/// `KHR_materials_transmission` (+ `_ior`, `_volume`) → [`Glass`]; None without transmission.
/// Transmission, thickness and volume textures are not read (their factors are).
fn glass(m: &gltf::Material, pbr: &gltf::material::PbrMetallicRoughness) -> Result<Option<Glass>, String> {
    let Some(t) = m.transmission() else { return Ok(None) };
    let factor = t.transmission_factor();
    if !(0.0..=1.0).contains(&factor) {
        return Err(format!("transmissionFactor {factor} is outside [0, 1]"));
    }
    let weight = factor * (1.0 - pbr.metallic_factor());
    if weight <= 0.0 {
        return Ok(None);
    }
    let ior = m.ior().unwrap_or(1.5);
    let roughness = pbr.roughness_factor();
    let volume = m.volume().filter(|v| v.thickness_factor() > 0.0);
    let sigma_a = match &volume {
        Some(v) => {
            let (colour, distance) = (Vec3::from(v.attenuation_color()), v.attenuation_distance());
            if !(distance > 0.0) || !(colour.min_element() > 0.0 && colour.max_element() <= 1.0) {
                return Err(format!("KHR_materials_volume: attenuationDistance {distance} must be > 0 and attenuationColor {colour} in (0, 1]"));
            }
            // Infinite distance (the default) means no absorption.
            if distance.is_finite() { -colour.map(f32::ln) / distance } else { Vec3::ZERO }
        }
        None => Vec3::ZERO,
    };
    Ok(Some(Glass { weight, ior, alpha: roughness * roughness, thin: volume.is_none(), sigma_a }))
}

fn metallic_roughness(m: &gltf::Material, pbr: &gltf::material::PbrMetallicRoughness) -> Result<Pbr, String> {
    let base_color = Vec4::from(pbr.base_color_factor()).truncate();
    let (specular, specular_color) = m
        .specular()
        .map_or((1.0, Vec3::ONE), |s| (s.specular_factor(), Vec3::from(s.specular_color_factor())));
    let p = Pbr {
        base_color,
        metallic: pbr.metallic_factor(),
        roughness: pbr.roughness_factor(),
        specular,
        specular_color,
        ior: m.ior().unwrap_or(1.5),
    };
    let unit = [("metallicFactor", p.metallic), ("roughnessFactor", p.roughness), ("specularFactor", p.specular)];
    for (name, v) in unit {
        if !(0.0..=1.0).contains(&v) {
            return Err(format!("{name} {v} is outside [0, 1]"));
        }
    }
    if !(base_color.is_finite() && base_color.min_element() >= 0.0 && base_color.max_element() <= 1.0) {
        return Err(format!("baseColorFactor {base_color} is outside [0, 1]"));
    }
    if !(specular_color.is_finite() && specular_color.min_element() >= 0.0) {
        return Err(format!("specularColorFactor {specular_color} must be finite and ≥ 0"));
    }
    if !(p.ior >= 1.0 && p.ior.is_finite()) {
        return Err(format!("ior {} must be ≥ 1", p.ior));
    }
    Ok(p)
}

fn phong(v: &serde_json::Value) -> Result<Phong, String> {
    let rgb = |key: &str| -> Result<Vec3, String> {
        let a = v.get(key).and_then(|x| x.as_array()).ok_or(format!("{PHONG_EXTENSION}.{key} must be an array of 3 numbers"))?;
        let c: Vec<f32> = a.iter().filter_map(|x| x.as_f64()).map(|x| x as f32).collect();
        match c[..] {
            [r, g, b] if a.len() == 3 => Ok(Vec3::new(r, g, b)),
            _ => Err(format!("{PHONG_EXTENSION}.{key} must be an array of 3 numbers")),
        }
    };
    let n = v.get("n").and_then(|x| x.as_f64()).ok_or(format!("{PHONG_EXTENSION}.n must be a number"))? as f32;
    Phong::new(rgb("kd")?, rgb("ks")?, n).map_err(|e| format!("{PHONG_EXTENSION}: {e}"))
}

/// Decodes every texture's image (colour textures: sRGB → linear).
pub fn load_textures(doc: &gltf::Document, base: Option<&Path>, buffers: &[Vec<u8>]) -> Result<Vec<Texture>, SceneError> {
    let mut images: Vec<Option<(u32, u32, Vec<Vec4>)>> = vec![None; doc.images().len()];
    let mut out = Vec::new();
    let mut budget = MAX_TEXTURE_PIXELS;
    for tex in doc.textures() {
        let img = tex.source();
        let at = |what: String| SceneError::new(format!("texture {} (image {}): {what}", tex.index(), img.index()));
        if images[img.index()].is_none() {
            images[img.index()] = Some(decode_image(&img, base, buffers, &mut budget).map_err(at)?);
        }
        let (width, height, texels) = images[img.index()].clone().expect("decoded above");
        let sampler = tex.sampler();
        out.push(Texture { width, height, texels, wrap_s: wrap(sampler.wrap_s()), wrap_t: wrap(sampler.wrap_t()) });
    }
    Ok(out)
}

fn wrap(w: gltf::texture::WrappingMode) -> Wrap {
    match w {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
    }
}

fn decode_image(img: &gltf::Image, base: Option<&Path>, buffers: &[Vec<u8>], budget: &mut u64) -> Result<(u32, u32, Vec<Vec4>), String> {
    let encoded = match img.source() {
        gltf::image::Source::View { view, .. } => {
            let buf = buffers.get(view.buffer().index()).ok_or("buffer view refers to a missing buffer")?;
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
        return Err(format!("image is {w}×{h}; a scene's textures may hold at most {MAX_TEXTURE_PIXELS} pixels in all ({} left)", *budget));
    }
    *budget -= w as u64 * h as u64;
    let decoded = image::load_from_memory(&encoded).map_err(|e| format!("cannot decode image: {e}"))?;
    let rgba = decoded.to_rgba32f();
    let texels = rgba
        .pixels()
        .map(|p| Vec4::new(srgb_to_linear(p[0]), srgb_to_linear(p[1]), srgb_to_linear(p[2]), p[3]))
        .collect();
    Ok((w, h, texels))
}
