//! Ray–triangle acceleration: an obvhs BVH with a watertight triangle test.
//!
//! obvhs supplies the tree and its SIMD node test; the walk (`wide.rs`) and the triangle
//! test are ours: watertight (Woop, Benthin and Wald 2013, as in pbrt-v4), because obvhs's
//! Möller–Trumbore test leaks rays through shared edges, and run on four triangles at once
//! (`packet.rs`).
//! Two obvhs pitfalls are handled here, not by callers:
//! - its `Ray::new` clamps tiny direction components, so near-axis rays could miss thin far
//!   geometry: we write the exact reciprocal (±f32::MAX for zero) into `inv_direction`;
//! - its wide BVH skips boxes lying entirely within 1e-4 of the origin, an absolute distance. The
//!   tree is therefore built in a space scaled by a power of two (exact in floating point) that
//!   makes the scene about 2¹² units across, where 1e-4 is below f32 resolution.
use crate::tracer::ray::Ray;
use build::{Topology, WIDE_STACK, to_wide, tree_scale, tree_triangles, wide_depth, wide_source};
use faces::Degenerate;
pub(crate) use faces::PARALLEL_GRAIN;
pub use faces::{Faces, triangle_normal};
use glam::{Vec3, Vec3A};
use obvhs::{BvhBuildParams, bvh2::Bvh2, ray::RayHit};
use packet::{Packets, WatertightRay, for_packets, intersect_triangle};
pub use refit::WORN;
use stats::Tally;
pub use stats::WalkCounts;
use std::sync::Arc;
use std::time::Duration;

/// Which obvhs tree to build. The wide BVH is faster; the binary one is kept for cross-checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BvhKind {
    Wide,
    Binary,
}

enum Tree {
    /// The nodes of obvhs's wide tree as our walk reads them (tight f32 child boxes,
    /// `node/mod.rs`); its primitive slots (`layout.rs`) live on as `prim_ids`.
    Wide(Vec<node::Node>),
    Binary(Bvh2),
    Empty,
}

pub struct Accel {
    tree: Tree,
    /// Triangle vertices in tree space, in the tree's primitive order, four to a packet.
    tris: Packets,
    /// Tree primitive slot → caller's triangle index (shared by the frames refitted from it).
    prim_ids: Arc<[u32]>,
    scale: f32,
    /// The tree's topology, kept by [`Accel::build_refittable`] so [`Accel::refit`] can move its
    /// boxes instead of building again; shared by every frame refitted from it.
    refit: Option<Arc<refit::RefitBase>>,
    /// Whether queries run the walk compiled for AVX2 (`accel/avx2.rs`): the same hits.
    avx2: bool,
}

/// Closest hit: ray parameter and barycentrics (b0 = 1 − b1 − b2) on triangle `prim`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub b1: f32,
    pub b2: f32,
}

impl Accel {
    /// The tree over every non-[degenerate](triangle_normal) triangle: those have no area
    /// f32 can resolve, and rounding in the hit test could only give them false hits.
    pub fn build(tris: &[[Vec3; 3]], kind: BvhKind) -> Accel {
        Accel::build_over(tris, &Degenerate::of_triangles(tris), kind, false)
    }

    /// [`Accel::build`], keeping what [`Accel::refit`] needs: for the wide tree obvhs's nodes
    /// and primitive slots (18 bytes per triangle more on the 1M-triangle field, `tessera-bench
    /// bvh`), for the binary one the tree itself.
    pub fn build_refittable(tris: &[[Vec3; 3]], kind: BvhKind) -> Accel {
        Accel::build_over(tris, &Degenerate::of_triangles(tris), kind, true)
    }

    /// [`Accel::build`] (or, `refittable`, [`Accel::build_refittable`]) given the triangles'
    /// [`Faces`] normals, which tell the degenerate ones: a frame whose refit was refused has
    /// them already, for its shading. (A build without them holds only a bit per triangle, not
    /// the normals' 12 bytes, through its memory peak.)
    pub fn build_with_normals(
        tris: &[[Vec3; 3]],
        normals: &[Vec3],
        kind: BvhKind,
        refittable: bool,
    ) -> Accel {
        assert_eq!(tris.len(), normals.len(), "one face normal per triangle");
        Accel::build_over(tris, &Degenerate::of(normals), kind, refittable)
    }

