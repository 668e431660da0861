//! What a worker keeps between units: parsed scene files ([`Sequence`]) by scene id (a still
//! file's only until its one scene is made; its animation list, empty, stays), and the last few
//! frame scenes (with their BVHs) by (scene id, animation, time), so each frame is built once
//! per worker and the next frame of an animation can refit the last one's BVH.
//! Scenes that failed to load are remembered too (loading is deterministic), so a broken scene
//! is not downloaded again for every lease of its job.
use std::collections::VecDeque;
use std::sync::Arc;
use tessera_render::scene::{AnimationInfo, Sequence};
use tessera_render::tracer::Scene;

/// Frame scenes kept (each holds its triangles and BVH: the memory that matters).
pub(crate) const FRAMES_KEPT: usize = 4;
/// Parsed files kept (decoded buffers and textures).
const SEQUENCES_KEPT: usize = 2;
const FAILURES_KEPT: usize = 16;
/// Files whose animation lists are kept (a few bytes each).
const ANIMATIONS_KEPT: usize = 64;

/// One frame of a scene: the animation played (None: the static pose) and the time in seconds
/// (as bits, 0 for the static pose).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct FrameKey {
    pub scene_id: String,
    pub animation: Option<usize>,
    pub time_bits: u64,
}

/// Least recently used first.
#[derive(Debug)]
pub(crate) struct Lru<K, V> {
    capacity: usize,
    entries: VecDeque<(K, V)>,
}

impl<K: PartialEq, V: Clone> Lru<K, V> {
    pub(crate) fn new(capacity: usize) -> Lru<K, V> {
        Lru { capacity, entries: VecDeque::new() }
    }

    /// The value for `key`, which becomes the most recently used.
    pub(crate) fn get(&mut self, key: &K) -> Option<V> {
        let i = self.entries.iter().position(|(k, _)| k == key)?;
        let entry = self.entries.remove(i).expect("index from position");
        let value = entry.1.clone();
        self.entries.push_back(entry);
        Some(value)
    }

    /// The most recently used value whose key `matches`, left in place.
    pub(crate) fn latest(&self, matches: impl Fn(&K) -> bool) -> Option<V> {
        self.entries.iter().rev().find(|(k, _)| matches(k)).map(|(_, v)| v.clone())
    }

    pub(crate) fn remove(&mut self, key: &K) {
        self.entries.retain(|(k, _)| k != key);
    }

    pub(crate) fn insert(&mut self, key: K, value: V) {
        self.entries.retain(|(k, _)| *k != key);
        self.entries.push_back((key, value));
        while self.entries.len() > self.capacity {
            self.entries.pop_front();
        }
    }
}

#[derive(Debug)]
pub(crate) struct SceneCache {
    pub sequences: Lru<String, Arc<Sequence>>,
    /// Each file's animations, kept after its [`Sequence`] is dropped (a still file's, once its
    /// one scene is made) so that a lease finds its frame without the file.
    pub animations: Lru<String, Arc<[AnimationInfo]>>,
    pub frames: Lru<FrameKey, Arc<Scene>>,
    /// Why a scene id (or a frame: its key, formatted) does not load.
    pub failures: Lru<String, String>,
}

impl Default for SceneCache {
    fn default() -> SceneCache {
        SceneCache {
            sequences: Lru::new(SEQUENCES_KEPT),
            animations: Lru::new(ANIMATIONS_KEPT),
            frames: Lru::new(FRAMES_KEPT),
            failures: Lru::new(FAILURES_KEPT),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keeps_the_most_recently_used_entries() {
        let mut c: Lru<&str, u32> = Lru::new(4);
        for (i, id) in ["a", "b", "c", "d"].into_iter().enumerate() {
            c.insert(id, i as u32);
        }
        assert_eq!(c.get(&"a"), Some(0)); // "a" is now the most recent
        c.insert("e", 4); // evicts "b"
        assert_eq!(c.get(&"b"), None);
        for id in ["a", "c", "d", "e"] {
            assert!(c.get(&id).is_some(), "{id}");
        }
        assert_eq!(c.latest(|k| *k < "e"), Some(3), "the most recent of a, c, d is d");
        c.insert("c", 9); // replaces, becomes the most recent
        assert_eq!(c.latest(|k| *k < "e"), Some(9));
        assert_eq!(c.entries.len(), 4);
    }
}
