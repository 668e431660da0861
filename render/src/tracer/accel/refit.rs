//! BVH refits for animation frames: the next frame's tree keeps this one's topology and only
//! moves its boxes, recomputed bottom-up from the moved triangles.
//!
//! The wide tree is refitted as the walk reads it: its nodes' tight f32 child boxes are made
//! again from the triangles below each child ([`super::node::Node::of_tree`], as at build), over
//! the links and packed primitive slots kept from the build. Refitting obvhs's binary tree and
//! converting it to a wide tree again would be most of a build's work: on the 1M-triangle
//! field that took 0.57–0.66 s against a build's 0.85 s, where this refit takes 0.08 s (`tessera-bench
//! bvh`, docs/performance.md).
//!
//! A refittable tree holds every triangle with finite corners, the degenerate ones (see
//! [`super::triangle_normal`]) with empty boxes and NaN corners, never hit. A triangle may then
//! become degenerate or stop being so between frames and the tree still refits: a deforming
//! mesh's slivers cross that line (the bench's waved field does), and each crossing used to
//! cost a full build.
//!
//! The refitted tree has the topology the first frame's triangles chose, so the further
//! triangles move from where they were built, the more its boxes overlap and the slower (never
//! the wronger) its walk: a hit is the closest (t, triangle index) whatever the tree. Its
//! [`Accel::wear`] (its surface-area cost against the cost as built) tells when a frame is
//! better served by a build: [`Accel::worn`], past [`WORN`].
use super::Faces;
use super::build::scale_for_box;
use super::{Accel, Tree};
use glam::Vec3;
use obvhs::{aabb::Aabb, bvh2::Bvh2, cwbvh::CwBvh};
use std::sync::Arc;

/// What a refit needs besides the tree the walk reads: the caller's triangles the tree holds
/// (its primitives, in input order) and, for a wide tree, obvhs's wide tree with its leaves
/// packed (the links and primitive slots the walk's nodes were made from). A binary tree is its
/// own topology.
pub(super) struct RefitBase {
    /// The number of triangles the tree was built over.
    pub(super) count: usize,
    pub(super) keep: Vec<u32>,
    pub(super) wide: Option<CwBvh>,
    /// The wide tree's surface-area cost as built ([`super::node::walk_cost`]).
    pub(super) built_cost: Option<f64>,
}

impl RefitBase {
    /// Whether `tris`, with their normals of [`Faces`] (zero for a degenerate triangle, which
    /// the tree holds but must not hit), can be refitted onto this tree: not another count, and
    /// no triangle the tree left out (not finite when it was built) solid now.
    fn holds(&self, tris: &[[Vec3; 3]], normals: &[Vec3]) -> bool {
        if tris.len() != self.count || normals.len() != self.count {
            return false;
        }
        if self.keep.len() == self.count {
            return true;
        }
        let mut held = self.keep.iter().peekable();
        !(0u32..).zip(normals).any(|(i, &n)| held.next_if_eq(&&i).is_none() && n != Vec3::ZERO)
    }
}

/// A refitted tree whose surface-area cost exceeds its cost as built by this factor is worn
/// out: [`Accel::worn`].
pub const WORN: f64 = 1.5;

impl Accel {
    /// The tree for `tris`, made by moving the boxes of this one (built by
    /// [`Accel::build_refittable`] over triangles that have since moved), not by building anew.
    /// None when that is not possible: no topology kept, another number of triangles, or a
    /// triangle the tree left out (one with a corner not finite) that is not degenerate now. A
    /// triangle the tree holds that is degenerate (see [`super::triangle_normal`]) stays in it,
    /// never hit: its box is empty and its vertices NaN, which fail every comparison of the
    /// triangle test.
    ///
    /// Hits do not depend on the tree: the closest hit is the smallest (t, triangle index)
    /// whatever the traversal order (see [`Accel::intersect_where`]).
    pub fn refit(&self, tris: &[[Vec3; 3]]) -> Option<Accel> {
        self.refit_with_faces(tris, &Faces::of(tris))
    }

    /// [`Accel::refit`] given the triangles' [`Faces`], which a scene computes once for the
    /// tree and for its shading.
    pub fn refit_with_faces(&self, tris: &[[Vec3; 3]], faces: &Faces) -> Option<Accel> {
        let normals = &faces.normals;
        let base = self.refit.as_ref().filter(|b| b.holds(tris, normals))?;
        // Every solid triangle is held (a left-out one is degenerate: `holds`), so the tree's
        // scale is that of the solid triangles' box.
        let scale = faces.solid_box.map_or(1.0, |(lo, hi)| scale_for_box(lo, hi));
        let packets = super::packets(&self.prim_ids, tris, scale, &super::Degenerate::of(normals));
        let tree = match (&self.tree, &base.wide) {
            (Tree::Wide(_), Some(wide)) => {
                Tree::Wide(super::node::Node::of_tree(wide, |s| packets.slot_box(s)))
            }
            (Tree::Binary(b), _) => {
                let mut b = b.clone();
                refit_boxes(&mut b, |s| packets.slot_box(s));
                Tree::Binary(b)
            }
            _ => return None,
        };
        Some(Accel {
            tree,
            tris: packets,
            prim_ids: Arc::clone(&self.prim_ids),
            scale,
            refit: Some(Arc::clone(base)),
            avx2: self.avx2,
        })
    }

    /// The wide tree's surface-area cost against its cost as built: 1 for a tree as built, more
    /// as refits onto moving triangles make its boxes overlap. None for a tree not built
    /// refittable, or not wide.
    pub fn wear(&self) -> Option<f64> {
        let built = self.refit.as_ref()?.built_cost?;
        let now = self.tree.walk_cost()?;
        Some(if built > 0.0 { now / built } else { 1.0 })
    }

    /// Whether this tree's walk is expected to cost more than [`WORN`] times the walk of the tree
    /// as built: the next frame should be built, not refitted.
    pub fn worn(&self) -> bool {
        self.wear().is_some_and(|w| w > WORN)
    }
}

impl Tree {
    pub(super) fn walk_cost(&self) -> Option<f64> {
        match self {
            Tree::Wide(nodes) => Some(super::node::walk_cost(nodes)),
            _ => None,
        }
    }
}

/// Leaf boxes from the moved triangles (`slot_box(s)`: the box of the triangle in primitive
/// slot s), then every inner box from its children.
fn refit_boxes(bvh2: &mut Bvh2, slot_box: impl Fn(usize) -> Aabb) {
    for node in bvh2.nodes.iter_mut().filter(|n| n.is_leaf()) {
        let first = node.first_index as usize;
        let aabb = (first..first + node.prim_count as usize)
            .map(&slot_box)
            .fold(Aabb::INVALID, |a, b| a.union(&b));
        node.set_aabb(aabb);
    }
    bvh2.refit_all();
}
