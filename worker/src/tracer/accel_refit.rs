//! BVH refits for animation frames: the next frame's tree keeps this one's topology and only
//! moves its boxes (obvhs `Bvh2::refit_all`), then the wide tree is converted again.
use super::build::{WIDE_STACK, kept, to_wide, tree_scale, tree_triangles, wide_depth};
use super::{Accel, Tree};
use glam::Vec3;
use obvhs::{BvhBuildParams, aabb::Aabb, bvh2::Bvh2, triangle::Triangle};

/// What a refit needs: the caller's triangles the tree holds (its primitives, in input order)
/// and the binary tree over them.
pub(super) struct RefitBase {
    pub(super) keep: Vec<u32>,
    pub(super) bvh2: Bvh2,
}

impl Accel {
    /// The tree for `tris`, made by moving the boxes of this one (built by
    /// [`Accel::build_refittable`] over triangles that have since moved), not by building anew:
    /// same topology, boxes refitted bottom-up, and for the wide tree a new conversion from the
    /// refitted binary one. None when that is not possible: no binary tree kept, a different
    /// set of (non-degenerate) triangles, or a wide tree that would be too deep.
    ///
    /// Hits do not depend on the tree: the closest hit is the smallest (t, triangle index)
    /// whatever the traversal order (see [`Accel::intersect_where`]).
    pub fn refit(&self, tris: &[[Vec3; 3]]) -> Option<Accel> {
        let base = self.refit.as_ref()?;
        if kept(tris) != base.keep {
            return None;
        }
        let scale = tree_scale(base.keep.iter().map(|&i| &tris[i as usize]));
        let obvhs_tris = tree_triangles(tris, &base.keep, scale);
        let mut bvh2 = base.bvh2.clone();
        refit_boxes(&mut bvh2, &obvhs_tris);
        let (tree, wide_slots) = match &self.tree {
            Tree::Wide(..) => {
                let wide = to_wide(&bvh2, BvhBuildParams::medium_build());
                if wide_depth(&wide) >= WIDE_STACK {
                    return None;
                }
                let (tree, slots) = Tree::wide(wide, |p| obvhs_tris[p].aabb());
                (tree, Some(slots))
            }
            Tree::Binary(_) => (Tree::Binary(bvh2.clone()), None),
            Tree::Empty => return None,
        };
        let keep = base.keep.clone();
        Some(Accel::assemble(tree, wide_slots, tris, &keep, scale, Some(RefitBase { keep: keep.clone(), bvh2 })))
    }

}

/// Leaf boxes from the moved triangles, then every inner box from its children.
fn refit_boxes(bvh2: &mut Bvh2, tris: &[Triangle]) {
    for node in bvh2.nodes.iter_mut().filter(|n| n.is_leaf()) {
        let first = node.first_index as usize;
        let prims = &bvh2.primitive_indices[first..first + node.prim_count as usize];
        let aabb = prims.iter().map(|&p| tris[p as usize].aabb()).reduce(|a, b| a.union(&b)).unwrap_or(Aabb::INVALID);
        node.set_aabb(aabb);
    }
    bvh2.refit_all();
}

