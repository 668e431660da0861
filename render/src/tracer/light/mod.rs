//! Lights: emissive triangles, glTF punctual lights and a constant background, as one closed set.
//!
//! | kind          | source                              | quantity (linear RGB)                  |
//! |---------------|-------------------------------------|----------------------------------------|
//! | `Triangle`    | a triangle whose material emits     | radiance L (W·m⁻²·sr⁻¹)                |
//! | `Point`       | `KHR_lights_punctual` "point"       | intensity I (W·sr⁻¹; glTF candela × colour) |
//! | `Spot`        | `KHR_lights_punctual` "spot"        | intensity I, glTF's smooth cone falloff |
//! | `Directional` | `KHR_lights_punctual` "directional" | irradiance E (W·m⁻²; glTF lux × colour) |
//! | `Background`  | the job's `background` setting       | radiance L from every direction        |
//!
//! glTF's photometric units are used as radiometric ones (no 683 lm/W factor): a light of
//! intensity 1 in the file gives radiance of order 1 in the image. Point, spot and directional
//! lights are delta lights: they are reached only by light sampling, never by a BSDF ray.
//! A [`LightSet`] picks lights in proportion to their power, so dim lights cost little; a scene
//! with many area lights ([`LightTree::MIN_LIGHTS`]), or a few that differ in what they give
//! its surfaces ([`LightTree::suits`]), picks among those through a [`LightTree`] instead, by
//! what each can give the point being lit (`tree/mod.rs`, `tree/auto.rs`).
//!
//! A triangle whose material has an `emissiveTexture` emits radiance × texture(uv): light
//! sampling picks a point uniformly on the triangle and evaluates the texture exactly there,
//! the same function a BSDF ray that hits the point evaluates, so light-sampling and BSDF
//! estimates (and their MIS weights, which depend on geometry and the choice probability only)
//! agree. The power used to *choose* the light takes the texture's mean texel instead of the
//! texels the triangle covers: any positive choice probability keeps the estimate unbiased;
//! this one only costs variance when a triangle maps a region much brighter or darker than
//! the whole image.
use crate::tracer::accel::triangle_normal;
use crate::tracer::kernel::{AllEffects, EffectSet};
use crate::tracer::ray::ErrPoint;
use crate::tracer::sampler::ONE_MINUS_EPSILON;
use crate::tracer::sampling::{Frame, cosine_hemisphere, luminance, uniform_triangle};
pub use crate::tracer::texture::EmissiveTexture;
use crate::tracer::texture::Texture;
use glam::{DVec3, Vec2, Vec3};
use std::f32::consts::PI;

mod tree;
pub use tree::{LightSampler, LightTree, Spread, UnknownLightSampler};

#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    /// `plane`: the f64 unit normal and offset n·v0, so that the height of a point above the
    /// plane (hence the cosine at the light) is exact for points in or near the plane.
    /// `texture`: the material's emissive texture (radiance × texel), boxed to keep
    /// untextured lights small.
    Triangle {
        tri: u32,
        v: [Vec3; 3],
        n: Vec3,
        plane: (DVec3, f64),
        area: f32,
        radiance: Vec3,
        two_sided: bool,
        texture: Option<Box<EmissiveTexture>>,
    },
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Spot {
        position: Vec3,
        axis: Vec3,
        intensity: Vec3,
        cos_inner: f32,
        cos_outer: f32,
    },
    Directional {
        dir: Vec3,
        irradiance: Vec3,
    },
    Background {
        radiance: Vec3,
    },
}

/// Where a light sample lies, for the shadow ray.
#[derive(Clone, Copy, Debug)]
pub enum Target {
    /// A point on a surface (normal `ng`) or a punctual light (`ng` zero).
    Point { p: ErrPoint, ng: Vec3 },
    /// Infinitely far along `wi`.
    Infinite,
}

#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Radiance arriving along `wi` (for delta lights: the delta's weight, e.g. I/d²).
    pub li: Vec3,
    /// Unit direction towards the light.
    pub wi: Vec3,
    /// Solid-angle density including the choice of light; for delta lights the choice probability.
    pub pdf: f32,
    pub delta: bool,
    pub target: Target,
}

