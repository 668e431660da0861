//! Fingerprints the source that decides a pixel's bits, for [`renderer_id`](src/renderer_id.rs).
//!
//! SHA-256 over this crate's `src/` and `Cargo.toml` and the workspace's `Cargo.lock` (the
//! versions of glam, gltf and the rest), each file as its relative path and contents, in path
//! order. Tests are left out by path (every `tests.rs`, everything under a `tests/` folder):
//! they change no pixel, and a test edit should not set two builds' workers apart.
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

fn main() {
    let crate_dir =
        PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let roots =
        [crate_dir.join("src"), crate_dir.join("Cargo.toml"), crate_dir.join("../Cargo.lock")];
    let mut files = Vec::new();
    for root in &roots {
        // Missing (a crate packaged on its own): fingerprint what there is.
        if root.exists() {
            println!("cargo:rerun-if-changed={}", root.display());
            collect(root, &mut files);
        }
    }
    files.sort();
    let mut hash = Sha256::new();
    for file in &files {
        let name =
            file.strip_prefix(&crate_dir).unwrap_or(file).to_string_lossy().replace('\\', "/");
        let bytes =
            std::fs::read(file).unwrap_or_else(|e| panic!("reading {}: {e}", file.display()));
        hash.update((name.len() as u64).to_le_bytes());
        hash.update(name.as_bytes());
        hash.update((bytes.len() as u64).to_le_bytes());
        hash.update(&bytes);
    }
    let digest = hash.finalize();
    let hex: String = digest.iter().take(6).map(|b| format!("{b:02x}")).collect();
    println!("cargo:rustc-env=TESSERA_SOURCE_HASH={hex}");
}

fn collect(path: &Path, out: &mut Vec<PathBuf>) {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    if path.is_dir() {
        if name == "tests" {
            return;
        }
        let entries =
            std::fs::read_dir(path).unwrap_or_else(|e| panic!("listing {}: {e}", path.display()));
        for entry in entries {
            collect(&entry.expect("directory entry").path(), out);
        }
        return;
    }
    let source = name.ends_with(".rs") || name.ends_with(".toml") || name == "Cargo.lock";
    if source && name != "tests.rs" {
        out.push(path.to_path_buf());
    }
}
