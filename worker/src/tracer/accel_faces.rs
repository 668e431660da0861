//! Which triangles the tracer sees: each triangle's face normal in f64, none for a degenerate
//! one (invariant 15 in ARCHITECTURE.md), computed for a frame's million triangles over the
//! worker's threads, and the degenerate ones as a bit each for the tree.
use crate::tracer::ray::MACHINE_EPSILON;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// The unit geometric normal (counter-clockwise winding), computed in f64; None for a
/// degenerate triangle: one whose smallest height is at most half an f32 ulp of its largest
/// coordinate (zero-area triangles, needles). f32 cannot place a point strictly inside such a
/// triangle, and its f32 cross product may underflow to a NaN normal, so the tracer ignores it
/// (not hit, not a light).
pub fn triangle_normal(v: &[Vec3; 3]) -> Option<DVec3> {
    let [a, b, c] = v.map(|p| p.as_dvec3());
    let cross = (b - a).cross(c - a);
    let longest = (b - a).length().max((c - b).length()).max((a - c).length());
    let reach = a.abs().max(b.abs()).max(c.abs()).max_element();
    let height = cross.length() / longest;
    (height > MACHINE_EPSILON as f64 * reach && height.is_finite()).then(|| cross / cross.length())
}

/// Each triangle's unit geometric normal ([`triangle_normal`] rounded to f32), zero for a
/// degenerate one. A frame computes them once: the tree reads from them which triangles it may
/// hit, the scene keeps them for shading. A pure map, so the same on any number of threads.
pub fn face_normals(tris: &[[Vec3; 3]]) -> Vec<Vec3> {
    tris.par_iter().with_min_len(PARALLEL_GRAIN).map(|t| triangle_normal(t).map_or(Vec3::ZERO, |n| n.as_vec3())).collect()
}

/// Per-triangle work below this many items stays on one thread.
const PARALLEL_GRAIN: usize = 4096;

/// Which triangles are degenerate (a zero [`face_normals`]), a bit each: the packets are
/// gathered in tree order, in which a read of each triangle's 12-byte normal would miss the
/// cache as often as the triangle's own read does; the bits of a million fit in 128 KiB.
pub(super) struct Degenerate(Vec<u64>);

impl Degenerate {
    pub(super) const NONE: Degenerate = Degenerate(Vec::new());

    pub(super) fn of(normals: &[Vec3]) -> Degenerate {
        Degenerate::marking(normals, |n| *n == Vec3::ZERO)
    }

    /// [`Degenerate::of`] the triangles' normals, without keeping them.
    pub(super) fn of_triangles(tris: &[[Vec3; 3]]) -> Degenerate {
        Degenerate::marking(tris, |t| triangle_normal(t).is_none())
    }

    /// Bit i set where `degenerate(items[i])`; a word of 64 bits per task.
    fn marking<T: Sync>(items: &[T], degenerate: impl Fn(&T) -> bool + Sync) -> Degenerate {
        let word = |c: &[T]| c.iter().enumerate().fold(0u64, |w, (k, x)| w | u64::from(degenerate(x)) << k);
        Degenerate(items.par_chunks(64).with_min_len(64).map(word).collect())
    }

    pub(super) fn contains(&self, i: usize) -> bool {
        self.0.get(i / 64).is_some_and(|w| w >> (i % 64) & 1 != 0)
    }
}