impl Light {
    /// An area light for triangle `tri`; None for [degenerate](triangle_normal) triangles
    /// (zero area, needles), which then have zero probability of being sampled.
    pub fn triangle(tri: u32, v: &[Vec3; 3], radiance: Vec3, two_sided: bool) -> Option<Light> {
        let n = triangle_normal(v)?;
        let d = v.map(|p| p.as_dvec3());
        let area = (0.5 * (d[1] - d[0]).cross(d[2] - d[0]).length()) as f32;
        let plane = (n, n.dot(d[0]));
        (area > 0.0 && area.is_finite()).then_some(Light::Triangle {
            tri,
            v: *v,
            n: n.as_vec3(),
            plane,
            area,
            radiance,
            two_sided,
            texture: None,
        })
    }

    /// This area light with an emissive texture.
    pub fn with_texture(mut self, t: EmissiveTexture) -> Light {
        if let Light::Triangle { texture, .. } = &mut self {
            *texture = Some(Box::new(t));
        }
        self
    }

    /// Emitted power (luminance), used only to choose lights in proportion to it.
    fn power(&self, scene_radius: f32) -> f32 {
        let disc = PI * scene_radius * scene_radius;
        match self {
            Light::Triangle { area, radiance, two_sided, texture, .. } => {
                let mean = texture.as_ref().map_or(Vec3::ONE, |t| t.mean);
                luminance(*radiance * mean) * area * PI * if *two_sided { 2.0 } else { 1.0 }
            }
            Light::Point { intensity, .. } => 4.0 * PI * luminance(*intensity),
            Light::Spot { intensity, cos_inner, cos_outer, .. } => {
                2.0 * PI * luminance(*intensity) * (1.0 - 0.5 * (cos_inner + cos_outer))
            }
            Light::Directional { irradiance, .. } => disc * luminance(*irradiance),
            Light::Background { radiance } => disc * PI * luminance(*radiance),
        }
    }

    /// Samples incident light at `p` (shading normal `n`), ignoring visibility and choice
    /// probability; kernels without `E::SURFACES` ignore emissive textures.
    fn sample<E: EffectSet>(
        &self,
        p: Vec3,
        n: Vec3,
        u: Vec2,
        textures: &[Texture],
    ) -> Option<LightSample> {
        match *self {
            Light::Triangle { v, n: ln, plane, area, radiance, two_sided, ref texture, .. } => {
                let (b1, b2) = uniform_triangle(u);
                let q = ErrPoint::from_barycentric(&v, 1.0 - b1 - b2, b1, b2);
                let d = q.p - p;
                let dist2 = d.length_squared();
                let dist = dist2.sqrt();
                let wi = d / dist;
                let cos_l = cos_at_light(plane, p, dist);
                if !(cos_l > 0.0 || two_sided && cos_l < 0.0) {
                    return None;
                }
                let pdf = dist2 / (cos_l.abs() * area);
                let li = match texture {
                    Some(t) if E::SURFACES => radiance * t.at(textures, [1.0 - b1 - b2, b1, b2]),
                    _ => radiance,
                };
                (pdf.is_finite() && pdf > 0.0).then_some(LightSample {
                    li,
                    wi,
                    pdf,
                    delta: false,
                    target: Target::Point { p: q, ng: ln },
                })
            }
            Light::Point { position, intensity } => punctual(p, position, intensity),
            Light::Spot { position, axis, intensity, cos_inner, cos_outer } => {
                let mut s = punctual(p, position, intensity)?;
                s.li *= spot_falloff(-s.wi.dot(axis), cos_inner, cos_outer);
                (s.li.max_element() > 0.0).then_some(s)
            }
            Light::Directional { dir, irradiance } => Some(LightSample {
                li: irradiance,
                wi: -dir,
                pdf: 1.0,
                delta: true,
                target: Target::Infinite,
            }),
            Light::Background { radiance } => {
                let local = cosine_hemisphere(u);
                let wi = Frame::from_normal(n).to_world(local);
                let pdf = local.z / PI;
                (pdf > 0.0).then_some(LightSample {
                    li: radiance,
                    wi,
                    pdf,
                    delta: false,
                    target: Target::Infinite,
                })
            }
        }
    }
}

