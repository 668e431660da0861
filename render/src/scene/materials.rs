//! glTF materials → [`Material`]: factors, the four texture slots (base colour, emissive:
//! sRGB; metallic-roughness, normal: linear; each with `KHR_texture_transform`), and the
//! extensions listed in [`crate::scene`].
use super::SceneError;
use super::textures::{ColourSpace, TexturePool, Transform};
use crate::tracer::bsdf::{Pbr, Phong};
use crate::tracer::material::{Glass, Material, MaterialModel, NormalTexture, TextureRef};
use glam::{Vec3, Vec4};

/// The project's extension carrying the seed's Phong/Lafortune BRDF:
/// `"TESSERA_materials_phong": {"kd": [r, g, b], "ks": [r, g, b], "n": exponent}` with kd + ks ≤ 1.
pub const PHONG_EXTENSION: &str = "TESSERA_materials_phong";

pub fn default_material() -> Material {
    // glTF 2.0 default: base colour 1, metallic 1, roughness 1.
    let pbr = Pbr::new(Vec3::ONE, 1.0, 1.0);
    Material { model: MaterialModel::Pbr(pbr), ..Material::lambert("default", Vec3::ONE) }
}

pub fn load_materials(
    doc: &gltf::Document,
    pool: &mut TexturePool,
) -> Result<Vec<Material>, SceneError> {
    doc.materials().map(|m| material(&m, pool)).collect()
}

/// The binding of a `textureInfo` slot.
fn info(
    slot: &str,
    info: Option<gltf::texture::Info>,
    pool: &mut TexturePool,
    space: ColourSpace,
) -> Result<Option<TextureRef>, String> {
    let Some(info) = info else { return Ok(None) };
    let t = pool.bind(info.texture().index(), info.tex_coord(), Transform::of_info(&info), space);
    t.map(Some).map_err(|e| format!("{slot}: {e}"))
}

fn normal_texture(
    m: &gltf::Material,
    pool: &mut TexturePool,
) -> Result<Option<NormalTexture>, String> {
    let Some(n) = m.normal_texture() else { return Ok(None) };
    let at = |e: String| format!("normalTexture: {e}");
    let transform = n
        .extension_value("KHR_texture_transform")
        .map(Transform::of_json)
        .transpose()
        .map_err(at)?;
    let texture = pool
        .bind(n.texture().index(), n.tex_coord(), transform, ColourSpace::Linear)
        .map_err(at)?;
    if !n.scale().is_finite() {
        return Err(at(format!("scale {} must be finite", n.scale())));
    }
    Ok(Some(NormalTexture { texture, scale: n.scale() }))
}

fn material(m: &gltf::Material, pool: &mut TexturePool) -> Result<Material, SceneError> {
    let i = m.index().unwrap_or(0);
    let at = |what: String| SceneError::new(format!("material {i}: {what}"));
    let pbr = m.pbr_metallic_roughness();
    let emission = Vec3::from(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0);
    if !emission.is_finite() || emission.min_element() < 0.0 {
        return Err(at(format!("emission {emission} must be finite and ≥ 0")));
    }
    let base_color_texture =
        info("baseColorTexture", pbr.base_color_texture(), pool, ColourSpace::Srgb).map_err(at)?;
    let metallic_roughness_texture = info(
        "metallicRoughnessTexture",
        pbr.metallic_roughness_texture(),
        pool,
        ColourSpace::Linear,
    )
    .map_err(at)?;
    let emissive_texture =
        info("emissiveTexture", m.emissive_texture(), pool, ColourSpace::Srgb).map_err(at)?;
    let normal_texture = normal_texture(m, pool).map_err(at)?;
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
    Ok(Material {
        name,
        model,
        base_color_texture,
        metallic_roughness_texture,
        normal_texture,
        emissive_texture,
        emission,
        double_sided: m.double_sided(),
        alpha,
        alpha_cutoff,
        glass,
    })
}

/// `KHR_materials_transmission` (+ `_ior`, `_volume`) → [`Glass`]; None without transmission.
/// Transmission, thickness and volume textures are not read (their factors are).
fn glass(
    m: &gltf::Material,
    pbr: &gltf::material::PbrMetallicRoughness,
) -> Result<Option<Glass>, String> {
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
            if !(distance > 0.0 && colour.min_element() > 0.0 && colour.max_element() <= 1.0) {
                return Err(format!(
                    "KHR_materials_volume: attenuationDistance {distance} must be > 0 and attenuationColor {colour} in (0, 1]"
                ));
            }
            // Infinite distance (the default) means no absorption.
            if distance.is_finite() { -colour.map(f32::ln) / distance } else { Vec3::ZERO }
        }
        None => Vec3::ZERO,
    };
    Ok(Some(Glass { weight, ior, alpha: roughness * roughness, thin: volume.is_none(), sigma_a }))
}

fn metallic_roughness(
    m: &gltf::Material,
    pbr: &gltf::material::PbrMetallicRoughness,
) -> Result<Pbr, String> {
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
    let unit = [
        ("metallicFactor", p.metallic),
        ("roughnessFactor", p.roughness),
        ("specularFactor", p.specular),
    ];
    for (name, v) in unit {
        if !(0.0..=1.0).contains(&v) {
            return Err(format!("{name} {v} is outside [0, 1]"));
        }
    }
    if !(base_color.is_finite()
        && base_color.min_element() >= 0.0
        && base_color.max_element() <= 1.0)
    {
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
        let a = v
            .get(key)
            .and_then(|x| x.as_array())
            .ok_or(format!("{PHONG_EXTENSION}.{key} must be an array of 3 numbers"))?;
        let c: Vec<f32> = a.iter().filter_map(|x| x.as_f64()).map(|x| x as f32).collect();
        match c[..] {
            [r, g, b] if a.len() == 3 => Ok(Vec3::new(r, g, b)),
            _ => Err(format!("{PHONG_EXTENSION}.{key} must be an array of 3 numbers")),
        }
    };
    let n = v
        .get("n")
        .and_then(|x| x.as_f64())
        .ok_or(format!("{PHONG_EXTENSION}.n must be a number"))? as f32;
    Phong::new(rgb("kd")?, rgb("ks")?, n).map_err(|e| format!("{PHONG_EXTENSION}: {e}"))
}