    /// The memory a build holds at once is most of a worker's peak on a large scene, so each
    /// part goes as soon as it has served: obvhs's copy of the triangles (48 bytes each) after
    /// the binary build, before the conversion to the wide tree allocates its own (the build's
    /// high point), and the binary tree before the wide nodes are made.
    ///
    /// A refittable tree also holds the degenerate triangles with finite corners, never hit (as
    /// those that become degenerate in a refit), so that a later frame in which one is
    /// degenerate no more can still be refitted.
    fn build_over(
        tris: &[[Vec3; 3]],
        degenerate: &Degenerate,
        kind: BvhKind,
        refittable: bool,
    ) -> Accel {
        // A refittable tree holds every triangle with finite corners, another the solid ones.
        let held = |i: usize| match refittable {
            true => tris[i].iter().all(|v| v.is_finite()),
            false => !degenerate.contains(i),
        };
        let keep: Vec<u32> = (0..tris.len() as u32).filter(|&i| held(i as usize)).collect();
        // A non-refittable tree holds no degenerate triangle to hide.
        let hidden = if refittable { degenerate } else { &Degenerate::NONE };
        // Over every triangle held, hidden ones too: obvhs's build takes their boxes as well
        // (a refit, which gives hidden triangles empty boxes, scales by the others alone).
        let scale = tree_scale(tris, held);
        if keep.is_empty() {
            return Accel {
                tree: Tree::Empty,
                tris: Packets::new(0, |_| [Vec3::ZERO; 3]),
                prim_ids: Arc::from([]),
                scale,
                refit: None,
                avx2: false,
            };
        }
        let params = BvhBuildParams::medium_build();
        let binary = || {
            Topology::Binary(obvhs::bvh2::builder::build_bvh2_from_tris(
                &tree_triangles(tris, &keep, scale),
                params,
                &mut Duration::default(),
            ))
        };
        let topology = match kind {
            BvhKind::Wide => {
                // A wide tree is walked with a fixed 32-entry stack (ours in wide.rs, like
                // obvhs's); a deeper tree would overflow it and silently drop nodes and hits. Pathological geometry (found by fuzzing) builds deeper
                // trees: those get the binary tree, whose traversal stack grows.
                let build = || {
                    let bvh2 = wide_source(&tree_triangles(tris, &keep, scale), params);
                    to_wide(&bvh2, params)
                };
                match std::panic::catch_unwind(std::panic::AssertUnwindSafe(build)) {
                    Ok(mut bvh) if wide_depth(&bvh) < WIDE_STACK => {
                        layout::pack_leaves(&mut bvh);
                        Topology::Wide(bvh)
                    }
                    _ => binary(),
                }
            }
            BvhKind::Binary => binary(),
        };
        // Padding slots (`layout::PAD`) are never tested: a zero triangle and index fill them.
        let prim_ids: Vec<u32> = topology
            .slots()
            .iter()
            .map(|&k| if k == layout::PAD { layout::PAD } else { keep[k as usize] })
            .collect();
        let packets = packets(&prim_ids, tris, scale, hidden);
        let (tree, wide) = match topology {
            Topology::Wide(mut bvh) => {
                let nodes = node::Node::of_tree(&bvh, |s| packets.slot_box(s));
                // obvhs sizes its vectors for the worst case: half the node memory is spare.
                bvh.nodes.shrink_to_fit();
                bvh.primitive_indices.shrink_to_fit();
                (Tree::Wide(nodes), refittable.then_some(bvh))
            }
            Topology::Binary(b) => (Tree::Binary(b), None),
        };
        let refit = refittable.then(|| {
            Arc::new(refit::RefitBase {
                count: tris.len(),
                keep,
                wide,
                built_cost: tree.walk_cost(),
            })
        });
        Accel {
            tree,
            tris: packets,
            prim_ids: prim_ids.into(),
            scale,
            refit,
            avx2: avx2::detected(),
        }
    }

    /// Closest hit with 0 < t < t_max.
    #[inline]
    pub fn intersect(&self, ray: &Ray, t_max: f32) -> Option<Hit> {
        self.intersect_where(ray, t_max, |_, _, _| true)
    }