/// Cosine at an area light of the direction towards `p`, at distance `dist`: height of `p`
/// above the light's plane over the distance. The height does not depend on where the sample
/// point landed, so its rounding cannot turn a receiver in the plane (exactly 0) or just above
/// it (a cosine of 10⁻⁵) into a wrong sign or a 1 % error. It is found in f64 and rounded once;
/// the division is f32's, by the distance the caller already has (within 1.5 ulp in all).
fn cos_at_light((n, offset): (DVec3, f64), p: Vec3, dist: f32) -> f32 {
    (n.dot(p.as_dvec3()) - offset) as f32 / dist
}

fn punctual(p: Vec3, position: Vec3, intensity: Vec3) -> Option<LightSample> {
    let d = position - p;
    let dist2 = d.length_squared();
    if !(dist2 > 0.0 && dist2.is_finite()) {
        return None;
    }
    Some(LightSample {
        li: intensity / dist2,
        wi: d / dist2.sqrt(),
        pdf: 1.0,
        delta: true,
        target: Target::Point { p: ErrPoint::exact(position), ng: Vec3::ZERO },
    })
}

/// glTF KHR_lights_punctual's recommended falloff: a squared linear ramp in cos θ.
fn spot_falloff(cos_theta: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let scale = 1.0 / (cos_inner - cos_outer).max(1e-3);
    let t = ((cos_theta - cos_outer) * scale).clamp(0.0, 1.0);
    t * t
}

/// The lights of one render (the scene's plus the job's background), chosen by power, and
/// the scene's area lights through its [`LightTree`] when it has one.
pub struct LightSet<'a> {
    scene_lights: &'a [Light],
    /// The scene's textures (for emissive textures).
    textures: &'a [Texture],
    background: Option<Light>,
    /// The tree over `scene_lights[..tree.len()]`, which are then one entry of the choice.
    tree: Option<&'a LightTree>,
    /// Choice probability per entry: the tree's lights as one (first), then each other light;
    /// the background, if any, is last.
    pmf: Vec<f32>,
    cdf: Vec<f32>,
}

impl<'a> LightSet<'a> {
    pub fn new(scene_lights: &'a [Light], background: Vec3, scene_radius: f32) -> LightSet<'a> {
        LightSet::with_tree(scene_lights, None, background, scene_radius)
    }

    /// The set whose first `tree.len()` lights are chosen through `tree`.
    pub fn with_tree(
        scene_lights: &'a [Light],
        tree: Option<&'a LightTree>,
        background: Vec3,
        scene_radius: f32,
    ) -> LightSet<'a> {
        let background =
            (background.max_element() > 0.0).then_some(Light::Background { radiance: background });
        let tree = tree.filter(|t| !t.is_empty());
        let grouped = tree.map_or(0, |t| t.len());
        let powers: Vec<f32> = tree
            .map(|t| t.power().max(0.0))
            .into_iter()
            .chain(
                scene_lights[grouped..]
                    .iter()
                    .chain(background.iter())
                    .map(|l| l.power(scene_radius).max(0.0)),
            )
            .collect();
        let total: f32 = powers.iter().sum();
        let n = powers.len() as f32;
        let pmf: Vec<f32> = if total > 0.0 && total.is_finite() {
            powers.iter().map(|p| p / total).collect()
        } else {
            powers.iter().map(|_| 1.0 / n).collect()
        };
        let mut acc = 0.0;
        let cdf = pmf.iter().map(|p| {
            acc += p;
            acc
        });
        let cdf = cdf.collect();
        LightSet { scene_lights, textures: &[], background, tree, pmf, cdf }
    }

