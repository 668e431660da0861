//! Which triangles the tracer sees: each triangle's face normal in f64, none for a degenerate
//! one (invariant 15 in ARCHITECTURE.md), computed for a frame's million triangles over the
//! worker's threads, and the degenerate ones as a bit each for the tree.
use crate::tracer::ray::MACHINE_EPSILON;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::mem::MaybeUninit;

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

/// A frame's triangles as the tracer sees them: each one's face normal, and the box around the
/// solid ones (those with a normal), which a refit scales the tree by and the scene bounds its
/// geometry with. One pass over the triangles: each further pass over a million of them reads
/// 36 MB.
pub struct Faces {
    /// Each triangle's unit geometric normal ([`triangle_normal`] rounded to f32), zero for a
    /// degenerate one. A frame computes them once: the tree reads from them which triangles it
    /// may hit, the scene keeps them for shading.
    pub normals: Vec<Vec3>,
    /// Lowest and highest corner of the solid triangles; None when there are none.
    pub solid_box: Option<(Vec3, Vec3)>,
}

impl Faces {
    /// In parallel: a box's minima and maxima are exact in any order, so the same on any number
    /// of threads.
    pub fn of(tris: &[[Vec3; 3]]) -> Faces {
        let empty = (Vec3::INFINITY, Vec3::NEG_INFINITY);
        let chunk = |(out, tris): (&mut [MaybeUninit<Vec3>], &[[Vec3; 3]])| {
            let mut b = empty;
            for (n, t) in out.iter_mut().zip(tris) {
                let normal = triangle_normal(t).map_or(Vec3::ZERO, |n| n.as_vec3());
                n.write(normal);
                if normal != Vec3::ZERO {
                    b = t.iter().fold(b, |(lo, hi), &v| (lo.min(v), hi.max(v)));
                }
            }
            b
        };
        let mut normals = Vec::with_capacity(tris.len());
        let room = &mut normals.spare_capacity_mut()[..tris.len()];
        let union = |(l0, h0): (Vec3, Vec3), (l1, h1): (Vec3, Vec3)| (l0.min(l1), h0.max(h1));
        let (lo, hi) = room
            .par_chunks_mut(PARALLEL_GRAIN)
            .zip(tris.par_chunks(PARALLEL_GRAIN))
            .map(chunk)
            .reduce(|| empty, union);
        // SAFETY: the chunks cover the room, each slot written above.
        unsafe { normals.set_len(tris.len()) };
        Faces { normals, solid_box: lo.cmple(hi).all().then_some((lo, hi)) }
    }
}

/// Per-triangle work below this many items stays on one thread (here and in the scene's scans).
pub(crate) const PARALLEL_GRAIN: usize = 4096;

/// Which triangles are degenerate (a zero normal of [`Faces`]), a bit each: the packets are
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
        let word = |c: &[T]| {
            c.iter().enumerate().fold(0u64, |w, (k, x)| w | u64::from(degenerate(x)) << k)
        };
        Degenerate(items.par_chunks(64).with_min_len(64).map(word).collect())
    }

    pub(super) fn contains(&self, i: usize) -> bool {
        self.0.get(i / 64).is_some_and(|w| w >> (i % 64) & 1 != 0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Over several parallel chunks, with degenerate triangles (one in seven, and a point far
    /// off that would move the box), the normals are [`triangle_normal`]'s and the box is the
    /// solid triangles' own, as a plain loop finds them.
    #[test]
    fn faces_hold_each_normal_and_the_box_of_the_solid_triangles() {
        let mut state = 7u64;
        let mut next = || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32 * 20.0 - 10.0
        };
        let mut tris: Vec<[Vec3; 3]> = (0..3 * PARALLEL_GRAIN + 5)
            .map(|_| std::array::from_fn(|_| Vec3::new(next(), next(), next())))
            .collect();
        for i in (0..tris.len()).step_by(7) {
            tris[i][2] = tris[i][1]; // two corners in one place: no area
        }
        tris[PARALLEL_GRAIN + 1] = [Vec3::splat(1e6); 3];
        let faces = Faces::of(&tris);
        let expected: Vec<Vec3> =
            tris.iter().map(|t| triangle_normal(t).map_or(Vec3::ZERO, |n| n.as_vec3())).collect();
        assert_eq!(faces.normals, expected);
        let solid =
            tris.iter().zip(&expected).filter(|(_, n)| **n != Vec3::ZERO).flat_map(|(t, _)| *t);
        let (lo, hi) =
            solid.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), v| (lo.min(v), hi.max(v)));
        assert!(hi.max_element() < 10.0, "the far degenerate triangle is left out");
        assert_eq!(faces.solid_box, Some((lo, hi)));
        assert_eq!(Faces::of(&tris[..1]).solid_box, None, "a degenerate triangle alone has no box");
        assert_eq!(Faces::of(&[]).solid_box, None);
    }
}