    /// Closest hit with 0 < t < t_max among those `keep(triangle, b1, b2)` accepts (an any-hit
    /// filter, e.g. alpha masks: rejected hits do not shorten the ray).
    #[inline]
    pub fn intersect_where(
        &self,
        ray: &Ray,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
    ) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: `avx2` is set only where the CPU has the features `closest_avx2` enables.
            return unsafe { self.closest_avx2(ray, t_max, keep, &mut ()) };
        }
        self.closest::<false>(ray, t_max, keep, &mut ())
    }

    /// [`Accel::intersect`], adding what the walk did to `counts` (the wide tree's work only).
    pub fn intersect_counted(&self, ray: &Ray, t_max: f32, counts: &mut WalkCounts) -> Option<Hit> {
        self.closest::<false>(ray, t_max, |_, _, _| true, counts)
    }

    /// [`Accel::occluded`], adding what the walk did to `counts` (the wide tree's work only).
    pub fn occluded_counted(&self, ray: &Ray, t_max: f32, counts: &mut WalkCounts) -> bool {
        self.blocked::<false>(ray, t_max, |_, _, _| true, counts)
    }

    #[inline(always)]
    fn closest<const AVX: bool>(
        &self,
        ray: &Ray,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
        tally: &mut impl Tally,
    ) -> Option<Hit> {
        let (obvhs_ray, wt) = self.tree_ray(ray, t_max)?;
        // (slot, t, b1, b2) of the closest accepted candidate. The test accepts t ≤ tmax, so a
        // tie (a ray through a shared edge) comes here too: it goes to the smaller triangle
        // index, making the hit independent of the order in which the tree is walked (a
        // rebuilt and a refitted tree give the same hit). Only t < tmax shortens the ray.
        let mut best: Option<(usize, f32, f32, f32)> = None;
        let mut consider = |tmax: &mut f32, slot: usize, t: f32, b1: f32, b2: f32| {
            let closer = t < *tmax
                || (t == *tmax
                    && best.is_some_and(|(s, ..)| self.prim_ids[slot] < self.prim_ids[s]));
            if closer && keep(self.prim_ids[slot], b1, b2) {
                best = Some((slot, t, b1, b2));
                *tmax = tmax.min(t);
            }
        };
        match &self.tree {
            Tree::Wide(nodes) => {
                wide::walk::<AVX, _>(nodes, obvhs_ray, tally, |r, base, bits, tally| {
                    for_packets(base, bits, |packet, lanes| {
                        tally.packet(lanes);
                        for (lane, t, b1, b2) in self.tris.test(&wt, packet, lanes, r.tmax).iter() {
                            consider(&mut r.tmax, packet * 4 + lane, t, b1, b2);
                        }
                        false
                    })
                })
            }
            Tree::Binary(b) => {
                // obvhs shortens the ray to the t returned when it is below tmax.
                let mut hit = RayHit::none();
                b.ray_traverse(obvhs_ray, &mut hit, |r: &obvhs::ray::Ray, slot: usize| {
                    let mut tmax = r.tmax;
                    if let Some((t, b1, b2)) =
                        intersect_triangle(&wt, &self.tris.triangle(slot), r.tmax)
                    {
                        consider(&mut tmax, slot, t, b1, b2);
                    }
                    tmax
                });
            }
            Tree::Empty => {}
        }
        let (slot, t, b1, b2) = best?;
        Some(Hit { t: t / self.scale, prim: self.prim_ids[slot], b1, b2 })
    }

    /// Whether anything blocks the ray on 0 < t < t_max.
    #[inline]
    pub fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.occluded_where(ray, t_max, |_, _, _| true)
    }

    /// Whether a hit `keep(triangle, b1, b2)` accepts blocks the ray on 0 < t < t_max.
    #[inline]
    pub fn occluded_where(
        &self,
        ray: &Ray,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
    ) -> bool {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 {
            // SAFETY: as in `intersect_where`.
            return unsafe { self.blocked_avx2(ray, t_max, keep, &mut ()) };
        }
        self.blocked::<false>(ray, t_max, keep, &mut ())
    }

    #[inline(always)]
    fn blocked<const AVX: bool>(
        &self,
        ray: &Ray,
        t_max: f32,
        keep: impl Fn(u32, f32, f32) -> bool,
        tally: &mut impl Tally,
    ) -> bool {
        let Some((obvhs_ray, wt)) = self.tree_ray(ray, t_max) else { return false };
        let blocks = |slot: usize, t: f32, b1: f32, b2: f32, tmax: f32| {
            t < tmax && keep(self.prim_ids[slot], b1, b2)
        };
        match &self.tree {
            Tree::Wide(nodes) => {
                let mut found = false;
                wide::walk::<AVX, _>(nodes, obvhs_ray, tally, |r, base, bits, tally| {
                    found = for_packets(base, bits, |packet, lanes| {
                        tally.packet(lanes);
                        let c = self.tris.test(&wt, packet, lanes, r.tmax);
                        c.iter()
                            .any(|(lane, t, b1, b2)| blocks(packet * 4 + lane, t, b1, b2, r.tmax))
                    });
                    found
                });
                found
            }
            Tree::Binary(b) => {
                !b.ray_traverse_miss(obvhs_ray, |r: &obvhs::ray::Ray, slot: usize| {
                    match intersect_triangle(&wt, &self.tris.triangle(slot), r.tmax) {
                        Some((t, b1, b2)) if blocks(slot, t, b1, b2, r.tmax) => t,
                        _ => f32::INFINITY,
                    }
                })
            }
            Tree::Empty => false,
        }
    }

    #[inline(always)]
    fn tree_ray(&self, ray: &Ray, t_max: f32) -> Option<(obvhs::ray::Ray, WatertightRay)> {
        let origin = ray.origin * self.scale;
        // In SIMD: glam's Vec3 tests each component apart (a branch and a bit test each).
        let dir = Vec3A::from(ray.dir);
        if !(Vec3A::from(origin).is_finite() && dir.is_finite()) || dir.cmpeq(Vec3A::ZERO).all() {
            return None;
        }
        let tmax = t_max * self.scale;
        let inv = exact_reciprocal(dir);
        let r = obvhs::ray::Ray {
            origin: origin.into(),
            direction: ray.dir.into(),
            inv_direction: inv,
            tmin: 0.0,
            tmax,
        };
        Some((r, WatertightRay::new(origin, ray.dir)))
    }
}

