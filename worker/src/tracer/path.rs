//! One camera path as four stages, with its state between them in a [`Path`].
//!
//! A bounce is: [`Integrator::arrive`] (trace the path's ray, shade nothing yet),
//! [`Integrator::shade`] (emission, the light sample's shadow ray, the BSDF sample),
//! [`Integrator::test_shadow`] (trace the shadow ray, add the light it lets through) and
//! [`Integrator::continue_path`] (throughput, medium, roulette). [`Integrator::li_for`] runs
//! them one after another; [`crate::tracer::lanes`] runs each stage for several paths before
//! the next, so the processor has independent work from other paths while one waits on a
//! division or a cache miss. Both add the same numbers in the same order: the same bits.
use crate::tracer::bsdf::{Bsdf, BsdfSample};
use crate::tracer::effects::EffectSet;
use crate::tracer::integrator::{Estimator, Integrator, PathSample, Roulette};
use crate::tracer::light::Target;
use crate::tracer::ray::{Ray, SHADOW_EPSILON};
use crate::tracer::sampler::Sampler;
use crate::tracer::sampling::power_heuristic;
use crate::tracer::surface::Surface;
use glam::{Vec2, Vec3};

/// What a path carries from one stage to the next.
pub(crate) struct Path {
    ray: Ray,
    l: Vec3,
    beta: Vec3,
    max_weight: f32,
    prev: Option<Bounce>,
    /// Absorption coefficient of the medium the ray travels in (zero: air).
    medium: Vec3,
    rays: u32,
    depth: u32,
    /// The throughput overflowed: the sample is meaningless and reported as NaN.
    overflowed: bool,
}

/// The previous bounce, for MIS weights of emission found by a BSDF-sampled ray.
#[derive(Clone, Copy)]
pub(crate) struct Bounce {
    pub p: Vec3,
    pub n: Vec3,
    pub bsdf_pdf: f32,
    /// A delta bounce: light sampling could not have found what this ray finds.
    pub specular: bool,
}

/// A light sample waiting for its shadow ray: the light it adds (before β) if nothing blocks.
pub(crate) struct ShadowTest {
    ray: Ray,
    t_max: f32,
    li: Vec3,
}

/// What shading a hit leaves for the rest of the bounce.
pub(crate) struct Shaded {
    pub shadow: Option<ShadowTest>,
    /// The direction to continue in; None ends the path after the shadow test.
    pub bs: Option<BsdfSample>,
}

impl Path {
    pub fn new(ray: Ray) -> Path {
        Path { ray, l: Vec3::ZERO, beta: Vec3::ONE, max_weight: 1.0, prev: None, medium: Vec3::ZERO, rays: 0, depth: 0, overflowed: false }
    }

    /// The finished path's sample.
    pub fn sample(&self) -> PathSample {
        let radiance = if self.overflowed { Vec3::NAN } else { self.l };
        PathSample { radiance, max_weight: self.max_weight, rays: self.rays }
    }
}