    /// This set reading emissive textures from `textures`.
    pub fn with_textures(self, textures: &'a [Texture]) -> LightSet<'a> {
        LightSet { textures, ..self }
    }

    pub fn is_empty(&self) -> bool {
        self.pmf.is_empty()
    }

    pub fn background(&self) -> Vec3 {
        match self.background {
            Some(Light::Background { radiance }) => radiance,
            _ => Vec3::ZERO,
        }
    }

    fn light(&self, i: usize) -> &Light {
        self.scene_lights
            .get(i)
            .unwrap_or_else(|| self.background.as_ref().expect("index in range"))
    }

    /// The light of choice entry `e`, which is not the tree's (the inverse of `choice_pmf`'s
    /// entry for a light).
    fn entry_light(&self, e: usize) -> usize {
        match self.tree {
            Some(t) => e - 1 + t.len(),
            None => e,
        }
    }

    /// The probability that a light sample for `p` (shading normal `n`) picks light `i`.
    fn choice_pmf(&self, i: usize, p: Vec3, n: Vec3) -> f32 {
        match self.tree {
            Some(t) if i < t.len() => self.pmf[0] * t.pmf(i, p, n),
            Some(t) => self.pmf[i - t.len() + 1],
            None => self.pmf[i],
        }
    }

    /// Picks a light with `u.x` (by power, or through the tree) and samples it from `p` with
    /// shading normal `n`.
    pub fn sample(&self, p: Vec3, n: Vec3, u: Vec2) -> Option<LightSample> {
        self.sample_for::<AllEffects>(p, n, u)
    }

    /// [`LightSet::sample`] as kernel `E` sees the lights.
    ///
    /// The light is chosen by where `u.x` falls in the cumulative choice probabilities, and
    /// `u.x` is then stretched from that interval back to [0, 1) for the light's own sample
    /// (Mitsuba's `sample_reuse`). A stratified 2D pattern thus stays stratified over the union
    /// of the lights — a quad light is two triangles, and a separate choice dimension would
    /// hand each a random half of a pixel's points — and a bounce draws one number fewer.
    #[inline]
    pub fn sample_for<E: EffectSet>(&self, p: Vec3, n: Vec3, u: Vec2) -> Option<LightSample> {
        let (e, x) = self.choose(u.x)?;
        let (i, pick, x) = match self.tree {
            Some(t) if e == 0 => {
                let (i, in_tree, x) = t.sample(p, n, x)?;
                (i, self.pmf[0] * in_tree, x)
            }
            _ => (self.entry_light(e), self.pmf[e], x),
        };
        let mut s = self.light(i).sample::<E>(p, n, Vec2::new(x, u.y), self.textures)?;
        s.pdf *= pick;
        Some(s)
    }

    /// The light `x` chooses, and `x` stretched from its interval of the cdf to [0, 1).
    ///
    /// The stretch keeps the resolution x had within the interval: samples are multiples of
    /// 2⁻²⁴, so a light chosen with probability p gets about 2²⁴·p distinct x positions (still
    /// about 17 at p = 10⁻⁶, with y at full resolution) — the same grain that bounds which
    /// lights a separate 24-bit choice dimension could pick at all.
    fn choose(&self, x: f32) -> Option<(usize, f32)> {
        let last = self.cdf.len().checked_sub(1)?;
        let i = self.cdf.partition_point(|&c| c <= x).min(last);
        let pick = self.pmf[i];
        if pick == 0.0 {
            return None;
        }
        let below = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        Some((i, ((x - below) / pick).clamp(0.0, ONE_MINUS_EPSILON)))
    }

    /// Solid-angle density with which `sample` returns the point `q` of area light `light` as
    /// seen from `p` with shading normal `n`.
    pub fn pdf_area(&self, light: u32, p: Vec3, n: Vec3, q: Vec3) -> f32 {
        match self.scene_lights[light as usize] {
            Light::Triangle { plane, area, two_sided, .. } => {
                let dist2 = (q - p).length_squared();
                let cos_l = cos_at_light(plane, p, dist2.sqrt());
                if !(cos_l > 0.0 || two_sided && cos_l < 0.0) {
                    return 0.0;
                }
                self.choice_pmf(light as usize, p, n) * dist2 / (cos_l.abs() * area)
            }
            _ => 0.0,
        }
    }

    /// Density with which `sample` returns direction `wi` towards the background from a point
    /// with shading normal `n`.
    pub fn pdf_background(&self, n: Vec3, wi: Vec3) -> f32 {
        if self.background.is_none() {
            return 0.0;
        }
        self.pmf[self.pmf.len() - 1] * n.dot(wi).max(0.0) / PI
    }
}

#[cfg(test)]
mod tests;
