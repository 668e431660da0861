//! One configuration's convergence: relMSE against a reference after 1, 2, 4, … samples per
//! pixel, with the wall time spent so far.
//!
//! Rendering is progressive: sample indices [0, 1), [1, 2), [2, 4), … are rendered in turn and
//! their sums added. Randomness is addressed by sample index, so the sums after [0, n) are
//! exactly those of one n-spp render, and the whole ladder costs what its last rung costs.
use super::reference::Reference;
use std::time::Instant;
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::integrator::PathSettings;
use tessera_render::tracer::sampler::SamplerKind;
use tessera_render::tracer::{Estimator, PixelSums, RenderSettings, Roulette, Scene, render_tile};

/// What varies between the curves of one scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    pub estimator: Estimator,
    pub sampler: SamplerKind,
    pub roulette: bool,
}

impl Config {
    /// Every estimator × sampler × roulette, `mis` first within each sampler/roulette group.
    pub fn all() -> Vec<Config> {
        let mut out = Vec::new();
        for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
            for roulette in [true, false] {
                for estimator in
                    [Estimator::Mis, Estimator::Light, Estimator::Bsdf, Estimator::Naive]
                {
                    out.push(Config { estimator, sampler, roulette });
                }
            }
        }
        out
    }

    pub fn label(&self) -> String {
        format!(
            "{} {} rr {}",
            self.estimator.name(),
            self.sampler.name(),
            if self.roulette { "on" } else { "off" }
        )
    }

    pub fn settings(&self, size: u32, seed: u64) -> RenderSettings {
        let roulette = if self.roulette { Roulette::default() } else { Roulette::Off };
        RenderSettings {
            width: size,
            height: size,
            seed,
            sampler: self.sampler,
            path: PathSettings { estimator: self.estimator, roulette, ..PathSettings::default() },
            background: glam::Vec3::ZERO,
            camera: None,
        }
    }
}

/// The state of a render after its first `spp` samples per pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Point {
    pub spp: u32,
    /// Wall time spent rendering samples [0, spp), seconds.
    pub time_s: f64,
    pub rel_mse: f64,
}

/// When to stop climbing the ladder.
#[derive(Clone, Copy, Debug)]
pub struct Budget {
    /// Stop before a rung that would take the total past this many seconds.
    pub seconds: f64,
    pub max_spp: u32,
}

/// Renders `settings` at 1, 2, 4, … spp within `budget`, measuring relMSE against `reference`.
pub fn converge(
    scene: &Scene,
    settings: &RenderSettings,
    reference: &Reference,
    budget: Budget,
) -> Result<Vec<Point>, String> {
    let mut sums = vec![PixelSums::default(); (settings.width * settings.height) as usize];
    let mut points = Vec::new();
    let (mut done, mut elapsed) = (0u32, 0.0);
    loop {
        let next = (done * 2).max(1);
        let t = Instant::now();
        let part = render_tile(
            scene,
            settings,
            settings.full_frame(),
            done..next,
            &RenderOptions::default(),
        )
        .map_err(|e| e.to_string())?;
        elapsed += t.elapsed().as_secs_f64();
        sums.iter_mut().zip(&part.pixels).for_each(|(s, p)| s.merge(p));
        done = next;
        points.push(Point { spp: done, time_s: elapsed, rel_mse: reference.rel_mse(&sums) });
        // The next rung costs about as much as all before it.
        if done >= budget.max_spp || elapsed * 2.0 > budget.seconds {
            return Ok(points);
        }
    }
}

/// relMSE of an image against a reference: mean over pixels and channels of
/// (value − ref)² / (ref + 0.01)² (0.01 keeps black pixels finite).
pub fn rel_mse(means: impl Iterator<Item = [f64; 3]>, reference: &[[f64; 3]]) -> f64 {
    let mut acc = 0.0;
    let mut n = 0usize;
    for (m, r) in means.zip(reference) {
        for c in 0..3 {
            let d = r[c] + 0.01;
            acc += (m[c] - r[c]).powi(2) / (d * d);
        }
        n += 3;
    }
    acc / n.max(1) as f64
}
