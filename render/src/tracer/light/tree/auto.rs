//! # When the `auto` light sampler chooses through the tree
//!
//! From [`LightTree::MIN_LIGHTS`] emissive triangles on, always. Below that, the count says
//! little (2026-12-07, docs/dev/performance-log.md): four lamps apart (8 triangles) reach a given
//! quality 2.6× sooner through the tree, a 16-facet sphere light 1.4× sooner, while a 12-face
//! emissive enclosure takes 1.23× longer and a textured quad 1.08×. What decides is whether
//! the lights differ in what they give the scene's surfaces, and whether the tree's choice
//! follows that difference better than power does. [`Spread`] measures both, without tracing:
//!
//! - *Receivers*: 1,024 points spread over the scene's scattering surfaces by area (the
//!   triangle by a stratified draw over the areas, the point in it by an R2 sequence), each
//!   with its face normal, either side.
//! - At each, each light's unoccluded contribution f (its luminance times the two cosines over
//!   d², by the midpoint rule on its four half-size sub-triangles), and the light choice's
//!   variance Σ f²/p − (Σ f)², for p the probability by power and through the tree.
//! - Over all receivers, each choice's variance over Σ (Σ f)²: the relative variance of the
//!   light choice, weighted by how bright a receiver is.
//!
//! The tree is chosen when power's relative variance is at least [`MIN_EXCESS`] and the tree's
//! at most [`GAIN`] of it: the choice by power must be far from what the lights give, and
//! the tree much closer, to pay for its walk (which cost 5–37 % more time per sample on these
//! scenes). On the scenes measured (`docs/tools/light_tree_study.py` prints both figures and the
//! choice) the rule picks the tree for lamps apart and faceted sphere lights, power for the
//! Cornell box's quad, a textured quad, an enclosure and emitters that light nothing.
//!
//! Occlusion is left out: it hides lights from both choices alike. The measure is a function
//! of the scene's triangles and materials alone, in IEEE operations without libm, so every
//! worker and the coordinator reach the same choice.
use super::{Light, LightTree};
use crate::tracer::sampling::luminance;
use glam::Vec3;

/// Points at which the choices are compared.
const RECEIVERS: usize = 1024;
/// The least relative variance of the choice by power for which the tree may pay.
pub const MIN_EXCESS: f64 = 0.25;
/// The tree is chosen when its relative variance is at most this fraction of power's.
pub const GAIN: f64 = 0.5;

/// The relative variance of the light choice by power and through the tree (see the module).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Spread {
    pub by_power: f64,
    pub by_tree: f64,
}

impl Spread {
    /// Where no receiver is lit (or none scatters): no variance either way.
    pub const NOTHING_LIT: Spread = Spread { by_power: 0.0, by_tree: 0.0 };

    /// Measures the choices among `lights[..tree.len()]` at receivers on the triangles
    /// `positions` for which `scatters(t)`.
    pub fn measure(
        tree: &LightTree,
        lights: &[Light],
        positions: &[[Vec3; 3]],
        scatters: impl Fn(usize) -> bool,
    ) -> Spread {
        let lights = &lights[..tree.len()];
        let powers: Vec<f32> = lights.iter().map(|l| l.power(1.0).max(0.0)).collect();
        let total_power: f32 = powers.iter().sum();
        let by_power: Vec<f64> = powers.iter().map(|&p| (p / total_power) as f64).collect();
        let (cdf, area) = area_cdf(positions, scatters);
        if !(area > 0.0) {
            return Spread::NOTHING_LIT;
        }
        let (mut var_power, mut var_tree, mut mean_sq) = (0.0f64, 0.0f64, 0.0f64);
        let mut f = vec![0.0f64; lights.len()];
        for (x, n) in (0..RECEIVERS).filter_map(|i| receiver(i, &cdf, area, positions)) {
            for (fk, l) in f.iter_mut().zip(lights) {
                *fk = unoccluded(l, x, n) as f64;
            }
            let sum: f64 = f.iter().sum();
            if !(sum > 0.0 && sum.is_finite()) {
                continue;
            }
            // Σ f²/p over the lights, for the choice that picks light k with probability p(k).
            let second_moment = |p: &dyn Fn(usize) -> f64| {
                f.iter().enumerate().map(|(k, fk)| fk * fk / p(k).max(1e-30)).sum::<f64>()
            };
            var_power += second_moment(&|k| by_power[k]) - sum * sum;
            var_tree += second_moment(&|k| tree.pmf(k, x, n) as f64) - sum * sum;
            mean_sq += sum * sum;
        }
        match mean_sq > 0.0 {
            true => Spread { by_power: var_power / mean_sq, by_tree: var_tree / mean_sq },
            false => Spread::NOTHING_LIT,
        }
    }

