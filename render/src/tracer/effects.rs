//! Which light-transport effects a scene calls for, and the integrator kernel they select
//! (the kernels themselves: [`crate::tracer::kernel`]).
//!
//! [`Effects`] is the scene analysis: a set of named effects computed once per scene (and the
//! job's background). The names are what the coordinator reports (`"effects": [...]`).
//!
//! Gating: effects are grouped into kernel bits ([`KernelBits`]); the integrator and the tile
//! loop are generic over an [`EffectSet`] whose associated consts are those bits, and
//! `dispatch_kernel!` instantiates one monomorphized kernel per bit combination. Code for an
//! absent effect is behind `if E::GLASS { … }` with a constant condition, so the compiler
//! removes it from that kernel: a matte scene runs a kernel that contains no glass, alpha,
//! lens or texture code at all, not one that branches around it per sample.
//!
//! Normal maps are folded into `SURFACES` rather than given a fifth bit (32 kernels, twice the
//! compile time): the matte kernel has no normal-map code; a textured kernel checks the
//! material's `normal_texture` once per hit, next to the texture lookups it does anyway.
//!
//! Depth: [`Effects::NO_SCATTERING`] (no used material can scatter) lets a render stop every
//! path at its first hit; see [`crate::tracer::Scene::needed_depth`].
use crate::tracer::kernel::KernelBits;
use crate::tracer::light::Light;
use crate::tracer::material::{Material, MaterialModel};

/// A set of effects, one bit each.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Effects(pub u32);

impl Effects {
    pub const AREA_LIGHTS: Effects = Effects(1 << 0);
    pub const POINT_LIGHTS: Effects = Effects(1 << 1);
    pub const SPOT_LIGHTS: Effects = Effects(1 << 2);
    pub const DIRECTIONAL_LIGHTS: Effects = Effects(1 << 3);
    pub const BACKGROUND: Effects = Effects(1 << 4);
    pub const LAMBERT: Effects = Effects(1 << 5);
    pub const GGX: Effects = Effects(1 << 6);
    pub const PHONG: Effects = Effects(1 << 7);
    pub const TEXTURES: Effects = Effects(1 << 8);
    pub const GLASS: Effects = Effects(1 << 9);
    pub const ABSORPTION: Effects = Effects(1 << 10);
    pub const ALPHA_MASK: Effects = Effects(1 << 11);
    pub const DEPTH_OF_FIELD: Effects = Effects(1 << 12);
    pub const NORMAL_MAPS: Effects = Effects(1 << 13);
    /// Not an effect but its absence: no material can scatter light, so a path needs no
    /// bounce (the camera sees emitters and black); reported as the depth limit "max_depth=0".
    pub const NO_SCATTERING: Effects = Effects(1 << 14);
    /// Area lights that the `auto` light sampler chooses among through the scene's light tree
    /// (many, or a few that differ in what they give the surfaces:
    /// [`LightTree::suits`](crate::tracer::light::LightTree::suits)); others are chosen by
    /// power, at no cost for the tree. Set where the scene's lights are made (when it is built,
    /// or, for a scene not yet built, by the same function), not by [`Effects::analyse`].
    pub const LIGHT_TREE: Effects = Effects(1 << 15);
    pub const NONE: Effects = Effects(0);

