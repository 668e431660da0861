//! Scratch directories for commands that run a coordinator of their own (`tessera render`, the
//! benchmarks): its job store and checkpoints live there for the command's lifetime only.
//!
//! A [`ScratchDir`] removes its directory when dropped, so an early return or an error does not
//! leave it behind. A command that ends by `std::process::exit` runs no destructors; it calls
//! [`remove_all`] first (a benchmark whose reader has gone does, see [`crate::say!`]).
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Every scratch directory of this process that has not been removed yet.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// A directory under the system's temporary directory, named after its purpose and this
/// process; created by whoever uses it, removed (with its contents) on drop.
#[derive(Debug)]
pub struct ScratchDir {
    path: PathBuf,
}

impl ScratchDir {
    /// `…/tmp/tessera-<label>-<pid>`. The label tells concurrent uses in one process apart.
    pub fn new(label: &str) -> ScratchDir {
        let path = std::env::temp_dir().join(format!("tessera-{label}-{}", std::process::id()));
        live().push(path.clone());
        ScratchDir { path }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ScratchDir {
    fn drop(&mut self) {
        live().retain(|p| p != &self.path);
        let _ = std::fs::remove_dir_all(&self.path);
    }
}

/// Removes every live scratch directory: for a process about to exit without unwinding.
pub fn remove_all() {
    for path in live().drain(..) {
        let _ = std::fs::remove_dir_all(path);
    }
}

fn live() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    // A panic elsewhere while the list was held leaves it intact: keep using it.
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_dropped_scratch_dir_is_gone_with_its_contents() {
        let dir = ScratchDir::new("scratch-test-drop");
        std::fs::create_dir_all(dir.path().join("nested")).unwrap();
        std::fs::write(dir.path().join("nested/file"), b"x").unwrap();
        let path = dir.path().to_path_buf();
        drop(dir);
        assert!(!path.exists());
        assert!(!live().contains(&path));
    }
}
