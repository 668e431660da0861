//! # LightTree — choosing among many area lights by what each can give a point
//!
//! A scene's emissive triangles in a tree of bounds. A light sample chooses through it where
//! the tree suits the scene ([`LightTree::suits`], `tree/auto.rs`: from
//! [`LightTree::MIN_LIGHTS`] of them on, or fewer that differ in what they give its surfaces;
//! job setting `light_sampler`: `auto`, the default; `tree` always, `power` never:
//! [`LightSampler`]). Elsewhere [`LightSet`](super::LightSet) picks lights in proportion to their
//! power alone: a handful of lights alike each get samples anyway, and a walk down a tree can
//! cost more than the choice it improves (a 12-triangle emissive enclosure, `furnace`, takes
//! 1.23× the relMSE·s through the tree). From 16 emissive triangles on, lamps apart and a
//! tessellated sphere light both reached a given quality sooner through the tree
//! (docs/tools/light_tree_study.py, docs/dev/performance-log.md, 2026-12-07).
//!
//! Power alone fails where lights are many and spread out (a field of lamps, a lit window
//! grid, an emissive mesh): a point is lit by the few lights near it and facing it, but is
//! sent towards a random one of all of them. The tree (pbrt-v4's `BVHLightSampler`, after
//! Conty Estevez & Kulla 2018) walks from the root and at each node picks a child with
//! probability proportional to an *importance*: the child's power, over its squared
//! distance, times bounds on the cosine at the lights and the cosine at the receiver.
//!
//! Four children per node, their bounds stored lane by lane, so one SIMD evaluation weighs
//! all four and the walk is about log₄ n levels deep (pbrt's tree is binary: twice the levels,
//! each with two scalar evaluations). The lights are grouped by median splits of their
//! centres along the widest spread, two per level.
//!
//! What a child bounds: the sphere around its triangles' box, their total power (the `power`
//! the set chooses by), and a cone (axis `w`, half-angle θo) holding every triangle's normal.
//! Emission is over a hemisphere per triangle (θe = π/2); a two-sided light counts its normal
//! in both directions. Unlike pbrt, the cone is fitted to the triangles' normals themselves
//! (`w` their normalized sum, θo the widest of them from it), not by unions of child cones,
//! so building uses no trigonometry and gives the same bits on every libm.
//!
//! Unbiased: a child's importance is zero only when no triangle in it can emit towards the
//! point at all (every direction from its bounding sphere to the point lies more than 90° +
//! a small margin from every normal in its cone); every other child gets a positive share,
//! however small. The choice probability of a light ([`LightTree::pmf`]) walks the same path
//! the sample took (each light's trail of children is kept), so MIS weights see exactly the
//! probability the light sample had. Everything is a function of (point, shading normal), in
//! IEEE operations whose order does not depend on the CPU: renders stay deterministic.
//!
//! The random number that makes the choices is stretched at each level back to [0, 1) (as
//! the set does for its choice) and then places the point on the light.
use super::Light;
use crate::tracer::sampler::ONE_MINUS_EPSILON;
use glam::{BVec4A, Vec3, Vec4};
use std::str::FromStr;

/// The tree over a scene's leading [`Light::Triangle`] lights.
#[derive(Clone, Debug)]
pub struct LightTree {
    /// The root first; children after their parent.
    nodes: Vec<Inner>,
    /// Per light: the children taken from the root to it, two bits per level (level k in bits
    /// 2k and 2k + 1).
    trails: Vec<u64>,
    /// The power of all the tree's lights.
    power: f32,
}

/// Children per node: their bounds are tested together, one per SIMD lane.
const WIDTH: usize = 4;
/// In [`Inner::child`]: the child is a light, its index in the other bits.
const LEAF: u32 = 1 << 31;

/// A node: its up to four children's bounds, lane by lane (an unused lane has no power).
#[derive(Clone, Copy, Debug)]
struct Inner {
    /// The centre and radius of the sphere around each child's box.
    cx: Vec4,
    cy: Vec4,
    cz: Vec4,
    r2: Vec4,
    r: Vec4,
    /// The axis and half-angle of the cone of each child's normals.
    wx: Vec4,
    wy: Vec4,
    wz: Vec4,
    cos_o: Vec4,
    sin_o: Vec4,
    power: Vec4,
    /// What a point inside the child's bounding sphere is given: power / r².
    power_inside: Vec4,
    /// 1 where a child has a two-sided light, else 0.
    two_sided: Vec4,
    child: [u32; WIDTH],
    count: u32,
}

/// How far past 90° from every normal a point must lie before a node gives it nothing: the
/// cosines are rounded, and a light that faces a point by a hair must keep a chance.
const COS_MARGIN: f32 = 1e-4;
/// The least cosine factor of a node that may light a point (one grazing the point's surface,
/// or one the margin kept), so its importance stays positive.
const COS_FLOOR: f32 = 1e-4;

