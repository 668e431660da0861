//! Resolving buffer and image URIs without letting a scene reach outside its own directory.
use super::SceneError;
use base64::Engine;
use std::path::{Component, Path, PathBuf};

/// Raw bytes of every buffer, in document order.
pub fn load_buffers(
    doc: &gltf::Document,
    base: Option<&Path>,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, SceneError> {
    let mut out = Vec::new();
    for buffer in doc.buffers() {
        let i = buffer.index();
        let mut data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                SceneError::new(format!(
                    "buffer {i}: refers to the GLB binary chunk, which is missing"
                ))
            })?,
            gltf::buffer::Source::Uri(uri) => {
                resolve(uri, base).map_err(|e| SceneError::new(format!("buffer {i}: {e}")))?
            }
        };
        if data.len() < buffer.length() {
            return Err(SceneError::new(format!(
                "buffer {i}: byteLength is {} but only {} bytes are present",
                buffer.length(),
                data.len()
            )));
        }
        // GLB chunks are padded to 4 bytes; keep what the document declares.
        data.truncate(buffer.length());
        out.push(data);
    }
    Ok(out)
}

/// The bytes behind a URI: a base64 data URI, or a relative file below `base`.
pub fn resolve(uri: &str, base: Option<&Path>) -> Result<Vec<u8>, String> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (meta, payload) = rest.split_once(',').ok_or("malformed data URI (no comma)")?;
        if !meta.ends_with(";base64") {
            return Err("data URI is not base64-encoded".into());
        }
        return base64::engine::general_purpose::STANDARD
            .decode(payload)
            .map_err(|e| format!("data URI: invalid base64 ({e})"));
    }
    let path = safe_relative_path(uri)?;
    let base = base.ok_or_else(|| format!("refers to external file {uri:?}, but the scene was given as a single file; embed it or upload a .glb"))?;
    std::fs::read(base.join(&path)).map_err(|e| format!("cannot read {uri:?}: {e}"))
}

/// A percent-decoded relative path with no root, no `..` and no scheme.
fn safe_relative_path(uri: &str) -> Result<PathBuf, String> {
    if uri.contains("://") || uri.starts_with('/') || uri.starts_with('\\') || uri.contains(':') {
        return Err(format!("external reference {uri:?} is not a relative path"));
    }
    let decoded = percent_encoding::percent_decode_str(uri)
        .decode_utf8()
        .map_err(|_| format!("URI {uri:?} is not valid UTF-8"))?;
    let path = PathBuf::from(decoded.as_ref());
    if path.components().any(|c| !matches!(c, Component::Normal(_) | Component::CurDir)) {
        return Err(format!("external reference {uri:?} leaves the scene's directory"));
    }
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_decode_and_paths_cannot_escape() {
        assert_eq!(
            resolve("data:application/octet-stream;base64,AAEC", None).unwrap(),
            vec![0, 1, 2]
        );
        assert!(resolve("data:application/octet-stream,AAEC", None).is_err());
        for bad in [
            "../secret.bin",
            "/etc/passwd",
            "a/../../b.bin",
            "file:///etc/passwd",
            "http://x/y.bin",
            "C:\\x.bin",
            "%2e%2e/x.bin",
        ] {
            let e = resolve(bad, Some(Path::new("/tmp"))).unwrap_err();
            assert!(e.contains("relative") || e.contains("leaves"), "{bad}: {e}");
        }
        assert!(resolve("mesh.bin", None).unwrap_err().contains("single file"));
    }
}