/// The tree's triangles in tree space, slot by slot (`prim_ids[k]`: the caller's triangle in
/// slot k); a triangle `hidden` holds gets NaN corners, which fail every comparison of the
/// triangle test, so it is never hit.
fn packets(prim_ids: &[u32], tris: &[[Vec3; 3]], scale: f32, hidden: &Degenerate) -> Packets {
    Packets::new(prim_ids.len(), |slot| match prim_ids[slot] {
        layout::PAD => [Vec3::ZERO; 3],
        i if hidden.contains(i as usize) => [Vec3::NAN; 3],
        i => tris[i as usize].map(|v| v * scale),
    })
}

/// 1/x per lane, with ±f32::MAX instead of ±∞ so that a slab test on a zero component gives
/// 0·MAX = 0 (ray inside the slab) rather than NaN. One SIMD division, the bits of three.
#[inline(always)]
fn exact_reciprocal(x: Vec3A) -> Vec3A {
    let r = Vec3A::ONE / x;
    Vec3A::select(r.is_finite_mask(), r, Vec3A::splat(f32::MAX).copysign(r))
}

/// Closest hit (t, triangle index) by testing every triangle in world space: the reference
/// the BVH traversal is checked against.
#[cfg(test)]
pub(crate) fn brute_force(tris: &[[Vec3; 3]], ray: &Ray) -> Option<(f32, u32)> {
    let wt = WatertightRay::new(ray.origin, ray.dir);
    let mut best: Option<(f32, u32)> = None;
    for (i, t) in tris.iter().enumerate() {
        let limit = best.map_or(f32::INFINITY, |b| b.0);
        if let Some((th, _, _)) = intersect_triangle(&wt, t, limit) {
            best = Some((th, i as u32));
        }
    }
    best
}

mod avx2;
mod build;
mod faces;
mod layout;
mod node;
mod packet;
mod refit;
mod stats;
mod wide;

#[cfg(test)]
mod tests;