    /// Every effect with its reported name, in report order.
    pub const NAMED: [(Effects, &'static str); 16] = [
        (Effects::ABSORPTION, "absorption"),
        (Effects::ALPHA_MASK, "alpha_mask"),
        (Effects::AREA_LIGHTS, "area_lights"),
        (Effects::BACKGROUND, "background"),
        (Effects::DEPTH_OF_FIELD, "depth_of_field"),
        (Effects::DIRECTIONAL_LIGHTS, "directional_lights"),
        (Effects::GGX, "ggx"),
        (Effects::GLASS, "glass"),
        (Effects::LAMBERT, "lambert"),
        (Effects::LIGHT_TREE, "light_tree"),
        (Effects::NO_SCATTERING, "max_depth=0"),
        (Effects::NORMAL_MAPS, "normal_maps"),
        (Effects::PHONG, "phong"),
        (Effects::POINT_LIGHTS, "point_lights"),
        (Effects::SPOT_LIGHTS, "spot_lights"),
        (Effects::TEXTURES, "textures"),
    ];

    pub fn contains(self, other: Effects) -> bool {
        self.0 & other.0 == other.0
    }

    pub fn intersects(self, other: Effects) -> bool {
        self.0 & other.0 != 0
    }

    pub fn names(self) -> Vec<String> {
        Effects::NAMED
            .iter()
            .filter(|(e, _)| self.contains(*e))
            .map(|(_, n)| n.to_string())
            .collect()
    }

    /// The effects of the materials used by `used_materials` and of `lights`.
    pub fn analyse<'m>(
        used_materials: impl Iterator<Item = &'m Material>,
        lights: &[Light],
    ) -> Effects {
        let (mut e, mut scatters) = (Effects::NONE, false);
        for m in used_materials {
            e = e | m.effects();
            scatters |= m.scatters();
        }
        if !scatters {
            e = e | Effects::NO_SCATTERING;
        }
        for l in lights {
            e = e | match l {
                Light::Point { .. } => Effects::POINT_LIGHTS,
                Light::Spot { .. } => Effects::SPOT_LIGHTS,
                Light::Directional { .. } => Effects::DIRECTIONAL_LIGHTS,
                Light::Triangle { .. } => Effects::AREA_LIGHTS,
                Light::Background { .. } => Effects::BACKGROUND,
            };
        }
        e
    }

    /// The kernel that covers these effects and nothing more.
    pub fn kernel(self) -> KernelBits {
        let mut k = 0;
        if self.intersects(Effects(
            Effects::GGX.0 | Effects::PHONG.0 | Effects::TEXTURES.0 | Effects::NORMAL_MAPS.0,
        )) {
            k |= KernelBits::SURFACES;
        }
        if self.intersects(Effects(Effects::GLASS.0 | Effects::ABSORPTION.0)) {
            k |= KernelBits::GLASS;
        }
        if self.contains(Effects::ALPHA_MASK) {
            k |= KernelBits::ALPHA;
        }
        if self.contains(Effects::DEPTH_OF_FIELD) {
            k |= KernelBits::DOF;
        }
        KernelBits(k)
    }
}

impl std::ops::BitOr for Effects {
    type Output = Effects;
    fn bitor(self, o: Effects) -> Effects {
        Effects(self.0 | o.0)
    }
}

impl Material {
    /// The effects this material calls for.
    pub fn effects(&self) -> Effects {
        let mut e = if self.is_emissive() { Effects::AREA_LIGHTS } else { Effects::NONE };
        e = e | match &self.model {
            MaterialModel::Pbr(p) if p.metallic == 0.0 && p.specular == 0.0 => Effects::LAMBERT,
            MaterialModel::Pbr(_) => Effects::GGX,
            MaterialModel::Phong(_) => Effects::PHONG,
        };
        let textures =
            [self.base_color_texture, self.metallic_roughness_texture, self.emissive_texture];
        if textures.iter().any(Option::is_some) || self.normal_texture.is_some() {
            e = e | Effects::TEXTURES;
        }
        if self.normal_texture.is_some() {
            e = e | Effects::NORMAL_MAPS;
        }
        if self.glass.is_some() {
            e = e | Effects::GLASS;
        }
        if self.glass.is_some_and(|g| g.absorbs()) {
            e = e | Effects::ABSORPTION;
        }
        if self.alpha_cutoff.is_some() {
            e = e | Effects::ALPHA_MASK;
        }
        e
    }
}

#[cfg(test)]
mod tests;