impl Integrator<'_> {
    /// Traces the path's ray: the surface it reaches, or None when it escaped (the path ends).
    #[inline]
    pub(crate) fn arrive<E: EffectSet>(&self, path: &mut Path, sampler: &mut Sampler) -> Option<Surface> {
        let u_glass = if E::GLASS { sampler.get_1d() } else { 0.0 };
        path.rays += 1;
        let hit = self.surface::<E>(&path.ray, u_glass);
        if E::GLASS && path.medium != Vec3::ZERO {
            path.beta *= transmittance(path.medium, hit.as_ref().map_or(f32::INFINITY, |s| s.dist));
        }
        if hit.is_none() {
            path.l += path.beta * self.escaped(self.settings.estimator, path.prev, path.ray.dir);
        }
        hit
    }

    /// Emission at `s`, the light sample and the BSDF sample; None ends the path here.
    #[inline]
    pub(crate) fn shade<E: EffectSet>(&self, path: &mut Path, s: &Surface, sampler: &mut Sampler) -> Option<Shaded> {
        let est = self.settings.estimator;
        if est == Estimator::Naive {
            // The seed's first tracer: emit or reflect, each with probability ½.
            let (u_choice, u_dir) = (sampler.get_1d(), sampler.get_2d());
            if u_choice < 0.5 {
                path.l += path.beta * 2.0 * s.le;
                return None;
            }
            let bsdf = s.bsdf.filter(|_| path.depth < self.settings.max_depth)?;
            // Uniform directions never hit a delta lobe: glass is sampled by its BSDF.
            let bs = if E::GLASS && bsdf.transmits() { bsdf.sample(s.wo, (u_choice - 0.5) * 2.0, u_dir) } else { bsdf.sample_uniform(s.wo, u_dir) };
            let bs = bs.map(|mut bs| {
                bs.pdf *= 0.5;
                bs
            });
            return Some(Shaded { shadow: None, bs });
        }
        path.l += path.beta * self.emitted(est, path.depth, path.prev, s);
        let u_light = sampler.get_2d();
        let (d_lobe, u_dir) = (sampler.defer_1d(), sampler.get_2d());
        let bsdf = s.bsdf.filter(|_| path.depth < self.settings.max_depth)?;
        let delta = E::GLASS && bsdf.is_specular();
        let lit = matches!(est, Estimator::Light | Estimator::Mis) && !delta && !self.lights.is_empty();
        let shadow = if lit { self.light_sample::<E>(est, s, &bsdf, path.medium, u_light) } else { None };
        let u_lobe = if bsdf.chooses_lobes() { sampler.deferred(d_lobe) } else { 0.0 };
        Some(Shaded { shadow, bs: bsdf.sample(s.wo, u_lobe, u_dir) })
    }

    /// Traces a light sample's shadow ray and adds its light if nothing blocks it.
    #[inline]
    pub(crate) fn test_shadow<E: EffectSet>(&self, path: &mut Path, test: &ShadowTest) {
        path.rays += 1;
        if !self.occluded::<E>(&test.ray, test.t_max) {
            path.l += path.beta * test.li;
        }
    }

    /// Continues the path along the BSDF sample; false when it ends here.
    #[inline]
    pub(crate) fn continue_path<E: EffectSet>(&self, path: &mut Path, s: &Surface, bs: Option<BsdfSample>, sampler: &mut Sampler) -> bool {
        let Some(bs) = bs else { return false };
        let Some(w) = self.scatter::<E>(s, &bs, &mut path.ray) else { return false };
        path.beta *= w;
        if E::GLASS && bs.wi.z < 0.0 {
            path.medium = s.medium_behind(path.medium);
        }
        path.prev = Some(Bounce { p: s.p.p, n: s.frame.n, bsdf_pdf: bs.pdf, specular: bs.specular });
        if !path.beta.is_finite() {
            // An overflowed throughput makes the sample meaningless (∞·0 later): report it
            // as non-finite, so it is dropped and counted, and keep max_weight finite.
            path.overflowed = true;
            return false;
        }
        path.max_weight = path.max_weight.max(path.beta.max_element());
        let d_roulette = sampler.defer_1d();
        if !survives_roulette(self.settings.roulette, path.depth, &mut path.beta, || sampler.deferred(d_roulette)) {
            return false;
        }
        path.depth += 1;
        true
    }

    /// Next-event estimation: one light sample, MIS-weighted for `Mis`, and the shadow ray
    /// that decides whether it counts (None: it cannot contribute).
    pub(crate) fn light_sample<E: EffectSet>(&self, est: Estimator, s: &Surface, bsdf: &Bsdf, medium: Vec3, u: Vec2) -> Option<ShadowTest> {
        let ls = self.lights.sample_for::<E>(s.p.p, s.frame.n, u)?;
        let wi = s.frame.to_local(ls.wi);
        let side = ls.wi.dot(s.ng);
        // Only glass sees lights behind the surface, and only where both normals agree.
        let through = E::GLASS && bsdf.transmits() && side < 0.0 && wi.z < 0.0;
        if !through && (side <= 0.0 || wi.z <= 0.0) {
            return None;
        }
        let f = bsdf.eval(s.wo, wi);
        if f == Vec3::ZERO {
            return None;
        }
        let (ray, dist) = match ls.target {
            Target::Point { p, ng } => (s.p.spawn_to(s.ng, &p, ng), (p.p - s.p.p).length()),
            Target::Infinite => (s.p.spawn(s.ng, ls.wi), f32::INFINITY),
        };
        let t_max = if dist.is_finite() { 1.0 - SHADOW_EPSILON } else { f32::INFINITY };
        let tr = if E::GLASS {
            let m = if through { s.medium_behind(medium) } else { medium };
            if m == Vec3::ZERO { Vec3::ONE } else { transmittance(m, dist) }
        } else {
            Vec3::ONE
        };
        let mis = if est == Estimator::Mis && !ls.delta { power_heuristic(1.0, ls.pdf, 1.0, bsdf.pdf(s.wo, wi)) } else { 1.0 };
        Some(ShadowTest { ray, t_max, li: f * tr * ls.li * (wi.z.abs() * mis / ls.pdf) })
    }

    /// [`Integrator::light_sample`] and its shadow ray at once: the light it adds (before β).
    #[cfg(test)]
    pub(crate) fn direct<E: EffectSet>(&self, est: Estimator, s: &Surface, bsdf: &Bsdf, medium: Vec3, u: Vec2, rays: &mut u32) -> Vec3 {
        let Some(test) = self.light_sample::<E>(est, s, bsdf, medium, u) else { return Vec3::ZERO };
        *rays += 1;
        if self.occluded::<E>(&test.ray, test.t_max) { Vec3::ZERO } else { test.li }
    }

    /// Continues the path along a BSDF sample; returns the throughput factor f·|cos|/pdf.
    fn scatter<E: EffectSet>(&self, s: &Surface, bs: &BsdfSample, ray: &mut Ray) -> Option<Vec3> {
        let wi = s.frame.to_world(bs.wi);
        // A direction on one side of the shading normal but the other of the surface would
        // pass through it (or, for glass, fail to).
        let side = wi.dot(s.ng);
        let ok = if E::GLASS && bs.wi.z < 0.0 { side < 0.0 } else { side > 0.0 };
        if !ok || !(bs.pdf > 0.0) {
            return None;
        }
        let w = bs.f * (bs.wi.z.abs() / bs.pdf);
        if !w.is_finite() {
            return None;
        }
        *ray = s.p.spawn(s.ng, wi);
        Some(w)
    }
}

/// Beer–Lambert: the fraction of light left after `dist` metres in a medium absorbing `sigma`
/// per metre (channels with σ = 0 keep everything, even over an infinite distance).
fn transmittance(sigma: Vec3, dist: f32) -> Vec3 {
    Vec3::select(sigma.cmpgt(Vec3::ZERO), (-sigma * dist).exp(), Vec3::ONE)
}

/// Applies Russian roulette; false when the path stops. Survivors are reweighted by 1/q.
/// `u` is asked for only when the path may stop.
pub(crate) fn survives_roulette(rr: Roulette, depth: u32, beta: &mut Vec3, u: impl FnOnce() -> f32) -> bool {
    let q = match rr {
        Roulette::Off => return true,
        Roulette::Threshold { threshold, p } => {
            if beta.max_element() >= threshold {
                return true;
            }
            1.0 - p
        }
        Roulette::Throughput { min_depth } => {
            if depth + 1 < min_depth || beta.max_element() >= 1.0 {
                return true;
            }
            beta.max_element()
        }
    };
    if !(u() < q) {
        return false;
    }
    *beta /= q;
    true
}
