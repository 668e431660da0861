//! The hard cases: scenes and inputs built to break a path tracer numerically.
//! Each test names the naive implementation it catches; `docs/numerics.md` maps every case to
//! its technique and test. Shared scene builders come from the integrator's tests.
mod accumulation;
mod degenerate;
mod energy;
mod far;
mod lights;
mod lobes;
mod spawn;

use crate::tracer::chi2::Rng;
use glam::Vec3;

/// A uniformly random unit vector.
pub(crate) fn unit_vector(rng: &mut Rng) -> Vec3 {
    let z = 2.0 * rng.f32() - 1.0;
    let phi = std::f32::consts::TAU * rng.f32();
    let r = ((1.0 - z) * (1.0 + z)).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// 10^x for x uniform in [lo, hi).
pub(crate) fn log_uniform(rng: &mut Rng, lo: f32, hi: f32) -> f32 {
    10f32.powf(lo + (hi - lo) * rng.f32())
}
