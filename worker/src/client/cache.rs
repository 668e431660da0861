//! The last few loaded scenes, by scene id, so each BVH is built once per scene per worker.
//! Scenes that failed to load are remembered too (loading is deterministic), so a broken scene
//! is not downloaded again for every lease of its job.
use crate::tracer::Scene;
use std::collections::VecDeque;
use std::sync::Arc;

pub(crate) const SCENES_KEPT: usize = 4;
const FAILURES_KEPT: usize = 16;

#[derive(Debug, Default)]
pub(crate) struct SceneCache {
    /// Least recently used first.
    scenes: VecDeque<(String, Arc<Scene>)>,
    failures: VecDeque<(String, String)>,
}

pub(crate) enum Cached {
    Scene(Arc<Scene>),
    Failed(String),
    Missing,
}

impl SceneCache {
    pub(crate) fn get(&mut self, id: &str) -> Cached {
        if let Some(i) = self.scenes.iter().position(|(k, _)| k == id) {
            let entry = self.scenes.remove(i).expect("index from position");
            let scene = entry.1.clone();
            self.scenes.push_back(entry);
            return Cached::Scene(scene);
        }
        match self.failures.iter().find(|(k, _)| k == id) {
            Some((_, e)) => Cached::Failed(e.clone()),
            None => Cached::Missing,
        }
    }

    pub(crate) fn insert(&mut self, id: &str, scene: Arc<Scene>) {
        self.scenes.retain(|(k, _)| k != id);
        self.scenes.push_back((id.to_owned(), scene));
        while self.scenes.len() > SCENES_KEPT {
            self.scenes.pop_front();
        }
    }

    pub(crate) fn insert_failure(&mut self, id: &str, error: String) {
        self.failures.retain(|(k, _)| k != id);
        self.failures.push_back((id.to_owned(), error));
        while self.failures.len() > FAILURES_KEPT {
            self.failures.pop_front();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scene() -> Arc<Scene> {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/furnace.gltf");
        Arc::new(crate::scene::load_path(std::path::Path::new(path)).unwrap())
    }

    #[test]
    fn keeps_the_most_recently_used_scenes() {
        let s = scene();
        let mut c = SceneCache::default();
        for id in ["a", "b", "c", "d"] {
            c.insert(id, s.clone());
        }
        assert!(matches!(c.get("a"), Cached::Scene(_))); // "a" is now the most recent
        c.insert("e", s.clone()); // evicts "b"
        assert!(matches!(c.get("b"), Cached::Missing));
        for id in ["a", "c", "d", "e"] {
            assert!(matches!(c.get(id), Cached::Scene(_)), "{id}");
        }
        c.insert_failure("x", "broken".into());
        assert!(matches!(c.get("x"), Cached::Failed(e) if e == "broken"));
    }
}
