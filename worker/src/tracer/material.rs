//! Surface materials as loaded from glTF, turned into a [`Bsdf`] at each hit.
//!
//! - `Pbr`: glTF 2.0 metallic-roughness (Appendix B) with `KHR_materials_specular` and
//!   `KHR_materials_ior`. With metallic = 0 and specular = 0 it is exactly Lambert, and is
//!   dispatched as [`Bsdf::Lambert`] so a matte scene never pays for the microfacet code.
//! - `Phong`: the project's `TESSERA_materials_phong` extension, the seed's Lafortune/Phong model.
//!
//! - `glass` (`KHR_materials_transmission`, `_ior`, `_volume`): with probability
//!   transmission × (1 − metallic) a hit is a [`Dielectric`] (a one-sample estimate of glTF's
//!   mix of the BTDF with the opaque model), tinted by the base colour; thin-walled unless the
//!   material has a volume (`thicknessFactor` > 0), in which case light inside is attenuated by
//!   Beer–Lambert with σ = −ln(attenuationColor)/attenuationDistance.
//! - `alpha_cutoff` (`alphaMode: MASK`): a hit whose alpha (base colour factor × texture alpha)
//!   is below the cutoff is not a hit at all; rays pass through.
//!
//! Emission is radiance (W·m⁻²·sr⁻¹, linear RGB) = `emissiveFactor × emissiveStrength`, leaving
//! the front face (counter-clockwise winding) only, unless the material is double-sided.
use crate::tracer::bsdf::{Bsdf, Dielectric, Lambert, Pbr, Phong};
use crate::tracer::effects::EffectSet;
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
    /// Base colour factor alpha (with `alpha_cutoff`).
    pub alpha: f32,
    /// `alphaMode: MASK`: hits with alpha below this are cut out.
    pub alpha_cutoff: Option<f32>,
    pub glass: Option<Glass>,
}

/// Transmission parameters of a glass material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Glass {
    /// transmissionFactor × (1 − metallic): the probability that a hit refracts.
    pub weight: f32,
    pub ior: f32,
    /// GGX width α = roughness².
    pub alpha: f32,
    /// No volume: a thin sheet.
    pub thin: bool,
    /// Absorption coefficient per metre inside the volume (zero: clear).
    pub sigma_a: Vec3,
}

impl Glass {
    pub fn absorbs(&self) -> bool {
        !self.thin && self.sigma_a.max_element() > 0.0
    }
}

impl Material {
    pub fn lambert(name: &str, albedo: Vec3) -> Material {
        Material {
            name: name.to_string(),
            model: MaterialModel::Pbr(Pbr { specular: 0.0, ..Pbr::new(albedo, 0.0, 1.0) }),
            base_color_texture: None,
            emission: Vec3::ZERO,
            double_sided: false,
            alpha: 1.0,
            alpha_cutoff: None,
            glass: None,
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.max_element() > 0.0
    }

    /// The BSDF at a hit with texture coordinates `uv` (the material's UV set already chosen),
    /// as kernel `E` sees it: without `E::SURFACES`, Lambert with the constant base colour;
    /// without `E::GLASS`, never glass. `u_glass` chooses glass for partly transmissive
    /// materials; `entering`: the hit is on the front face.
    #[inline]
    pub fn bsdf_for<E: EffectSet>(&self, uv: Vec2, textures: &[Texture], u_glass: f32, entering: bool) -> Bsdf {
        if E::GLASS && let Some(g) = self.glass && u_glass < g.weight {
            let base = match &self.model {
                MaterialModel::Pbr(p) => p.base_color,
                MaterialModel::Phong(p) => p.kd(),
            };
            let tint = if E::SURFACES { base * self.tint(uv, textures) } else { base };
            let eta = if g.thin || entering { g.ior } else { 1.0 / g.ior };
            return Bsdf::Dielectric(Dielectric { eta, alpha: g.alpha, tint, thin: g.thin });
        }
        if !E::SURFACES {
            return match &self.model {
                MaterialModel::Pbr(p) => Bsdf::Lambert(Lambert { albedo: p.base_color }),
                MaterialModel::Phong(p) => Bsdf::Phong(*p),
            };
        }
        self.bsdf(uv, textures)
    }

    fn tint(&self, uv: Vec2, textures: &[Texture]) -> Vec3 {
        self.base_color_texture.map_or(Vec3::ONE, |t| textures[t.texture as usize].sample(uv).truncate())
    }

    /// Alpha at `uv`: the factor times the base-colour texture's alpha.
    pub fn alpha_at(&self, uv: Vec2, textures: &[Texture]) -> f32 {
        self.base_color_texture.map_or(self.alpha, |t| self.alpha * textures[t.texture as usize].sample(uv).w)
    }

    /// The opaque BSDF at a hit with texture coordinates `uv` (the material's UV set already chosen).
    pub fn bsdf(&self, uv: Vec2, textures: &[Texture]) -> Bsdf {
        let tint = self.tint(uv, textures);
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
