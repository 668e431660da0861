//! Bounds checks on accessors before the `gltf` reader touches them: the reader trusts the file
//! and panics (or reads garbage) on out-of-range views, which a render farm must refuse instead.
use super::SceneError;

/// Checks every accessor a triangle primitive reads.
pub fn check_primitive(
    prim: &gltf::Primitive,
    buffers: &[Vec<u8>],
    at: &dyn Fn(&str) -> String,
) -> Result<(), SceneError> {
    for (semantic, accessor) in prim.attributes() {
        check(&accessor, buffers)
            .map_err(|e| SceneError::new(at(&format!("{} accessor {e}", semantic.to_string()))))?;
        check_type(&semantic, &accessor)
            .map_err(|e| SceneError::new(at(&format!("{} accessor {e}", semantic.to_string()))))?;
    }
    if let Some(ix) = prim.indices() {
        check(&ix, buffers).map_err(|e| SceneError::new(at(&format!("indices accessor {e}"))))?;
        if ix.dimensions() != gltf::accessor::Dimensions::Scalar
            || !matches!(
                ix.data_type(),
                gltf::accessor::DataType::U8
                    | gltf::accessor::DataType::U16
                    | gltf::accessor::DataType::U32
            )
        {
            return Err(SceneError::new(at("indices must be unsigned scalar integers")));
        }
    }
    Ok(())
}

/// Largest count of an accessor that has no buffer view (16 M elements: 200 MB as f32 VEC3).
const MAX_VIEWLESS_COUNT: usize = 1 << 24;

/// The element types glTF allows for the attributes the loader reads (the `gltf` reader assumes
/// them: it debug-asserts, or reads misaligned garbage, on others).
fn check_type(semantic: &gltf::Semantic, a: &gltf::Accessor) -> Result<(), String> {
    use gltf::Semantic::{Normals, Positions, TexCoords};
    use gltf::accessor::{DataType::*, Dimensions::*};
    let ok = match semantic {
        Positions | Normals => a.dimensions() == Vec3 && a.data_type() == F32,
        TexCoords(_) => a.dimensions() == Vec2 && matches!(a.data_type(), F32 | U8 | U16),
        _ => true, // not read
    };
    if ok {
        Ok(())
    } else {
        Err(format!(
            "has type {:?} of {:?}, which glTF does not allow for it",
            a.dimensions(),
            a.data_type()
        ))
    }
}

/// Checks that an accessor's data lies inside its buffers (the message continues "accessor …").
pub fn check_accessor(a: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<(), String> {
    check(a, buffers)
}

fn check(a: &gltf::Accessor, buffers: &[Vec<u8>]) -> Result<(), String> {
    let count = a.count();
    if count == 0 {
        return Err("count 0".into());
    }
    let size = a.size();
    // Without a buffer view the accessor is zeros (plus sparse values): nothing in the file
    // bounds its count, so a tiny file could make the reader allocate gigabytes.
    if a.view().is_none() && count > MAX_VIEWLESS_COUNT {
        return Err(format!(
            "has no bufferView and count {count}; at most {MAX_VIEWLESS_COUNT} such elements are accepted"
        ));
    }
    if let Some(view) = a.view() {
        let stride = view.stride().unwrap_or(size);
        if stride < size {
            return Err(format!("byteStride {stride} is smaller than its element size {size}"));
        }
        let span = (count - 1)
            .checked_mul(stride)
            .and_then(|s| s.checked_add(size))
            .and_then(|s| s.checked_add(a.offset()));
        if span.is_none_or(|s| s > view.length()) {
            return Err(format!(
                "with count {count} reads past the end of buffer view {}",
                view.index()
            ));
        }
        check_view(&view, buffers)?;
    }
    if let Some(sparse) = a.sparse() {
        let n = sparse.count();
        let (iv, vv) = (sparse.indices().view(), sparse.values().view());
        check_view(&iv, buffers)?;
        check_view(&vv, buffers)?;
        let index_size = sparse.indices().index_type().size();
        if n.checked_mul(index_size).is_none_or(|s| s + sparse.indices().offset() > iv.length())
            || n.checked_mul(size).is_none_or(|s| s + sparse.values().offset() > vv.length())
        {
            return Err(format!("sparse data with count {n} reads past its buffer views"));
        }
    }
    Ok(())
}

fn check_view(view: &gltf::buffer::View, buffers: &[Vec<u8>]) -> Result<(), String> {
    let len = buffers.get(view.buffer().index()).map_or(0, Vec::len);
    match view.offset().checked_add(view.length()) {
        Some(end) if end <= len => Ok(()),
        _ => Err(format!(
            "buffer view {} lies outside buffer {} ({len} bytes)",
            view.index(),
            view.buffer().index()
        )),
    }
}

/// A `VEC3` float accessor's elements as they lie in the buffer, when they are tightly packed
/// (the usual layout of `POSITION`): read in place, a million-triangle mesh costs no copy of
/// its vertices. None when the elements must go through the reader (strided, sparse,
/// unaligned, no buffer view, or a big-endian host). Call after [`check_primitive`].
pub fn packed_vec3<'a>(a: &gltf::Accessor, buffers: &'a [Vec<u8>]) -> Option<&'a [[f32; 3]]> {
    use gltf::accessor::{DataType, Dimensions};
    const ELEMENT: usize = size_of::<[f32; 3]>();
    let view = a.view()?;
    let packed = a.data_type() == DataType::F32
        && a.dimensions() == Dimensions::Vec3
        && view.stride().is_none_or(|s| s == ELEMENT);
    if !packed || a.sparse().is_some() || a.normalized() || cfg!(target_endian = "big") {
        return None;
    }
    let start = view.offset() + a.offset();
    let bytes = buffers.get(view.buffer().index())?.get(start..start + a.count() * ELEMENT)?;
    bytemuck::try_cast_slice(bytes).ok()
}
