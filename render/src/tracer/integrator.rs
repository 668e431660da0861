//! Path-tracing estimators of the radiance arriving along a camera ray.
//!
//! All four are unbiased and converge to the same image; they differ in variance, which is what
//! the accuracy study measures:
//!
//! | `Estimator` | at each hit                                                            |
//! |-------------|------------------------------------------------------------------------|
//! | `Naive`     | the seed's first tracer: with probability ½ return 2·Le, else continue in a uniformly random hemisphere direction with weight 2·f·cos/p |
//! | `Bsdf`      | add Le, continue by BSDF importance sampling                            |
//! | `Light`     | sample one light (emission is counted only through light samples, and on the camera ray), continue by BSDF sampling |
//! | `Mis`       | both, combined with the power heuristic (the default)                  |
//!
//! Russian roulette ([`Roulette`], its own file) is unbiased: a path that survives with
//! probability q is divided by q.
//! Surfaces are black from behind unless their material is double-sided (rays do not pass
//! through the back of a single-sided triangle; that would leak light into closed rooms).
//! Glass is always two-sided, and is the only surface rays pass through.
//!
//! The loop is generic over an [`EffectSet`]: code for glass (transmission, absorption), alpha
//! masks and textured/non-Lambert surfaces is inside `if E::… {}` blocks that vanish from
//! kernels without them. A smooth glass bounce is a delta: no light sample is taken there, and
//! emission found after it counts in full for every estimator.
use crate::tracer::bsdf::{Bsdf, BsdfSample};
use crate::tracer::kernel::{AllEffects, EffectSet};
use crate::tracer::light::{LightSampler, LightSet, Target};
use crate::tracer::ray::{Ray, SHADOW_EPSILON};
#[cfg(feature = "bench")]
use crate::tracer::ray_log::RayLog;
pub use crate::tracer::roulette::{DEFAULT_ROULETTE_DEPTH, Roulette};
use crate::tracer::sampler::Sampler;
use crate::tracer::sampling::power_heuristic;
use crate::tracer::scene::{NO_LIGHT, Scene};
use crate::tracer::surface::Surface;
use glam::{Vec2, Vec3, Vec3A};
use std::str::FromStr;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Estimator {
    Naive,
    Bsdf,
    Light,
    Mis,
}

impl Estimator {
    pub const ALL: [Estimator; 4] =
        [Estimator::Naive, Estimator::Bsdf, Estimator::Light, Estimator::Mis];

    pub fn name(self) -> &'static str {
        match self {
            Estimator::Naive => "naive",
            Estimator::Bsdf => "bsdf",
            Estimator::Light => "light",
            Estimator::Mis => "mis",
        }
    }
}

/// Error from parsing an unknown estimator name; lists the valid names.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown estimator {0:?} (expected one of naive, bsdf, light, mis)")]
pub struct UnknownEstimator(pub String);

impl FromStr for Estimator {
    type Err = UnknownEstimator;
    fn from_str(s: &str) -> Result<Estimator, UnknownEstimator> {
        Estimator::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| UnknownEstimator(s.to_owned()))
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    pub estimator: Estimator,
    pub roulette: Roulette,
    /// Most scattering events per path: a safety cap, not a bias knob (default 1024).
    pub max_depth: u32,
    /// How light samples choose among the area lights (default: through the tree where it
    /// suits the scene, [`LightTree::suits`](crate::tracer::light::LightTree::suits)).
    pub light_sampler: LightSampler,
}

impl Default for PathSettings {
    fn default() -> PathSettings {
        PathSettings {
            estimator: Estimator::Mis,
            roulette: Roulette::default(),
            max_depth: 1024,
            light_sampler: LightSampler::Auto,
        }
    }
}

/// One camera sample's radiance and the largest throughput weight along its path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSample {
    pub radiance: Vec3,
    pub max_weight: f32,
    /// Rays traced for it: closest-hit (camera and bounces) and shadow rays.
    pub rays: u32,
}

pub struct Integrator<'a> {
    pub(crate) scene: &'a Scene,
    pub(crate) lights: LightSet<'a>,
    settings: PathSettings,
    /// Where every traced ray is recorded, when a benchmark asks (see [`RayLog`]).
    #[cfg(feature = "bench")]
    pub(crate) ray_log: Option<&'a RayLog>,
}

