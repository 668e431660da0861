//! The scene's triangles: a triangle soup in world space, where index `i` of every vector
//! describes triangle `i`.
//!
//! What most triangles lack is not stored: a large scan or CAD mesh typically has flat normals,
//! no texture coordinates and no tangents, and storing those per corner would take 132 of the
//! 184 bytes a triangle holds (corner normals 36, two UV sets 48, tangents 48). Triangles are
//! appended with [`Mesh::push_attributes`], which keeps the compact forms while they hold and
//! expands a vector the first time a triangle needs it; readers go through [`Mesh::normals_of`],
//! [`Mesh::uvs_of`] and `tangents.get(i)`, so the stored form never changes what is read.
use glam::{Vec2, Vec3, Vec4};

#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<[Vec3; 3]>,
    /// Unit shading normals per corner (the face normal where the file has none), or empty
    /// while every triangle's three corners are the same bits: `flat_normals` then holds one
    /// per triangle (24 bytes a triangle less).
    pub normals: Vec<[Vec3; 3]>,
    pub flat_normals: Vec<Vec3>,
    /// Texture coordinates per corner for UV sets 0 and 1 (zero where absent), or empty when
    /// no triangle has any (48 bytes a triangle).
    pub uvs: Vec<[[Vec2; 3]; 2]>,
    /// `TANGENT` per corner (xyz, handedness w), or empty when no triangle has one; zero for
    /// triangles of primitives without (normal maps then derive tangents from UVs).
    pub tangents: Vec<[Vec4; 3]>,
    pub material: Vec<u32>,
}

impl Mesh {
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Triangle `i`'s corner UVs, both sets (zero when the mesh has none).
    #[inline]
    pub fn uvs_of(&self, i: usize) -> [[Vec2; 3]; 2] {
        self.uvs.get(i).copied().unwrap_or_default()
    }

    /// Triangle `i`'s corner normals, however they are stored.
    #[inline]
    pub fn normals_of(&self, i: usize) -> [Vec3; 3] {
        match self.normals.get(i) {
            Some(n) => *n,
            None => [self.flat_normals[i]; 3],
        }
    }

    /// Appends the next triangle's attributes (its index is `material.len()`; its positions are
    /// the caller's to push). `uvs` and `tangents`: None where the triangle has none.
    pub fn push_attributes(
        &mut self,
        normals: [Vec3; 3],
        uvs: Option<[[Vec2; 3]; 2]>,
        tangents: Option<[Vec4; 3]>,
        material: u32,
    ) {
        let i = self.material.len();
        if self.normals.is_empty() && is_flat(&normals) {
            self.flat_normals.push(normals[0]);
        } else {
            if self.normals.is_empty() {
                // As many as the mesh has room for (see `reserve`), and the flat ones freed.
                self.normals.reserve_exact(self.material.capacity());
                self.normals
                    .extend(std::mem::take(&mut self.flat_normals).into_iter().map(|n| [n; 3]));
            }
            self.normals.push(normals);
        }
        let room = self.material.capacity();
        if uvs.is_some() || !self.uvs.is_empty() {
            store(&mut self.uvs, i, room, uvs.unwrap_or_default());
        }
        if tangents.is_some() || !self.tangents.is_empty() {
            store(&mut self.tangents, i, room, tangents.unwrap_or([Vec4::ZERO; 3]));
        }
        self.material.push(material);
    }

    /// Appends `count` triangles of material `material` with flat normals and neither UVs nor
    /// tangents (a scan's or a generated mesh's): `pose` appends their positions and face
    /// normals, straight into the mesh's own vectors while it is in its compact forms (no copy
    /// of a frame's million normals), else into a scratch vector stored as
    /// [`Mesh::push_attributes`] would. Returns what `pose` returns.
    pub fn extend_flat<R>(
        &mut self,
        count: usize,
        material: u32,
        pose: impl FnOnce(&mut Vec<[Vec3; 3]>, &mut Vec<Vec3>) -> R,
    ) -> R {
        if self.normals.is_empty() && self.uvs.is_empty() && self.tangents.is_empty() {
            let posed = pose(&mut self.positions, &mut self.flat_normals);
            self.material.resize(self.material.len() + count, material);
            return posed;
        }
        let mut faces = Vec::with_capacity(count);
        let posed = pose(&mut self.positions, &mut faces);
        faces.into_iter().for_each(|f| self.push_attributes([f; 3], None, None, material));
        posed
    }