/// How a light sample chooses among a scene's area lights (job setting `light_sampler`). Every
/// choice gives the same expected image; they differ in noise and in time per sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightSampler {
    /// Through the tree where it suits the scene ([`LightTree::suits`]), else by power.
    #[default]
    Auto,
    /// In proportion to power alone (as Mitsuba 3 does).
    Power,
    /// Through the tree whenever the scene has area lights: a few lamps far apart are lit
    /// sooner so (docs/dev/performance-log.md, 2026-12-07).
    Tree,
}

impl LightSampler {
    pub const ALL: [LightSampler; 3] =
        [LightSampler::Auto, LightSampler::Power, LightSampler::Tree];

    pub fn name(self) -> &'static str {
        match self {
            LightSampler::Auto => "auto",
            LightSampler::Power => "power",
            LightSampler::Tree => "tree",
        }
    }

    /// Whether a scene's light samples choose through its tree, if it has one: `suits` is
    /// what `auto` does there ([`LightTree::suits`]).
    pub fn uses_tree(self, suits: bool) -> bool {
        match self {
            LightSampler::Auto => suits,
            LightSampler::Power => false,
            LightSampler::Tree => true,
        }
    }
}

/// Error from parsing an unknown light sampler name; lists the valid names.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown light sampler {0:?} (expected one of auto, power, tree)")]
pub struct UnknownLightSampler(pub String);

impl FromStr for LightSampler {
    type Err = UnknownLightSampler;
    fn from_str(s: &str) -> Result<LightSampler, UnknownLightSampler> {
        LightSampler::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| UnknownLightSampler(s.to_owned()))
    }
}

impl LightTree {
    /// From this many area lights on, `auto` chooses through the tree without judging the
    /// lights' spread (below, [`LightTree::suits`] judges it). The smallest power of two
    /// at which every scene family measured gains (2026-12-07: relMSE·s through the tree 0.26×
    /// on 16 lamps, 0.81× on a 32-facet sphere light); the bundled scenes have at most 24.
    pub const MIN_LIGHTS: usize = 32;

    /// A tree over the leading triangle lights of `lights`, if there are any.
    pub fn over(lights: &[Light]) -> Option<LightTree> {
        let count = lights.iter().take_while(|l| matches!(l, Light::Triangle { .. })).count();
        (count > 0).then(|| LightTree::build(&lights[..count]))
    }

    /// Lights in the tree: `lights[..len]` of the set it was built over.
    pub fn len(&self) -> usize {
        self.trails.len()
    }

    pub fn is_empty(&self) -> bool {
        self.trails.is_empty()
    }

    /// The power of all the tree's lights.
    pub fn power(&self) -> f32 {
        self.power
    }

    /// Picks a light for a point `p` with shading normal `n` (zero: no normal) with `u`:
    /// (the light's index, the probability it was picked with, `u` stretched back to [0, 1)).
    /// None when no light of the tree can reach the point.
    pub fn sample(&self, p: Vec3, n: Vec3, mut u: f32) -> Option<(usize, f32, f32)> {
        let mut at = 0;
        let mut pmf = 1.0f32;
        loop {
            let node = self.nodes.get(at)?;
            let (weights, total) = node.weights(p, n)?;
            // The choice scales u rather than the weights, so it need not wait for a division.
            let x = u * total;
            let (k, below) = pick(&weights, node.count as usize, x);
            pmf *= weights[k] / total;
            u = ((x - below) / weights[k]).min(ONE_MINUS_EPSILON);
            match node.child[k] {
                c if c & LEAF != 0 => return Some(((c & !LEAF) as usize, pmf, u)),
                c => at = c as usize,
            }
        }
    }

    /// The probability [`LightTree::sample`] picks light `light` for `p` with normal `n`.
    pub fn pmf(&self, light: usize, p: Vec3, n: Vec3) -> f32 {
        let Some(&trail) = self.trails.get(light) else { return 0.0 };
        let (mut at, mut trail, mut pmf) = (0, trail, 1.0f32);
        loop {
            let node = &self.nodes[at];
            let Some((weights, total)) = node.weights(p, n) else { return 0.0 };
            let k = (trail & 3) as usize;
            pmf *= weights[k] / total;
            match node.child[k] {
                c if c & LEAF != 0 => return pmf,
                c => at = c as usize,
            }
            trail >>= 2;
        }
    }
}

/// The child whose interval of [0, Σ weights) `x` falls in, and where that interval starts.
// A search with branches, not a branch-free count: the core runs ahead down the predicted
// child, overlapping the next level's loads and roots; counting was 8–15 % slower (measured 2026-12-07).
fn pick(weights: &[f32; WIDTH], count: usize, x: f32) -> (usize, f32) {
    let (mut below, mut last) = (0.0f32, 0);
    for (k, &w) in weights.iter().enumerate().take(count) {
        if w > 0.0 {
            let above = below + w;
            if x < above {
                return (k, below);
            }
            (below, last) = (above, k);
        }
    }
    // Rounding left x past the last interval: it is the last child's.
    (last, below - weights[last])
}

