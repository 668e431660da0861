//! obvhs as its own benchmarks use it, beside our BVH in `tessera-bench bvh`: a compressed wide
//! BVH of the same triangles (same build parameters), its traversal and its Möller–Trumbore
//! triangle test (not watertight). Closest-hit rays go through `ray_traverse`, shadow rays
//! through `ray_traverse_miss`, which stops at the first blocker: obvhs's fastest path for each.
use glam::Vec3;
use obvhs::cwbvh::CwBvh;
use obvhs::triangle::Triangle;
use std::time::Instant;
use tessera_render::tracer::accel::{Accel, WalkCounts};
use tessera_render::tracer::ray::Ray;
use tessera_render::tracer::ray_log::{LoggedRay, RayQuery};

pub struct StockBvh {
    tris: Vec<Triangle>,
    bvh: CwBvh,
}

impl StockBvh {
    pub fn new(tris: &[[Vec3; 3]]) -> StockBvh {
        let tris: Vec<Triangle> = tris
            .iter()
            .map(|t| Triangle { v0: t[0].into(), v1: t[1].into(), v2: t[2].into() })
            .collect();
        let bvh = obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &tris,
            obvhs::BvhBuildParams::medium_build(),
            &mut std::time::Duration::default(),
        );
        StockBvh { tris, bvh }
    }

    /// Whether `ray` meets a triangle before `t_max` (for closest-hit queries, after finding
    /// the nearest).
    fn hits(&self, ray: &Ray, t_max: f32, query: RayQuery) -> bool {
        let ray = obvhs::ray::Ray::new(ray.origin.into(), ray.dir.into(), 0.0, t_max);
        let test = |r: &obvhs::ray::Ray, id: usize| {
            self.tris[self.bvh.primitive_indices[id] as usize].intersect(r)
        };
        match query {
            RayQuery::Closest => self.bvh.ray_traverse(ray, &mut obvhs::ray::RayHit::none(), test),
            RayQuery::Occluded => !self.bvh.ray_traverse_miss(ray, test),
        }
    }

    /// Closest-hit rays of unbounded extent: the hits and the single-core seconds.
    pub fn trace(&self, rays: &[Ray]) -> (u64, f64) {
        let t = Instant::now();
        let hits = rays.iter().map(|r| self.hits(r, f32::INFINITY, RayQuery::Closest) as u64).sum();
        (hits, t.elapsed().as_secs_f64())
    }

    /// Logged rays, each asked what the path tracer asked: the hits and the single-core seconds.
    pub fn trace_logged(&self, rays: &[LoggedRay]) -> (u64, f64) {
        let t = Instant::now();
        let hits = rays.iter().map(|r| self.hits(&r.ray, r.t_max, r.query) as u64).sum();
        (hits, t.elapsed().as_secs_f64())
    }
}

/// The logged rays through our BVH alone, as the path tracer asked them: the hits and the
/// single-core seconds.
pub fn ours_logged(accel: &Accel, rays: &[LoggedRay]) -> (u64, f64) {
    let t = Instant::now();
    let hits = rays
        .iter()
        .map(|r| match r.query {
            RayQuery::Closest => accel.intersect(&r.ray, r.t_max).is_some(),
            RayQuery::Occluded => accel.occluded(&r.ray, r.t_max),
        } as u64)
        .sum();
    (hits, t.elapsed().as_secs_f64())
}

/// What our walk did on the logged rays: (closest-hit rays', shadow rays') counts.
pub fn ours_counted(accel: &Accel, rays: &[LoggedRay]) -> (WalkCounts, WalkCounts) {
    let (mut closest, mut shadow) = (WalkCounts::default(), WalkCounts::default());
    for r in rays {
        match r.query {
            RayQuery::Closest => _ = accel.intersect_counted(&r.ray, r.t_max, &mut closest),
            RayQuery::Occluded => _ = accel.occluded_counted(&r.ray, r.t_max, &mut shadow),
        }
    }
    (closest, shadow)
}