    /// Whether the tree's choice is enough better than power's to pay for its walk.
    pub fn favours_tree(&self) -> bool {
        self.by_power >= MIN_EXCESS && self.by_tree <= GAIN * self.by_power
    }
}

impl LightTree {
    /// Whether the `auto` light sampler chooses through this tree over the leading triangle
    /// lights of `lights`, in a scene of triangles `positions` of which those with
    /// `scatters(t)` reflect or transmit light (see the module).
    pub fn suits(
        &self,
        lights: &[Light],
        positions: &[[Vec3; 3]],
        scatters: impl Fn(usize) -> bool,
    ) -> bool {
        match self.len() {
            0 | 1 => false,
            c if c >= LightTree::MIN_LIGHTS => true,
            _ => Spread::measure(self, lights, positions, scatters).favours_tree(),
        }
    }
}

/// The running sums of the areas of the triangles that scatter, and their total.
fn area_cdf(positions: &[[Vec3; 3]], scatters: impl Fn(usize) -> bool) -> (Vec<f64>, f64) {
    let mut area = 0.0f64;
    let cdf = positions
        .iter()
        .enumerate()
        .map(|(t, v)| {
            if scatters(t) {
                area += 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length() as f64;
            }
            area
        })
        .collect();
    (cdf, area)
}

/// Receiver `i`: a point and its face normal (None on a degenerate triangle).
fn receiver(i: usize, cdf: &[f64], area: f64, positions: &[[Vec3; 3]]) -> Option<(Vec3, Vec3)> {
    let at = (i as f64 + 0.5) / RECEIVERS as f64 * area;
    let t = cdf.partition_point(|&c| c <= at).min(positions.len() - 1);
    let v = &positions[t];
    let n = (v[1] - v[0]).cross(v[2] - v[0]).try_normalize()?;
    // The R2 sequence's two irrationals (Roberts 2018), folded onto the triangle.
    let (mut b1, mut b2) = (
        (i as f64 * 0.754_877_666_246_692_7).fract() as f32,
        (i as f64 * 0.569_840_290_998_053_2).fract() as f32,
    );
    if b1 + b2 > 1.0 {
        (b1, b2) = (1.0 - b1, 1.0 - b2);
    }
    Some((v[0] + b1 * (v[1] - v[0]) + b2 * (v[2] - v[0]), n))
}

/// The luminance a triangle light gives a point `x` with normal `n` (either side) with nothing
/// in between, by the midpoint rule on the triangle's four half-size sub-triangles; each
/// sub-triangle's distance is kept at least the square root of its area, so a receiver
/// touching the light gets a bounded share.
fn unoccluded(light: &Light, x: Vec3, n: Vec3) -> f32 {
    let Light::Triangle { v, n: ln, area, radiance, two_sided, texture, .. } = light else {
        return 0.0;
    };
    let luminance = luminance(*radiance * texture.as_ref().map_or(Vec3::ONE, |t| t.mean));
    let m = [(v[0] + v[1]) * 0.5, (v[1] + v[2]) * 0.5, (v[2] + v[0]) * 0.5];
    let centres = [
        (v[0] + m[0] + m[2]) / 3.0,
        (v[1] + m[0] + m[1]) / 3.0,
        (v[2] + m[1] + m[2]) / 3.0,
        (m[0] + m[1] + m[2]) / 3.0,
    ];
    let quarter = area * 0.25;
    let each = |c: Vec3| {
        let d = x - c;
        let d2 = d.length_squared();
        let inv_d = d2.sqrt().recip();
        let cos_light = ln.dot(d) * inv_d;
        let cos_light = if *two_sided { cos_light.abs() } else { cos_light.max(0.0) };
        let cos_receiver = (n.dot(d) * inv_d).abs();
        let g = cos_light * cos_receiver / d2.max(quarter);
        if g.is_finite() { luminance * g * quarter } else { 0.0 }
    };
    centres.into_iter().map(each).sum()
}

#[cfg(test)]
mod tests;
