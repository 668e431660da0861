//! Surface materials as loaded from glTF, turned into a [`Bsdf`] at each hit.
//!
//! - `Pbr`: glTF 2.0 metallic-roughness (Appendix B) with `KHR_materials_specular` and
//!   `KHR_materials_ior`. With metallic = 0 and specular = 0 it is exactly Lambert, and is
//!   dispatched as [`Bsdf::Lambert`] so a matte scene never pays for the microfacet code.
//! - `Phong`: the project's `TESSERA_materials_phong` extension, the seed's Lafortune/Phong model.
//!
//! Emission is radiance (W·m⁻²·sr⁻¹, linear RGB) = `emissiveFactor × emissiveStrength`, leaving
//! the front face (counter-clockwise winding) only, unless the material is double-sided.
use crate::tracer::bsdf::{Bsdf, Lambert, Pbr, Phong};
use crate::tracer::texture::Texture;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub enum MaterialModel {
    Pbr(Pbr),
    Phong(Phong),
}

/// A texture binding: which texture, which UV set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextureRef {
    pub texture: u32,
    pub tex_coord: u32,
}

#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub model: MaterialModel,
    /// Multiplies the base colour (Pbr) or kd (Phong).
    pub base_color_texture: Option<TextureRef>,
    pub emission: Vec3,
    pub double_sided: bool,
}

impl Material {
    pub fn lambert(name: &str, albedo: Vec3) -> Material {
        Material {
            name: name.to_string(),
            model: MaterialModel::Pbr(Pbr { specular: 0.0, ..Pbr::new(albedo, 0.0, 1.0) }),
            base_color_texture: None,
            emission: Vec3::ZERO,
            double_sided: false,
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// The BSDF at a hit with texture coordinates `uv` (the material's UV set already chosen).
    pub fn bsdf(&self, uv: Vec2, textures: &[Texture]) -> Bsdf {
        let tint = self
            .base_color_texture
            .map_or(Vec3::ONE, |t| textures[t.texture as usize].sample(uv).truncate());
        match &self.model {
            MaterialModel::Pbr(p) => {
                let base_color = p.base_color * tint;
                if p.metallic == 0.0 && p.specular == 0.0 {
                    Bsdf::Lambert(Lambert { albedo: base_color })
                } else {
                    Bsdf::Pbr(Pbr { base_color, ..*p })
                }
            }
            MaterialModel::Phong(p) => {
                // A tint in [0, 1] keeps kd + ks ≤ 1, so this cannot fail; keep the untinted lobe if it did.
                Bsdf::Phong(Phong::new(p.kd() * tint, p.ks(), p.n()).unwrap_or(*p))
            }
        }
    }

    /// Emitted radiance leaving the surface towards `wo`, given the geometric normal `ng`.
    pub fn emitted(&self, ng: Vec3, wo: Vec3) -> Vec3 {
        if self.double_sided || ng.dot(wo) > 0.0 { self.emission } else { Vec3::ZERO }
    }
}
