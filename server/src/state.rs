//! Shared coordinator state: the scheduler behind a mutex, the scene store, finished images.
//! A job's status as clients see it is built in `crate::status`.
pub use crate::output::JobImage;
use crate::persist::Durability;
use crate::scenes::SceneStore;
use crate::scheduler::Scheduler;
use anyhow::Context;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tokio::sync::broadcast;

#[derive(Clone, Debug)]
pub struct Config {
    pub data_dir: PathBuf,
    pub lease_timeout_ms: u64,
    pub max_scene_bytes: usize,
    pub max_triangles: u64,
    /// Bearer token for clients (submit, read, cancel); None leaves client routes open.
    pub client_token: Option<String>,
    /// Bearer token for workers (register, lease, heartbeat, result, scene data).
    pub worker_token: Option<String>,
    /// Milliseconds between checkpoints of job state to `data_dir` (see `crate::persist`);
    /// None keeps jobs in memory only (an in-process farm that cannot outlive its process).
    pub checkpoint_ms: Option<u64>,
    /// Units of one job a worker may fail before it is kept off that job.
    pub max_failures: u32,
    /// Give workers units of the animation frame they rendered last (see `scheduler::frames`).
    pub frame_affinity: bool,
    /// Let workers of different renderer ids share a job (see `scheduler::renderers`).
    pub mix_renderers: bool,
    /// Delete ended jobs (record, checkpoints, images) this long after they ended; None keeps
    /// them until deleted by request.
    pub delete_ended_after_ms: Option<u64>,
    /// Return an animation frame's freed sums to the system as soon as its image is written,
    /// rather than when the job ends. False in a process that runs workers too
    /// ([`crate::local`]): mimalloc's purge is process-wide and would take the pages those
    /// workers keep for their next frame (`crate::purge`).
    pub purge_each_frame: bool,
}

impl Config {
    pub fn new(data_dir: PathBuf) -> Config {
        Config {
            data_dir,
            lease_timeout_ms: 10_000,
            max_scene_bytes: 256 << 20,
            max_triangles: 5_000_000,
            client_token: None,
            worker_token: None,
            checkpoint_ms: Some(1000),
            max_failures: Scheduler::DEFAULT_MAX_FAILURES,
            frame_affinity: true,
            mix_renderers: false,
            delete_ended_after_ms: None,
            purge_each_frame: true,
        }
    }
}

#[derive(Default)]
pub struct Counters {
    pub units_merged: AtomicU64,
    pub results_stale: AtomicU64,
    pub results_malformed: AtomicU64,
    pub leases_granted: AtomicU64,
    pub merge_nanos: AtomicU64,
}

pub struct Shared {
    pub config: Config,
    pub scheduler: Mutex<Scheduler>,
    pub scenes: SceneStore,
    /// Durable job state: the store and its checkpoints.
    pub durable: Durability,
    pub(crate) finalize_lock: Mutex<()>,
    /// Ids of jobs whose status changed (for SSE).
    pub events: broadcast::Sender<String>,
    pub counters: Counters,
    /// Woken when units may have become available (new job, released or expired lease), so
    /// long-polling lease requests answer at once.
    pub work_available: tokio::sync::Notify,
    start: Instant,
    next_job: AtomicU64,
}

#[derive(Clone)]
pub struct AppState(pub Arc<Shared>);

impl std::ops::Deref for AppState {
    type Target = Shared;
    fn deref(&self) -> &Shared {
        &self.0
    }
}

impl AppState {
    /// Opens the data directory; with checkpoints on, resumes every stored job.
    pub fn new(config: Config) -> anyhow::Result<AppState> {
        let jobs_dir = config.data_dir.join("jobs");
        std::fs::create_dir_all(&jobs_dir)
            .with_context(|| format!("creating {}", jobs_dir.display()))?;
        let scenes = SceneStore::open(config.data_dir.join("scenes"), config.max_triangles)?;
        let (durable, epoch) = Durability::open(&config.data_dir, config.checkpoint_ms)?;
        let mut scheduler =
            Scheduler::with_epoch(config.lease_timeout_ms, config.max_failures, epoch);
        scheduler.set_frame_affinity(config.frame_affinity);
        scheduler.set_mix_renderers(config.mix_renderers);
        let finished = durable.restore(&mut scheduler)?;
        let (events, _) = broadcast::channel(1024);
        let state = AppState(Arc::new(Shared {
            config,
            scheduler: Mutex::new(scheduler),
            scenes,
            durable,
            finalize_lock: Mutex::new(()),
            events,
            counters: Counters::default(),
            work_available: tokio::sync::Notify::new(),
            start: Instant::now(),
            next_job: AtomicU64::new(0),
        }));
        for (id, index) in state.remove_stale_frames() {
            state.write_frame(&id, index);
        }
        // A crash between a job's last checkpoint and its EXR leaves the image to write again.
        for id in &finished {
            state.finalize(id);
        }
        Ok(state)
    }
}

impl Shared {
    /// Writes every job changed since the last checkpoint; returns how many (see
    /// [`Durability::checkpoint`]).
    pub fn checkpoint(&self) -> anyhow::Result<usize> {
        self.durable.checkpoint(&self.scheduler, self.now())
    }

    /// Milliseconds on the coordinator's monotonic clock.
    pub fn now(&self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }

    pub fn new_job_id(&self) -> String {
        let n = self.next_job.fetch_add(1, Ordering::Relaxed) + 1;
        format!("j{:x}-{n}", unix_ms())
    }

    pub fn notify(&self, job_id: &str) {
        let _ = self.events.send(job_id.to_string());
    }

    /// Finalizes jobs that ended by their time limit inside any scheduler call, and tells watchers.
    pub async fn settle(self: &Arc<Self>) {
        let finished = self.scheduler.lock().expect("lock").take_finished();
        for id in finished {
            let me = self.clone();
            let id2 = id.clone();
            let _ = tokio::task::spawn_blocking(move || me.finalize(&id2)).await;
            self.notify(&id);
        }
    }

    /// Where a finished job's EXR of frame index `index` is kept: `DATA/jobs/<id>.exr` for a
    /// still, `DATA/jobs/<id>.f<frame>.exr` for frames of an animation.
    pub fn image_path(&self, job_id: &str, frame: Option<u32>) -> PathBuf {
        let name = match frame {
            None => format!("{job_id}.exr"),
            Some(n) => format!("{job_id}.f{n:06}.exr"),
        };
        self.config.data_dir.join("jobs").join(name)
    }

    /// The file of frame index `index` of a job, or None when the job is unknown.
    pub fn frame_image_path(&self, job_id: &str, index: usize) -> Option<PathBuf> {
        let sched = self.scheduler.lock().expect("lock");
        Some(self.frame_file(sched.job(job_id)?, index))
    }

    /// The file of frame index `index` of `job` (see [`Self::image_path`]).
    pub(crate) fn frame_file(&self, job: &crate::scheduler::JobRun, index: usize) -> PathBuf {
        self.image_path(&job.cfg().id, job.is_animation().then(|| job.frame_number(index)))
    }
}

pub use crate::status::job_status;

/// Milliseconds since the Unix epoch, by the wall clock.
pub fn unix_ms() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap_or_default()
        .as_millis() as u64
}