    /// Room for `additional` more triangles in the vectors every triangle uses, so a large
    /// mesh loads without the copies (and the freed blocks) of a vector doubling.
    pub fn reserve(&mut self, additional: usize) {
        self.positions.reserve(additional);
        self.material.reserve(additional);
        match self.normals.is_empty() {
            true => self.flat_normals.reserve(additional),
            false => self.normals.reserve(additional),
        }
    }

    /// Sets UV set `set` of triangle `i`'s corners (storing UVs from now on).
    pub fn set_uvs(&mut self, i: usize, set: usize, corners: [Vec2; 3]) {
        if self.uvs.len() < self.material.len() {
            self.uvs.resize(self.material.len(), Default::default());
        }
        self.uvs[i][set] = corners;
    }

    /// Appends a triangle with flat normals and no UVs.
    pub fn push_flat(&mut self, v: [Vec3; 3], material: u32) {
        let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
        self.positions.push(v);
        self.push_attributes([n; 3], None, None, material);
    }

    /// Brings a mesh whose vectors were filled directly to the compact forms (what is read does
    /// not change): UVs that are all zero dropped, flat normals kept once per triangle. A scene
    /// does it before building its BVH, whose peak is most of a large scene's memory.
    pub fn compact(&mut self) {
        if self.uvs.iter().flatten().flatten().all(|uv| *uv == Vec2::ZERO) {
            self.uvs = Vec::new();
        }
        if !self.normals.is_empty() && self.normals.iter().all(is_flat) {
            self.flat_normals = self.normals.iter().map(|n| n[0]).collect();
            self.normals = Vec::new();
        }
    }

    /// Bytes the mesh's vectors hold on the heap.
    pub fn heap_bytes(&self) -> usize {
        fn held<T>(v: &Vec<T>) -> usize {
            v.capacity() * size_of::<T>()
        }
        held(&self.positions)
            + held(&self.normals)
            + held(&self.flat_normals)
            + held(&self.uvs)
            + held(&self.tangents)
            + held(&self.material)
    }
}

/// Stores triangle `i`'s entry of a per-triangle vector stored only once some triangle needs it,
/// the triangles before `i` taking the default (zero: none); when the vector starts, with room
/// for as many triangles as the mesh has (see [`Mesh::reserve`]).
fn store<T: Clone + Default>(v: &mut Vec<T>, i: usize, room: usize, value: T) {
    if v.is_empty() {
        v.reserve_exact(room.max(i + 1));
    }
    v.resize(i, T::default());
    v.push(value);
}

/// Three corners of the same bits (equal as numbers is not enough: the sign of a zero can
/// decide a shading frame's orientation).
fn is_flat(n: &[Vec3; 3]) -> bool {
    let bits = |n: &Vec3| n.to_array().map(f32::to_bits);
    bits(&n[0]) == bits(&n[1]) && bits(&n[0]) == bits(&n[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`Mesh::extend_flat`] stores what a [`Mesh::push_attributes`] per triangle would, in
    /// the compact forms and after a triangle has made the mesh store more.
    #[test]
    fn flat_triangles_appended_at_once_are_stored_as_one_by_one() {
        let faces = [Vec3::X, Vec3::Y, Vec3::NEG_Z];
        let starts: [fn(&mut Mesh); 4] = [
            |_| {},
            |m| m.push_attributes([Vec3::Z; 3], None, None, 0),
            |m| m.push_attributes([Vec3::X, Vec3::Y, Vec3::Z], None, None, 0),
            |m| {
                m.push_attributes(
                    [Vec3::Z; 3],
                    Some([[Vec2::ONE; 3], [Vec2::ZERO; 3]]),
                    Some([Vec4::ONE; 3]),
                    0,
                )
            },
        ];
        for (k, start) in starts.iter().enumerate() {
            let (mut at_once, mut one_by_one) = (Mesh::default(), Mesh::default());
            start(&mut at_once);
            start(&mut one_by_one);
            at_once.extend_flat(faces.len(), 7, |_, normals| normals.extend_from_slice(&faces));
            faces.iter().for_each(|&f| one_by_one.push_attributes([f; 3], None, None, 7));
            let read = |m: &Mesh| {
                (0..m.material.len())
                    .map(|i| {
                        (m.normals_of(i), m.uvs_of(i), m.tangents.get(i).copied(), m.material[i])
                    })
                    .collect::<Vec<_>>()
            };
            assert_eq!(read(&at_once), read(&one_by_one), "start {k}");
            assert_eq!(
                (at_once.normals.len(), at_once.flat_normals.len(), at_once.uvs.len()),
                (one_by_one.normals.len(), one_by_one.flat_normals.len(), one_by_one.uvs.len()),
                "start {k}: stored forms"
            );
        }
    }
}
