//! A unit's scene: the frame its lease asks for, from the cache, refitted from the last frame
//! of the same animation, or built; the file is downloaded and parsed once per scene id.
//!
//! The time this took and how are sent with the result (`x-tessera-prepare-ms`,
//! `x-tessera-prepare`), so the coordinator can report BVH build and refit times per frame.
use super::Worker;
use super::api::CallError;
use super::cache::FrameKey;
use super::retry::RETRY;
use std::sync::Arc;
use std::time::{Duration, Instant};
use tessera_proto::Lease;
use tessera_render::scene::animation::{self, AnimationInfo};
use tessera_render::scene::{Preparation, Sequence};
use tessera_render::tracer::Scene;
use tracing::{debug, info, warn};

const SCENE_ATTEMPTS: u32 = 5;

/// How a unit's scene was made.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum How {
    /// Already in the cache.
    Cached,
    Build,
    Refit,
}

impl How {
    /// The value of the `x-tessera-prepare` header.
    pub(crate) fn name(self) -> &'static str {
        match self {
            How::Cached => "cached",
            How::Build => "build",
            How::Refit => "refit",
        }
    }
}

/// How a unit's scene was made and the milliseconds it took (parsing the file when this unit
/// did it, walking the animated node tree, building or refitting the BVH; not the download).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Prepared {
    pub how: How,
    pub ms: f64,
}

/// Seconds into the animation of `frame`; 0 for the static pose.
fn frame_time(animation: Option<usize>, frame: u32, fps: f64) -> Result<f64, String> {
    match animation {
        None => Ok(0.0),
        Some(_) if fps.is_finite() && fps > 0.0 => Ok(f64::from(frame) / fps),
        Some(_) => Err(format!("fps {fps} must be finite and > 0")),
    }
}

impl Worker {
    /// The scene of the lease's frame, and how it was prepared.
    pub(super) async fn frame_scene(
        &self,
        lease: &Lease,
    ) -> Result<(Arc<Scene>, Prepared), String> {
        let id = lease.scene_id.as_str();
        let (animations, mut parse_time) = self.animations_of(id).await?;
        let animation = animation::resolve(&animations, lease.params.animation.as_deref())
            .map_err(|e| format!("scene {id}: {e}"))?;
        let time_s = frame_time(animation, lease.frame, lease.params.fps)?;
        let key = FrameKey { scene_id: id.to_owned(), animation, time_bits: time_s.to_bits() };
        let failure_key = format!("{key:?}");
        let (cached, previous, failed) = {
            let mut cache = self.scenes.lock().expect("scene cache lock");
            let previous = animation.and_then(|_| {
                cache.frames.latest(|k| k.scene_id == id && k.animation == animation)
            });
            (cache.frames.get(&key), previous, cache.failures.get(&failure_key))
        };
        if let Some(scene) = cached {
            debug!(scene = id, frame = lease.frame, "frame scene cached");
            return Ok((scene, Prepared { how: How::Cached, ms: 0.0 }));
        }
        if let Some(e) = failed {
            return Err(e);
        }
        let (sequence, more_parse_time) = self.sequence(id).await?;
        parse_time += more_parse_time;
        // A still file makes one scene, which the frame cache keeps: its buffers (most of a
        // .glb) are dead weight from the moment it is walked, through the BVH build (a large
        // scene's memory peak) and after.
        let still = animations.is_empty();
        if still {
            self.scenes.lock().expect("scene cache lock").sequences.remove(&id.to_owned());
        }
        let (pool, cache, hook) = (self.pool.clone(), self.scenes.clone(), self.prepare_hook);
        let frame = lease.frame;
        // The cache is filled by the building thread itself, so a frame still lands in it when
        // the lease that wanted it is lost meanwhile.
        tokio::task::spawn_blocking(move || {
            hook(if previous.is_some() { Preparation::Refit } else { Preparation::Build });
            let started = Instant::now();
            let made = pool.install(|| match &previous {
                Some(p) => sequence.scene_after(p, animation, time_s),
                // This handle goes before the build: for a still file it was the last one.
                None => sequence.parsed_at(animation, time_s).map(|parsed| {
                    drop(sequence);
                    (parsed.build(), Preparation::Build)
                }),
            });
            let ms = (parse_time + started.elapsed()).as_secs_f64() * 1e3;
            let mut cache = cache.lock().expect("scene cache lock");
            match made {
                Ok((scene, preparation)) => {
                    let how = match preparation {
                        Preparation::Build => How::Build,
                        Preparation::Refit => How::Refit,
                    };
                    info!(scene = %key.scene_id, frame, time_s, how = how.name(), ms, triangles = scene.mesh.len(), "frame scene ready");
                    let scene = Arc::new(scene);
                    cache.frames.insert(key, scene.clone());
                    Ok((scene, Prepared { how, ms }))
                }
                Err(e) => {
                    let msg = format!("scene {} frame {frame} does not load: {e}", key.scene_id);
                    cache.failures.insert(failure_key, msg.clone());
                    Err(msg)
                }
            }
        })
        .await
        .map_err(|e| format!("the scene builder failed: {e}"))?
    }

