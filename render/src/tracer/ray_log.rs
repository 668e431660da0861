//! A record of every ray a render traces, for measuring traversal on exactly the rays a path
//! tracer asks for (`tessera-bench bvh` times them through our BVH and through obvhs's own
//! traversal, against the render itself).
//!
//! Compiled only with the crate's `bench` feature (benchmark builds), and off unless a caller
//! hands one to [`crate::tracer::render_tile`] in its options: the product's render loop has no
//! check for it. Rays are kept in the order one thread
//! traces them; with several threads the order interleaves, the set does not change.
use crate::tracer::ray::Ray;
use std::sync::Mutex;

/// What the integrator asked of a ray.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RayQuery {
    /// The nearest surface (camera and bounce rays).
    Closest,
    /// Whether anything blocks it before `t_max` (shadow rays).
    Occluded,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoggedRay {
    pub ray: Ray,
    /// The ray's extent, in units of its (not necessarily unit) direction.
    pub t_max: f32,
    pub query: RayQuery,
}

#[derive(Debug, Default)]
pub struct RayLog(Mutex<Vec<LoggedRay>>);

impl RayLog {
    pub fn new() -> RayLog {
        RayLog::default()
    }

    pub(crate) fn push(&self, ray: &Ray, t_max: f32, query: RayQuery) {
        // A poisoned log only means another thread panicked mid-push; its rays are still rays.
        let mut rays = self.0.lock().unwrap_or_else(|e| e.into_inner());
        rays.push(LoggedRay { ray: *ray, t_max, query });
    }

    /// The rays logged so far, leaving the log empty.
    pub fn take(&self) -> Vec<LoggedRay> {
        std::mem::take(&mut *self.0.lock().unwrap_or_else(|e| e.into_inner()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::load_path;
    use crate::tracer::sampler::SamplerKind;
    use crate::tracer::{Estimator, Tile};
    use crate::tracer::{RenderOptions, render_tile};
    use std::path::Path;

    #[test]
    fn a_logged_render_gives_the_same_bits_and_logs_every_ray_it_counts() {
        let scene =
            load_path(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box.gltf"))
                .expect("bundled scene");
        let mut settings = crate::tracer::integrator::tests::settings(
            Estimator::Mis,
            Default::default(),
            32,
            glam::Vec3::ZERO,
        );
        settings.sampler = SamplerKind::Sobol;
        let tile = Tile { x0: 4, y0: 8, w: 16, h: 12 };
        let log = RayLog::new();
        let logged = render_tile(
            &scene,
            &settings,
            tile,
            0..4,
            &RenderOptions { ray_log: Some(&log), ..RenderOptions::default() },
        )
        .unwrap();
        assert_eq!(
            logged,
            render_tile(&scene, &settings, tile, 0..4, &RenderOptions::default()).unwrap(),
            "logging changes nothing"
        );
        let rays = log.take();
        assert_eq!(rays.len() as u64, logged.rays);
        let closest = rays.iter().filter(|r| r.query == RayQuery::Closest).count();
        assert!(closest >= 16 * 12 * 4, "at least one camera ray per sample, got {closest}");
        // Shadow rays to the box's area light end just short of it; closest-hit rays are unbounded.
        for r in &rays {
            match r.query {
                RayQuery::Closest => assert_eq!(r.t_max, f32::INFINITY),
                RayQuery::Occluded => assert!(r.t_max > 0.99 && r.t_max < 1.0, "{r:?}"),
            }
        }
        assert!(rays.len() > closest, "shadow rays are logged too");
        assert!(log.take().is_empty(), "take empties the log");
    }
}
