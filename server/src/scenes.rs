//! Content-addressed scene store: `DATA/scenes/<sha256>`, plus the bundled scenes by name.
//!
//! A scene is validated when stored (parsed, no BVH) and described once; workers fetch the bytes
//! by hash and build their own BVH.
use crate::bundled;
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::RwLock;
use tessera_proto::SceneAnimation;

#[derive(Clone, Debug, PartialEq)]
pub struct SceneMeta {
    pub id: String,
    pub triangles: u64,
    pub effects: Vec<String>,
    pub cameras: Vec<String>,
    pub animations: Vec<SceneAnimation>,
}

/// Why a scene was not stored.
#[derive(Debug, thiserror::Error)]
pub enum PutError {
    /// The bytes are not a scene this coordinator accepts (the reason names what is wrong).
    #[error("{0}")]
    Invalid(String),
    /// A valid scene that could not be written to the store.
    #[error("storing the scene failed: {0}")]
    Storage(std::io::Error),
}

pub struct SceneStore {
    dir: PathBuf,
    meta: RwLock<HashMap<String, SceneMeta>>,
    /// Bundled scene name → id.
    names: HashMap<String, String>,
    /// Bundled scenes by id. They live in the binary, so they are never written to `dir`, and
    /// each is described (parsed) on first use rather than at open: storing all of them cost
    /// every start 6 ms warm and 50 ms cold (two fsyncs each).
    bundled: HashMap<String, &'static [u8]>,
    max_triangles: u64,
}

pub fn scene_id(bytes: &[u8]) -> String {
    hex::encode(Sha256::digest(bytes))
}

impl SceneStore {
    /// Opens the store and registers the bundled scenes.
    pub fn open(dir: PathBuf, max_triangles: u64) -> std::io::Result<SceneStore> {
        std::fs::create_dir_all(&dir)?;
        let mut store = SceneStore {
            dir,
            meta: RwLock::new(HashMap::new()),
            names: HashMap::new(),
            bundled: HashMap::new(),
            max_triangles,
        };
        store.index_stored();
        for (name, bytes) in bundled::SCENES {
            let id = scene_id(bytes);
            store.names.insert(name.to_string(), id.clone());
            store.bundled.insert(id, bytes);
        }
        Ok(store)
    }

    /// Describes a bundled scene the first time it is asked for (no-op for anything else).
    fn ensure_described(&self, id: &str) {
        let Some(bytes) = self.bundled.get(id) else { return };
        if self.meta.read().expect("lock").contains_key(id) {
            return;
        }
        match self.describe(id, bytes) {
            Ok(meta) => {
                self.meta.write().expect("lock").insert(id.to_string(), meta);
            }
            Err(e) => tracing::error!(scene = id, "a bundled scene does not load: {e}"),
        }
    }

    /// Re-reads the descriptions of scenes stored by an earlier run (files named by their hash).
    fn index_stored(&mut self) {
        let Ok(entries) = std::fs::read_dir(&self.dir) else { return };
        for e in entries.flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if name.len() != 64 || !name.bytes().all(|b| b.is_ascii_hexdigit()) {
                continue;
            }
            match std::fs::read(e.path()).map_err(PutError::Storage).and_then(|b| self.put(&b)) {
                Ok(_) => {}
                Err(err) => {
                    tracing::warn!(scene = %name, "ignoring a stored scene that no longer loads: {err}")
                }
            }
        }
    }

    /// Validates and stores a scene; idempotent.
    pub fn put(&self, bytes: &[u8]) -> Result<SceneMeta, PutError> {
        let id = scene_id(bytes);
        if let Some(m) = self.meta.read().expect("lock").get(&id) {
            return Ok(m.clone());
        }
        let meta = self.describe(&id, bytes).map_err(PutError::Invalid)?;
        write_atomically(&self.dir.join(&id), bytes).map_err(PutError::Storage)?;
        self.meta.write().expect("lock").insert(id, meta.clone());
        Ok(meta)
    }

    /// Parses (no BVH) and describes a scene, refusing one with no triangles or too many.
    fn describe(&self, id: &str, bytes: &[u8]) -> Result<SceneMeta, String> {
        let parsed = tessera_render::scene::parse_limited(bytes, None, self.max_triangles)
            .map_err(|e| e.0)?;
        let triangles = parsed.triangles() as u64;
        if triangles > self.max_triangles {
            return Err(format!(
                "the scene has {triangles} triangles; this coordinator accepts at most {}",
                self.max_triangles
            ));
        }
        if triangles == 0 {
            return Err("the scene has no triangles".into());
        }
        let animations = parsed
            .animations()
            .into_iter()
            .map(|a| SceneAnimation { name: a.name, duration_s: a.duration_s })
            .collect();
        Ok(SceneMeta {
            id: id.to_string(),
            triangles,
            effects: parsed.effects(),
            cameras: parsed.cameras(),
            animations,
        })
    }

    /// A scene id or a bundled name → the scene's metadata.
    pub fn resolve(&self, id_or_name: &str) -> Option<SceneMeta> {
        let id = self.names.get(id_or_name).map(String::as_str).unwrap_or(id_or_name);
        self.ensure_described(id);
        self.meta.read().expect("lock").get(id).cloned()
    }

    /// The name of the bundled scene with this id, if it is one.
    pub fn bundled_name(&self, id: &str) -> Option<String> {
        self.names.iter().find(|(_, i)| *i == id).map(|(name, _)| name.clone())
    }

    /// Every stored scene: bundled ones first by name, then uploads by id.
    pub fn list(&self) -> Vec<(Option<String>, SceneMeta)> {
        self.bundled.keys().for_each(|id| self.ensure_described(id));
        let meta = self.meta.read().expect("lock");
        let mut named: Vec<_> = self
            .names
            .iter()
            .filter_map(|(n, id)| Some((Some(n.clone()), meta.get(id)?.clone())))
            .collect();
        named.sort_by(|a, b| a.0.cmp(&b.0));
        let bundled: std::collections::HashSet<&String> = self.names.values().collect();
        let mut uploaded: Vec<_> =
            meta.values().filter(|m| !bundled.contains(&m.id)).map(|m| (None, m.clone())).collect();
        uploaded.sort_by(|a, b| a.1.id.cmp(&b.1.id));
        named.extend(uploaded);
        named
    }

    pub fn bytes(&self, id: &str) -> Option<Vec<u8>> {
        if let Some(bytes) = self.bundled.get(id) {
            return Some(bytes.to_vec());
        }
        if !self.meta.read().expect("lock").contains_key(id) {
            return None; // also keeps request paths away from the filesystem
        }
        std::fs::read(self.dir.join(id)).ok()
    }
}

/// Temp file, fsync, rename, fsync the directory: readers see the old file or the whole new one.
pub fn write_atomically(path: &std::path::Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let dir = path.parent().unwrap_or(std::path::Path::new("."));
    let tmp =
        dir.join(format!(".{}.tmp", path.file_name().and_then(|n| n.to_str()).unwrap_or("file")));
    let mut f = std::fs::File::create(&tmp)?;
    f.write_all(bytes)?;
    f.sync_all()?;
    std::fs::rename(&tmp, path)?;
    std::fs::File::open(dir)?.sync_all()
}