    /// The animations of file `id`, from the cache, else from the file (downloaded and parsed
    /// if need be), with the time parsing took (zero when cached).
    async fn animations_of(&self, id: &str) -> Result<(Arc<[AnimationInfo]>, Duration), String> {
        if let Some(a) =
            self.scenes.lock().expect("scene cache lock").animations.get(&id.to_owned())
        {
            return Ok((a, Duration::ZERO));
        }
        let (sequence, parse_time) = self.sequence(id).await?;
        let animations: Arc<[AnimationInfo]> = sequence.animations().into();
        self.scenes
            .lock()
            .expect("scene cache lock")
            .animations
            .insert(id.to_owned(), animations.clone());
        Ok((animations, parse_time))
    }

    /// The parsed file `id` from the cache, or downloaded and parsed (on the render pool), with
    /// the time parsing took (zero when cached).
    async fn sequence(&self, id: &str) -> Result<(Arc<Sequence>, Duration), String> {
        let (cached, failed) = {
            let mut cache = self.scenes.lock().expect("scene cache lock");
            (cache.sequences.get(&id.to_owned()), cache.failures.get(&id.to_owned()))
        };
        if let Some(s) = cached {
            return Ok((s, Duration::ZERO));
        }
        if let Some(e) = failed {
            return Err(e);
        }
        let bytes = self.download(id).await?;
        let (pool, cache, id, hook) =
            (self.pool.clone(), self.scenes.clone(), id.to_owned(), self.prepare_hook);
        tokio::task::spawn_blocking(move || {
            hook(Preparation::Build); // a file parsed is followed by its first build
            let started = Instant::now();
            let size = bytes.len();
            let parsed = pool.install(|| Sequence::parse_owned(bytes, None, tessera_render::scene::DEFAULT_MAX_TRIANGLES));
            let mut cache = cache.lock().expect("scene cache lock");
            match parsed {
                Ok(seq) => {
                    let seq = Arc::new(seq);
                    cache.sequences.insert(id.clone(), seq.clone());
                    info!(scene = %id, bytes = size, animations = seq.animations().len(), ms = started.elapsed().as_millis() as u64, "scene parsed");
                    Ok((seq, started.elapsed()))
                }
                Err(e) => {
                    let msg = format!("scene {id} does not load: {e}");
                    cache.failures.insert(id, msg.clone());
                    Err(msg)
                }
            }
        })
        .await
        .map_err(|e| format!("the scene loader failed: {e}"))?
    }

    async fn download(&self, id: &str) -> Result<Vec<u8>, String> {
        let mut backoff = RETRY;
        let mut attempt = 0;
        loop {
            attempt += 1;
            match self.api.scene(id).await {
                Ok(bytes) => return Ok(bytes),
                Err(CallError::Transient(e)) if attempt < SCENE_ATTEMPTS => {
                    let delay = backoff.next_delay();
                    warn!(scene = id, attempt, retry_in_ms = delay.as_millis() as u64, "{e}");
                    tokio::time::sleep(delay).await;
                }
                Err(e) => return Err(format!("cannot download the scene ({e})")),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_times_need_a_positive_fps_only_when_animated() {
        assert_eq!(frame_time(Some(0), 12, 24.0), Ok(0.5));
        assert_eq!(frame_time(None, 12, 0.0), Ok(0.0));
        assert!(frame_time(Some(0), 1, 0.0).unwrap_err().contains("fps 0"));
        assert!(frame_time(Some(0), 1, f64::NAN).is_err());
    }
}
