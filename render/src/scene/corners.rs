//! A primitive's triangles as corner indices, read without materialising them: a non-indexed
//! primitive (the usual form of a scan or a generated mesh) numbers its vertices in order, and
//! listing those numbers, then the triangles, would cost 24 bytes a triangle for nothing.
use gltf::mesh::Mode;

/// The vertex each corner of the primitive uses, in order.
pub enum Corners {
    /// From the `indices` accessor.
    Listed(Vec<u32>),
    /// No `indices`: corner k is vertex k, for this many vertices.
    InOrder(u32),
}

/// Triangle t's corner indices under one primitive mode.
type TriangleAt = fn(&Corners, usize) -> [u32; 3];

impl Corners {
    fn len(&self) -> usize {
        match self {
            Corners::Listed(ix) => ix.len(),
            Corners::InOrder(n) => *n as usize,
        }
    }

    fn at(&self, k: usize) -> u32 {
        match self {
            Corners::Listed(ix) => ix[k],
            Corners::InOrder(_) => k as u32,
        }
    }

    /// The first index that is not a vertex of the `vertices` the primitive has.
    pub fn out_of_range(&self, vertices: usize) -> Option<u32> {
        match self {
            Corners::Listed(ix) => ix.iter().copied().find(|&i| i as usize >= vertices),
            Corners::InOrder(n) => (*n as usize > vertices).then_some(vertices as u32),
        }
    }

    /// The triangles of `mode` (lists, strips, fans) by index: how many there are and triangle
    /// t's corners, so that they can be read in any order (by several threads); None for points
    /// and lines.
    pub fn indexed(&self, mode: Mode) -> Option<(usize, impl Fn(usize) -> [u32; 3] + Sync + '_)> {
        let n = self.len();
        let (count, shape): (usize, TriangleAt) = match mode {
            Mode::Triangles => (n / 3, |c, t| [c.at(3 * t), c.at(3 * t + 1), c.at(3 * t + 2)]),
            // Every other triangle of a strip is reversed to keep the winding.
            Mode::TriangleStrip => (n.saturating_sub(2), |c, t| match t % 2 {
                0 => [c.at(t), c.at(t + 1), c.at(t + 2)],
                _ => [c.at(t + 1), c.at(t), c.at(t + 2)],
            }),
            Mode::TriangleFan => (n.saturating_sub(2), |c, t| [c.at(0), c.at(t + 1), c.at(t + 2)]),
            _ => return None,
        };
        Some((count, move |t| shape(self, t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangles(c: &Corners, mode: Mode) -> Option<Vec<[u32; 3]>> {
        let (count, at) = c.indexed(mode)?;
        Some((0..count).map(at).collect())
    }

    fn listed(mode: Mode, ix: &[u32]) -> Vec<[u32; 3]> {
        triangles(&Corners::Listed(ix.to_vec()), mode).unwrap()
    }

    #[test]
    fn lists_strips_and_fans_give_gltf_triangles() {
        assert_eq!(listed(Mode::Triangles, &[5, 6, 7, 8, 9, 10, 11]), [[5, 6, 7], [8, 9, 10]]);
        assert_eq!(
            listed(Mode::TriangleStrip, &[0, 1, 2, 3, 4]),
            [[0, 1, 2], [2, 1, 3], [2, 3, 4]]
        );
        assert_eq!(listed(Mode::TriangleFan, &[0, 1, 2, 3, 4]), [[0, 1, 2], [0, 2, 3], [0, 3, 4]]);
        assert_eq!(listed(Mode::TriangleFan, &[0, 1]), Vec::<[u32; 3]>::new());
        assert!(triangles(&Corners::InOrder(3), Mode::Lines).is_none());
    }

    #[test]
    fn vertices_in_order_are_the_same_triangles_as_their_listed_numbers() {
        for mode in [Mode::Triangles, Mode::TriangleStrip, Mode::TriangleFan] {
            for n in 0..8 {
                let ix: Vec<u32> = (0..n).collect();
                let in_order = triangles(&Corners::InOrder(n), mode).unwrap();
                assert_eq!(in_order, listed(mode, &ix), "{mode:?} with {n} vertices");
            }
        }
    }

    #[test]
    fn finds_the_first_index_past_the_vertices() {
        assert_eq!(Corners::Listed(vec![0, 4, 2, 9]).out_of_range(4), Some(4));
        assert_eq!(Corners::Listed(vec![0, 3, 2]).out_of_range(4), None);
        assert_eq!(Corners::InOrder(4).out_of_range(4), None);
    }
}
