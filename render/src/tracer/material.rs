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
//! Emission is radiance (W·m⁻²·sr⁻¹, linear RGB) = `emissiveFactor × emissiveStrength`
//! (× the sRGB-decoded `emissiveTexture` at the point), leaving the front face
//! (counter-clockwise winding) only, unless the material is double-sided.
//!
//! Textures (each with its UV set and `KHR_texture_transform`, see [`TextureRef`]):
//! `baseColorTexture` (sRGB, multiplies the base colour / kd and its alpha),
//! `metallicRoughnessTexture` (linear; B multiplies metallic, G roughness),
//! `normalTexture` (linear, tangent space, with `scale`; applied in [`crate::tracer::normal_map`]),
//! `emissiveTexture` (sRGB, multiplies the emission). Textures hold values in [0, 1], so a
//! texture can only darken its factor: a material black by its factors stays black.
use crate::tracer::bsdf::{Bsdf, Dielectric, Lambert, Pbr, Phong};
use crate::tracer::kernel::EffectSet;
use crate::tracer::texture::Texture;
pub use crate::tracer::texture::TextureRef;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub enum MaterialModel {
    Pbr(Pbr),
    Phong(Phong),
}

/// A tangent-space normal map: n = normalize((2c − 1)·(scale, scale, 1)) in (T, B, N).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NormalTexture {
    pub texture: TextureRef,
    pub scale: f32,
}

#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub model: MaterialModel,
    /// Multiplies the base colour (Pbr) or kd (Phong).
    pub base_color_texture: Option<TextureRef>,
    /// B multiplies metallic, G multiplies roughness (Pbr only).
    pub metallic_roughness_texture: Option<TextureRef>,
    pub normal_texture: Option<NormalTexture>,
    /// Multiplies `emission`.
    pub emissive_texture: Option<TextureRef>,
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
            metallic_roughness_texture: None,
            normal_texture: None,
            emissive_texture: None,
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

    /// Whether any hit on this material can scatter light (by its factors; textures only
    /// darken them). A scene whose materials all fail this needs no bounce at all.
    pub fn scatters(&self) -> bool {
        self.glass.is_some()
            || !match &self.model {
                MaterialModel::Pbr(p) => Bsdf::Pbr(*p).is_black(),
                MaterialModel::Phong(p) => Bsdf::Phong(*p).is_black(),
            }
    }

    /// The BSDF at a hit with texture coordinates `uvs` (both UV sets), as kernel `E` sees it: without `E::SURFACES`, Lambert with the constant base colour;
    /// without `E::GLASS`, never glass. `u_glass` chooses glass for partly transmissive
    /// materials; `entering`: the hit is on the front face.
    #[inline]
    pub fn bsdf_for<E: EffectSet>(
        &self,
        uvs: &[Vec2; 2],
        textures: &[Texture],
        u_glass: f32,
        entering: bool,
    ) -> Bsdf {
        if E::GLASS
            && let Some(g) = self.glass
            && u_glass < g.weight
        {
            let base = match &self.model {
                MaterialModel::Pbr(p) => p.base_color,
                MaterialModel::Phong(p) => p.kd(),
            };
            let tint = if E::SURFACES { base * self.tint(uvs, textures) } else { base };
            let eta = if g.thin || entering { g.ior } else { 1.0 / g.ior };
            return Bsdf::Dielectric(Dielectric { eta, alpha: g.alpha, tint, thin: g.thin });
        }
        if !E::SURFACES {
            return match &self.model {
                MaterialModel::Pbr(p) => Bsdf::Lambert(Lambert { albedo: p.base_color }),
                MaterialModel::Phong(p) => Bsdf::Phong(*p),
            };
        }
        self.bsdf(uvs, textures)
    }

    fn tint(&self, uvs: &[Vec2; 2], textures: &[Texture]) -> Vec3 {
        self.base_color_texture.map_or(Vec3::ONE, |t| t.sample(textures, uvs).truncate())
    }

    /// Alpha at a point: the factor times the base-colour texture's alpha.
    pub fn alpha_at(&self, uvs: &[Vec2; 2], textures: &[Texture]) -> f32 {
        self.base_color_texture.map_or(self.alpha, |t| self.alpha * t.sample(textures, uvs).w)
    }

    /// Emitted radiance at a point (towards the front), with the emissive texture.
    pub fn emission_at(&self, uvs: &[Vec2; 2], textures: &[Texture]) -> Vec3 {
        self.emissive_texture
            .map_or(self.emission, |t| self.emission * t.sample(textures, uvs).truncate())
    }

    /// The opaque BSDF at a hit with texture coordinates `uvs` (both UV sets).
    pub fn bsdf(&self, uvs: &[Vec2; 2], textures: &[Texture]) -> Bsdf {
        let tint = self.tint(uvs, textures);
        match &self.model {
            MaterialModel::Pbr(p) => {
                let base_color = p.base_color * tint;
                let (mut metallic, mut roughness) = (p.metallic, p.roughness);
                if let Some(t) = self.metallic_roughness_texture {
                    let texel = t.sample(textures, uvs);
                    (metallic, roughness) = (metallic * texel.z, roughness * texel.y);
                }
                if metallic == 0.0 && p.specular == 0.0 {
                    Bsdf::Lambert(Lambert { albedo: base_color })
                } else {
                    Bsdf::Pbr(Pbr { base_color, metallic, roughness, ..*p })
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