/// The previous bounce, for MIS weights of emission found by a BSDF-sampled ray.
#[derive(Clone, Copy)]
struct Bounce {
    // 16-byte lanes: a Vec3 pair packed at 12-byte offsets was copied into the Option by
    // overlapping stores and read back across them, a store-forwarding stall on every bounce
    // (6 % of `li_for`'s profile samples).
    p: Vec3A,
    n: Vec3A,
    bsdf_pdf: f32,
    /// A delta bounce: light sampling could not have found what this ray finds.
    specular: bool,
}

impl<'a> Integrator<'a> {
    pub fn new(scene: &'a Scene, background: Vec3, settings: PathSettings) -> Integrator<'a> {
        let lights = LightSet::with_tree(
            &scene.lights,
            scene.light_tree_for(settings.light_sampler),
            background,
            scene.bounds_radius,
        )
        .with_textures(&scene.textures);
        Integrator {
            scene,
            lights,
            settings,
            #[cfg(feature = "bench")]
            ray_log: None,
        }
    }

    /// This integrator recording every ray it traces in `log`.
    #[cfg(feature = "bench")]
    pub fn with_ray_log(self, log: &'a RayLog) -> Integrator<'a> {
        Integrator { ray_log: Some(log), ..self }
    }

    /// Radiance along `ray` with every effect compiled in.
    pub fn li(&self, ray: Ray, sampler: &mut Sampler) -> PathSample {
        self.li_for::<AllEffects>(ray, sampler)
    }

    /// Radiance along `ray` by kernel `E` (see [`crate::tracer::effects`]).
    pub fn li_for<E: EffectSet>(&self, mut ray: Ray, sampler: &mut Sampler) -> PathSample {
        let est = self.settings.estimator;
        let (mut l, mut beta, mut max_weight) = (Vec3::ZERO, Vec3::ONE, 1.0f32);
        let mut prev: Option<Bounce> = None;
        // Absorption coefficient of the medium the ray travels in (zero: air).
        let mut medium = Vec3::ZERO;
        // Product of η'² over the refractions so far: β·eta_scale is the throughput without
        // the 1/η'² radiance compression, which roulette must not mistake for absorption.
        let mut eta_scale = 1.0f32;
        // Non-specular bounces so far: the depth roulette waits for.
        let mut rough_bounces = 0u32;
        let mut rays = 0u32;
        for depth in 0.. {
            let u_glass = if E::GLASS { sampler.get_1d() } else { 0.0 };
            rays += 1;
            let hit = self.surface::<E>(&ray, u_glass);
            if E::GLASS && medium != Vec3::ZERO {
                beta *= transmittance(medium, hit.as_ref().map_or(f32::INFINITY, |s| s.dist));
            }
            let Some(s) = hit else {
                l += beta * self.escaped(est, prev, ray.dir);
                break;
            };
            let bs = if est == Estimator::Naive {
                // The seed's first tracer: emit or reflect, each with probability ½.
                let (u_choice, u_dir) = (sampler.get_1d(), sampler.get_2d());
                if u_choice < 0.5 {
                    l += beta * 2.0 * s.le;
                    break;
                }
                let Some(bsdf) = s.bsdf.filter(|_| depth < self.settings.max_depth) else { break };
                // Uniform directions never hit a delta lobe: glass is sampled by its BSDF.
                let bs = if E::GLASS && bsdf.transmits() {
                    bsdf.sample(s.wo, (u_choice - 0.5) * 2.0, u_dir)
                } else {
                    bsdf.sample_uniform(s.wo, u_dir)
                };
                let Some(mut bs) = bs else { break };
                bs.pdf *= 0.5;
                bs
            } else {
                l += beta * self.emitted(est, depth, prev, &s);
                let u_light = sampler.get_2d();
                let (d_lobe, u_dir) = (sampler.defer_1d(), sampler.get_2d());
                let Some(bsdf) = s.bsdf.filter(|_| depth < self.settings.max_depth) else { break };
                let delta = E::GLASS && bsdf.is_specular();
                if matches!(est, Estimator::Light | Estimator::Mis)
                    && !delta
                    && !self.lights.is_empty()
                {
                    l += beta * self.direct::<E>(est, &s, &bsdf, medium, u_light, &mut rays);
                }
                let u_lobe = if bsdf.chooses_lobes() { sampler.deferred(d_lobe) } else { 0.0 };
                let Some(bs) = bsdf.sample(s.wo, u_lobe, u_dir) else { break };
                bs
            };
            let Some(w) = self.scatter::<E>(&s, &bs, &mut ray) else { break };
            beta *= w;
            if E::GLASS && bs.wi.z < 0.0 {
                medium = s.medium_behind(medium);
                eta_scale *= bs.eta * bs.eta;
            }
            prev = Some(Bounce {
                p: s.p.p.into(),
                n: s.frame.n.into(),
                bsdf_pdf: bs.pdf,
                specular: bs.specular,
            });
            if !beta.is_finite() {
                // An overflowed throughput makes the sample meaningless (∞·0 later): report it
                // as non-finite, so it is dropped and counted, and keep max_weight finite.
                return PathSample { radiance: Vec3::NAN, max_weight, rays };
            }
            max_weight = max_weight.max(beta.max_element());
            let d_roulette = sampler.defer_1d();
            rough_bounces += u32::from(!bs.specular);
            if !self
                .settings
                .roulette
                .survives(rough_bounces, &mut beta, eta_scale, || sampler.deferred(d_roulette))
            {
                break;
            }
        }
        PathSample { radiance: l, max_weight, rays }
    }

    /// Radiance picked up when a ray leaves the scene.
    fn escaped(&self, est: Estimator, prev: Option<Bounce>, dir: Vec3) -> Vec3 {
        let lb = self.lights.background();
        match (est, prev) {
            (Estimator::Naive | Estimator::Bsdf, _) | (_, None) => lb,
            (_, Some(b)) if b.specular => lb,
            (Estimator::Light, Some(_)) => Vec3::ZERO,
            (Estimator::Mis, Some(b)) => {
                let light_pdf = self.lights.pdf_background(b.n.into(), dir.normalize());
                lb * power_heuristic(1.0, b.bsdf_pdf, 1.0, light_pdf)
            }
        }
    }

    /// Emission at a hit, weighted as the estimator requires.
    // Always: a call would take the `Surface` out of registers (see `Integrator::surface`).
    #[inline(always)]
    fn emitted(&self, est: Estimator, depth: u32, prev: Option<Bounce>, s: &Surface) -> Vec3 {
        if s.le == Vec3::ZERO {
            return Vec3::ZERO;
        }
        match (est, prev) {
            (_, None) | (Estimator::Bsdf, _) => s.le,
            (_, Some(b)) if b.specular => s.le,
            (Estimator::Mis, Some(b)) if s.light != NO_LIGHT => {
                let light_pdf = self.lights.pdf_area(s.light, b.p.into(), b.n.into(), s.p.p);
                s.le * power_heuristic(1.0, b.bsdf_pdf, 1.0, light_pdf)
            }
            _ if depth == 0 => s.le,
            _ => Vec3::ZERO,
        }
    }

    /// Next-event estimation: one light sample, MIS-weighted for `Mis`.
    fn direct<E: EffectSet>(
        &self,
        est: Estimator,
        s: &Surface,
        bsdf: &Bsdf,
        medium: Vec3,
        u: Vec2,
        rays: &mut u32,
    ) -> Vec3 {
        let Some(ls) = self.lights.sample_for::<E>(s.p.p, s.frame.n, u) else { return Vec3::ZERO };
        let wi = s.frame.to_local(ls.wi);
        let side = ls.wi.dot(s.ng);
        // Only glass sees lights behind the surface, and only where both normals agree.
        let through = E::GLASS && bsdf.transmits() && side < 0.0 && wi.z < 0.0;
        if !through && (side <= 0.0 || wi.z <= 0.0) {
            return Vec3::ZERO;
        }
        let f = bsdf.eval(s.wo, wi);
        if f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let (shadow, dist) = match ls.target {
            Target::Point { p, ng } => (s.p.spawn_to(s.ng, &p, ng), (p.p - s.p.p).length()),
            Target::Infinite => (s.p.spawn(s.ng, ls.wi), f32::INFINITY),
        };
        let t_max = if dist.is_finite() { 1.0 - SHADOW_EPSILON } else { f32::INFINITY };
        *rays += 1;
        if self.occluded::<E>(&shadow, t_max) {
            return Vec3::ZERO;
        }
        let tr = if E::GLASS {
            let m = if through { s.medium_behind(medium) } else { medium };
            if m == Vec3::ZERO { Vec3::ONE } else { transmittance(m, dist) }
        } else {
            Vec3::ONE
        };
        let mis = if est == Estimator::Mis && !ls.delta {
            power_heuristic(1.0, ls.pdf, 1.0, bsdf.pdf(s.wo, wi))
        } else {
            1.0
        };
        f * tr * ls.li * (wi.z.abs() * mis / ls.pdf)
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

#[cfg(test)]
pub(crate) mod tests;
