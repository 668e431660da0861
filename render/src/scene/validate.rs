//! Checks the `gltf` crate's own validator skips (it panics on them instead).
use serde_json::Value;

/// Why the `gltf` crate panicked on `bytes`, as far as we can tell.
pub fn explain_panic(bytes: &[u8]) -> String {
    std::panic::catch_unwind(|| dangling_position(bytes))
        .unwrap_or_else(|_| "the document refers to an object that does not exist".into())
}

/// The first primitive whose POSITION attribute names an accessor that does not exist (the one
/// unchecked index in gltf-json 1.4's validator).
fn dangling_position(bytes: &[u8]) -> String {
    let json = match gltf::Glb::from_slice(bytes) {
        Ok(glb) => serde_json::from_slice::<Value>(&glb.json),
        Err(_) => serde_json::from_slice::<Value>(bytes),
    };
    let Ok(root) = json else {
        return "the document refers to an object that does not exist".into();
    };
    let accessors = root["accessors"].as_array().map_or(0, Vec::len);
    let meshes = root["meshes"].as_array().map(Vec::as_slice).unwrap_or_default();
    for (m, mesh) in meshes.iter().enumerate() {
        let prims = mesh["primitives"].as_array().map(Vec::as_slice).unwrap_or_default();
        for (p, prim) in prims.iter().enumerate() {
            if let Some(i) =
                prim["attributes"]["POSITION"].as_u64().filter(|&i| i >= accessors as u64)
            {
                return format!(
                    "meshes[{m}].primitives[{p}].attributes[\"POSITION\"] is accessor {i}, but there are only {accessors} accessors"
                );
            }
        }
    }
    "the document refers to an object that does not exist".into()
}

/// The GLB container's lengths, checked before the `gltf` crate reads them (gltf 1.4 subtracts
/// the 12-byte header from the declared length unchecked: a panic in debug builds).
pub fn glb_container(bytes: &[u8]) -> Result<(), String> {
    if !bytes.starts_with(b"glTF") {
        return Ok(()); // JSON, judged by the parser
    }
    let u32_at = |o: usize| {
        bytes.get(o..o + 4).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize)
    };
    let declared = u32_at(8).ok_or_else(|| {
        format!("GLB: the file is {} bytes, shorter than the 12-byte header", bytes.len())
    })?;
    if declared < 12 || declared > bytes.len() {
        return Err(format!(
            "GLB: the header declares {declared} bytes but the file has {}",
            bytes.len()
        ));
    }
    let mut at = 12;
    while at < declared {
        let len = u32_at(at)
            .filter(|_| at + 8 <= declared)
            .ok_or_else(|| format!("GLB: truncated chunk header at byte {at}"))?;
        if len > declared - at - 8 {
            return Err(format!(
                "GLB: the chunk at byte {at} declares {len} bytes, past the end of the file"
            ));
        }
        at += 8 + len;
    }
    Ok(())
}
