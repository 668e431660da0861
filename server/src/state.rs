//! Shared coordinator state: the scheduler behind a mutex, the scene store, finished images.
//! A job's status as clients see it is built in `crate::status`.
pub use crate::output::JobImage;
use crate::scenes::{SceneStore, write_atomically};
use crate::scheduler::Scheduler;
use crate::store::Store;
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
    pub checkpoint_failures: AtomicU64,
}

pub struct Shared {
    pub config: Config,
    pub scheduler: Mutex<Scheduler>,
    pub scenes: SceneStore,
    /// Durable job state; None when `Config::checkpoint_ms` is None.
    pub store: Option<Store>,
    pub(crate) persist_lock: Mutex<()>,
    finalize_lock: Mutex<()>,
    pub(crate) checkpoint_cost: Mutex<std::time::Duration>,
    /// Why the last checkpoint failed (cleared by the next that succeeds); shown by /healthz.
    pub last_checkpoint_error: Mutex<Option<String>>,
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
        std::fs::create_dir_all(&jobs_dir).with_context(|| format!("creating {}", jobs_dir.display()))?;
        let scenes = SceneStore::open(config.data_dir.join("scenes"), config.max_triangles)?;
        let store = config.checkpoint_ms.map(|_| Store::open(&config.data_dir)).transpose()?;
        let epoch = store.as_ref().map(Store::next_boot).transpose()?.unwrap_or(0);
        let mut scheduler = Scheduler::with_epoch(config.lease_timeout_ms, config.max_failures, epoch);
        scheduler.set_frame_affinity(config.frame_affinity);
        scheduler.set_mix_renderers(config.mix_renderers);
        let finished = match &store {
            Some(store) => crate::persist::restore(store, &mut scheduler, 0)?,
            None => Vec::new(),
        };
        let (events, _) = broadcast::channel(1024);
        let state = AppState(Arc::new(Shared {
            config,
            scheduler: Mutex::new(scheduler),
            scenes,
            store,
            persist_lock: Mutex::new(()),
            finalize_lock: Mutex::new(()),
            checkpoint_cost: Mutex::new(std::time::Duration::ZERO),
            last_checkpoint_error: Mutex::new(None),
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
    /// Milliseconds on the coordinator's monotonic clock.
    pub fn now(&self) -> u64 {
        self.start.elapsed().as_millis() as u64
    }

    pub fn new_job_id(&self) -> String {
        let n = self.next_job.fetch_add(1, Ordering::Relaxed) + 1;
        let t = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default().as_millis();
        format!("j{t:x}-{n}")
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

    /// Removes the image of every frame of a running job that the restored checkpoints leave
    /// incomplete: it was written after merges that the crash lost, and is written again when
    /// the frame completes again (the same pixels). Returns the complete frames whose release
    /// the crash lost, to write and release again.
    fn remove_stale_frames(&self) -> Vec<(String, usize)> {
        let sched = self.scheduler.lock().expect("lock");
        let mut complete = Vec::new();
        for job in sched.jobs_newest_first().filter(|j| !j.state.is_final()) {
            for i in (0..job.frame_count()).filter(|&i| !job.frame_released(i)) {
                if job.frame_complete(i) {
                    complete.push((job.cfg.id.clone(), i));
                } else {
                    let _ = std::fs::remove_file(self.image_path(&job.cfg.id, job.is_animation().then(|| job.frame_number(i))));
                }
            }
        }
        complete
    }

    /// The file of frame index `index` of a job, or None when the job is unknown.
    pub fn frame_image_path(&self, job_id: &str, index: usize) -> Option<PathBuf> {
        let sched = self.scheduler.lock().expect("lock");
        let job = sched.job(job_id)?;
        Some(self.image_path(job_id, job.is_animation().then(|| job.frame_number(index))))
    }

    /// Makes an ended job (done, canceled or failed) durable, writes each frame's EXR once (see
    /// [`Self::image_path`]), then drops the job's merged sums: every later request serves those
    /// files, so a job's EXR is the same bytes however often it is fetched (the `exr` crate writes
    /// attributes in hash order, so two encodings can differ), and a coordinator that has run
    /// many jobs holds none of their pixels. An image that cannot be written keeps the sums
    /// (encoded on request, and retried on the next request or start).
    pub fn finalize(&self, job_id: &str) {
        let _one_at_a_time = self.finalize_lock.lock().expect("lock");
        let frames: Vec<(usize, Option<u32>)> = {
            let sched = self.scheduler.lock().expect("lock");
            let Some(job) = sched.job(job_id) else { return };
            if !job.state.is_final() || job.sums_released() {
                return;
            }
            (0..job.frame_count()).map(|i| (i, job.is_animation().then(|| job.frame_number(i)))).collect()
        };
        let missing: Vec<_> = {
            let sched = self.scheduler.lock().expect("lock");
            let Some(job) = sched.job(job_id) else { return };
            // A frame released while the job ran has its file already (unless it was removed).
            frames.into_iter().filter(|(i, n)| !job.frame_released(*i) && !self.image_path(job_id, *n).exists()).collect()
        };
        if !missing.is_empty()
            && let Err(e) = self.checkpoint()
        {
            tracing::error!(job = job_id, "checkpointing the ended job failed (retried): {e:#}");
        }
        for (index, number) in missing {
            let snapshot = {
                let sched = self.scheduler.lock().expect("lock");
                let Some(job) = sched.job(job_id) else { return };
                JobImage::of(job, index, self.now())
            };
            let bytes = match snapshot.encode_exr() {
                Ok(b) => b,
                Err(e) => {
                    tracing::error!(job = job_id, "encoding the final image failed: {e:#}");
                    return;
                }
            };
            if let Err(e) = write_atomically(&self.image_path(job_id, number), &bytes) {
                tracing::error!(job = job_id, "writing the final image failed (it is encoded on request instead): {e}");
                return;
            }
        }
        self.scheduler.lock().expect("lock").release_sums(job_id);
        crate::purge::return_freed_pages();
        tracing::info!(job = job_id, "job ended: images written, sums released");
    }

    /// Writes the EXR of a frame that completed while its job goes on (an animation's), then
    /// drops the frame's sums, so a job's memory follows the frames in flight rather than its
    /// length. The file is the frame's final image: later requests serve it.
    pub fn write_frame(&self, job_id: &str, index: usize) {
        let _one_at_a_time = self.finalize_lock.lock().expect("lock");
        let (snapshot, path) = {
            let sched = self.scheduler.lock().expect("lock");
            let Some(job) = sched.job(job_id) else { return };
            if job.state.is_final() || job.frame_released(index) || !job.frame_complete(index) {
                return; // an ended job's frames are `finalize`'s
            }
            (JobImage::of(job, index, self.now()), self.image_path(job_id, job.is_animation().then(|| job.frame_number(index))))
        };
        let written = snapshot.encode_exr().and_then(|bytes| write_atomically(&path, &bytes).map_err(anyhow::Error::from));
        match written {
            Ok(()) => {
                self.scheduler.lock().expect("lock").release_frame(job_id, index);
                crate::purge::return_freed_pages();
                tracing::debug!(job = job_id, frame = index, "frame complete: image written, sums released");
            }
            Err(e) => tracing::error!(job = job_id, frame = index, "writing a complete frame's image failed (it is kept in memory and written when the job ends): {e:#}"),
        }
    }

    /// Deletes a job for good: it is canceled if it still runs, then its record, checkpoints
    /// and images go. False for an unknown job. The record goes first, so a crash midway leaves
    /// at worst files that no job names, never a job whose files are gone.
    pub fn purge(&self, job_id: &str) -> anyhow::Result<bool> {
        // Neither a finalize (which writes images) nor a checkpoint (which writes the record
        // back) may run in between.
        let _no_finalize = self.finalize_lock.lock().expect("lock");
        let _no_checkpoint = self.persist_lock.lock().expect("lock");
        let images: Vec<PathBuf> = {
            let sched = self.scheduler.lock().expect("lock");
            let Some(job) = sched.job(job_id) else { return Ok(false) };
            (0..job.frame_count()).map(|i| self.image_path(job_id, job.is_animation().then(|| job.frame_number(i)))).collect()
        };
        if let Some(store) = &self.store {
            store.delete_job(job_id)?;
        }
        {
            let mut sched = self.scheduler.lock().expect("lock");
            sched.cancel(job_id, self.now());
            sched.forget(job_id);
        }
        for path in images {
            match std::fs::remove_file(&path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => tracing::warn!(job = job_id, "removing {}: {e}", path.display()),
                _ => {}
            }
        }
        tracing::info!(job = job_id, "job deleted");
        Ok(true)
    }
}

pub use crate::status::job_status;
