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
//! Russian roulette is unbiased: a path that survives with probability q is divided by q.
//! Surfaces are black from behind unless their material is double-sided (rays do not pass
//! through the back of a single-sided triangle; that would leak light into closed rooms).
//! Glass is always two-sided, and is the only surface rays pass through.
//!
//! The loop is generic over an [`EffectSet`]: code for glass (transmission, absorption), alpha
//! masks and textured/non-Lambert surfaces is inside `if E::… {}` blocks that vanish from
//! kernels without them. A smooth glass bounce is a delta: no light sample is taken there, and
//! emission found after it counts in full for every estimator.
use crate::tracer::effects::{AllEffects, EffectSet};
use crate::tracer::light::LightSet;
use crate::tracer::path::{Bounce, Path};
use crate::tracer::ray::Ray;
use crate::tracer::ray_log::RayLog;
use crate::tracer::sampler::Sampler;
use crate::tracer::sampling::power_heuristic;
use crate::tracer::scene::{NO_LIGHT, Scene};
use crate::tracer::surface::Surface;
use glam::Vec3;
use std::str::FromStr;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Estimator {
    Naive,
    Bsdf,
    Light,
    Mis,
}

impl Estimator {
    pub const ALL: [Estimator; 4] = [Estimator::Naive, Estimator::Bsdf, Estimator::Light, Estimator::Mis];

    pub fn name(self) -> &'static str {
        match self {
            Estimator::Naive => "naive",
            Estimator::Bsdf => "bsdf",
            Estimator::Light => "light",
            Estimator::Mis => "mis",
        }
    }
}

impl FromStr for Estimator {
    type Err = String;
    fn from_str(s: &str) -> Result<Estimator, String> {
        Estimator::ALL
            .into_iter()
            .find(|e| e.name() == s)
            .ok_or_else(|| format!("unknown estimator {s:?} (expected one of naive, bsdf, light, mis)"))
    }
}

/// Russian roulette on the path throughput β.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Roulette {
    Off,
    /// The seed's form: once max(β) < `threshold`, stop with probability `p`, else β /= 1 − p.
    Threshold { threshold: f32, p: f32 },
    /// From bounce `min_depth` on, survive with probability max(β) (capped at 1), so a surviving
    /// path's throughput never exceeds 1 in any channel.
    Throughput { min_depth: u32 },
}

impl Default for Roulette {
    fn default() -> Roulette {
        Roulette::Throughput { min_depth: 3 }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    pub estimator: Estimator,
    pub roulette: Roulette,
    /// Most scattering events per path: a safety cap, not a bias knob (default 1024).
    pub max_depth: u32,
}

impl Default for PathSettings {
    fn default() -> PathSettings {
        PathSettings { estimator: Estimator::Mis, roulette: Roulette::default(), max_depth: 1024 }
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
    pub(crate) settings: PathSettings,
    /// Where every traced ray is recorded, when a benchmark asks (see [`RayLog`]).
    pub(crate) ray_log: Option<&'a RayLog>,
}

impl<'a> Integrator<'a> {
    pub fn new(scene: &'a Scene, background: Vec3, settings: PathSettings) -> Integrator<'a> {
        let lights = LightSet::new(&scene.lights, background, scene.bounds_radius).with_textures(&scene.textures);
        Integrator { scene, lights, settings, ray_log: None }
    }

    /// This integrator recording every ray it traces in `log`.
    pub fn with_ray_log(self, log: &'a RayLog) -> Integrator<'a> {
        Integrator { ray_log: Some(log), ..self }
    }

    /// Radiance along `ray` with every effect compiled in.
    pub fn li(&self, ray: Ray, sampler: &mut Sampler) -> PathSample {
        self.li_for::<AllEffects>(ray, sampler)
    }

    /// Radiance along `ray` by kernel `E` (see [`crate::tracer::effects`]): the stages of
    /// [`crate::tracer::path`], one bounce after another.
    pub fn li_for<E: EffectSet>(&self, ray: Ray, sampler: &mut Sampler) -> PathSample {
        let mut path = Path::new(ray);
        while let Some(s) = self.arrive::<E>(&mut path, sampler) {
            let Some(shaded) = self.shade::<E>(&mut path, &s, sampler) else { break };
            if let Some(test) = &shaded.shadow {
                self.test_shadow::<E>(&mut path, test);
            }
            if !self.continue_path::<E>(&mut path, &s, shaded.bs, sampler) {
                break;
            }
        }
        path.sample()
    }

    /// Radiance picked up when a ray leaves the scene.
    pub(crate) fn escaped(&self, est: Estimator, prev: Option<Bounce>, dir: Vec3) -> Vec3 {
        let lb = self.lights.background();
        match (est, prev) {
            (Estimator::Naive | Estimator::Bsdf, _) | (_, None) => lb,
            (_, Some(b)) if b.specular => lb,
            (Estimator::Light, Some(_)) => Vec3::ZERO,
            (Estimator::Mis, Some(b)) => {
                let light_pdf = self.lights.pdf_background(b.n, dir.normalize());
                lb * power_heuristic(1.0, b.bsdf_pdf, 1.0, light_pdf)
            }
        }
    }

    /// Emission at a hit, weighted as the estimator requires.
    pub(crate) fn emitted(&self, est: Estimator, depth: u32, prev: Option<Bounce>, s: &Surface) -> Vec3 {
        if s.le == Vec3::ZERO {
            return Vec3::ZERO;
        }
        match (est, prev) {
            (_, None) | (Estimator::Bsdf, _) => s.le,
            (_, Some(b)) if b.specular => s.le,
            (Estimator::Mis, Some(b)) if s.light != NO_LIGHT => {
                let light_pdf = self.lights.pdf_area(s.light, b.p, s.p.p);
                s.le * power_heuristic(1.0, b.bsdf_pdf, 1.0, light_pdf)
            }
            _ if depth == 0 => s.le,
            _ => Vec3::ZERO,
        }
    }
}

#[cfg(test)]
#[path = "integrator_tests.rs"]
pub(crate) mod tests;

#[cfg(test)]
#[path = "integrator_mis_tests.rs"]
mod mis_tests;