impl Inner {
    /// Each child's weight for `p` (normal `n`) and their sum (a child's probability is its
    /// weight over the sum), or None if none can light it.
    #[inline]
    fn weights(&self, p: Vec3, n: Vec3) -> Option<([f32; WIDTH], f32)> {
        let i = self.importance(p, n).to_array();
        let total = (i[0] + i[1]) + (i[2] + i[3]);
        if total == f32::INFINITY {
            // Lights bright enough to overflow: every child that may light p gets an equal share,
            // which `pmf` finds the same way.
            let reach = i.map(|i| if i > 0.0 { 1.0 } else { 0.0 });
            return Some((reach, (reach[0] + reach[1]) + (reach[2] + reach[3])));
        }
        (total > 0.0 && total.is_finite()).then_some((i, total))
    }

    /// How much each child's lights may give a point `p` with shading normal `n` (zero: none):
    /// zero only if none of them can emit towards `p`.
    #[inline]
    fn importance(&self, p: Vec3, n: Vec3) -> Vec4 {
        let (one, zero) = (Vec4::ONE, Vec4::ZERO);
        let (dx, dy, dz) =
            (Vec4::splat(p.x) - self.cx, Vec4::splat(p.y) - self.cy, Vec4::splat(p.z) - self.cz);
        let d2 = dx * dx + dy * dy + dz * dz;
        // Each sine and cosine below is a length over d, and the lengths' square roots are
        // independent, so they run side by side instead of each waiting for the one before: the
        // walk is a chain of levels, and its time is this function's latency.
        let wd = self.wx * dx + self.wy * dy + self.wz * dz;
        let wd = Vec4::select(self.two_sided.cmpgt(zero), wd.abs(), wd);
        let (d, beside_b, beside_w) =
            (sqrt(d2), sqrt((d2 - self.r2).max(zero)), sqrt((d2 - wd * wd).max(zero)));
        let inv_d = d.recip();
        // θb: the half-angle the bounding sphere subtends at p.
        let (cos_b, sin_b) = (beside_b * inv_d, (self.r * inv_d).min(one));
        // θw: from the cone's axis to p; θ' = max(0, θw − θo − θb), the least angle between
        // a normal of the child and the direction from one of its points to p.
        let (cos_w, sin_w) = (wd * inv_d, beside_w * inv_d);
        let (cos_x, sin_x) = angle_minus(cos_w, sin_w, self.cos_o, self.sin_o);
        let (cos_p, _) = angle_minus(cos_x, sin_x, cos_b, sin_b);
        let floor = Vec4::splat(COS_FLOOR);
        let mut importance = self.power * cos_p.max(floor) * (inv_d * inv_d);
        if n != Vec3::ZERO {
            // The receiver's cosine, at most θb better than towards the centre.
            let nd = (dx * n.x + dy * n.y + dz * n.z).abs();
            let (cos_i, sin_i) = (nd * inv_d, sqrt((d2 - nd * nd).max(zero)) * inv_d);
            importance *= angle_minus(cos_i, sin_i, cos_b, sin_b).0.max(floor);
        }
        let importance = Vec4::select(cos_p.cmplt(Vec4::splat(-COS_MARGIN)), zero, importance);
        // From inside a bounding sphere, lights lie in every direction (and d may be zero).
        let inside: BVec4A = !d2.cmpgt(self.r2);
        Vec4::select(inside, self.power_inside, importance)
    }
}

/// Lane by lane, cos and sin of max(0, a − b) from those of a and b (both in [0, π]).
#[inline(always)]
fn angle_minus(cos_a: Vec4, sin_a: Vec4, cos_b: Vec4, sin_b: Vec4) -> (Vec4, Vec4) {
    let none = cos_a.cmpgt(cos_b);
    (
        Vec4::select(none, Vec4::ONE, cos_a * cos_b + sin_a * sin_b),
        Vec4::select(none, Vec4::ZERO, sin_a * cos_b - cos_a * sin_b),
    )
}

/// Lane-wise square root, one instruction on x86_64 (glam's takes four); IEEE-exact either way.
#[inline(always)]
fn sqrt(v: Vec4) -> Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::_mm_sqrt_ps;
        // SAFETY: SSE is part of every x86_64 target; no memory is touched.
        Vec4::from(unsafe { _mm_sqrt_ps(v.into()) })
    }
    #[cfg(not(target_arch = "x86_64"))]
    v.sqrt()
}

mod auto;
mod build;
pub use auto::Spread;

#[cfg(test)]
mod tests;
