//! Shared coordinator state: the scheduler behind a mutex, the scene store, finished images.
use crate::image;
use crate::output::{self, MetaValue};
use crate::scenes::{SceneStore, write_atomically};
use crate::scheduler::{JobRun, Scheduler};
use crate::store::Store;
use anyhow::Context;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tessera_proto::{Job, JobState, Progress, WorkerContribution, WorkerFailures};
use tessera_worker::tracer::PixelSums;
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
        // A crash between a job's last checkpoint and its EXR leaves the image to write again.
        for id in finished.iter().filter(|id| !state.image_path(id).exists()) {
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

    /// Where a finished job's EXR is kept.
    pub fn image_path(&self, job_id: &str) -> PathBuf {
        self.config.data_dir.join("jobs").join(format!("{job_id}.exr"))
    }

    /// Makes a finished job durable, then writes its EXR to `DATA/jobs/<id>.exr` once: every later
    /// request serves that file, so a job's EXR is the same bytes however often it is fetched
    /// (the `exr` crate writes attributes in hash order, so two encodings can differ).
    pub fn finalize(&self, job_id: &str) {
        let _one_at_a_time = self.finalize_lock.lock().expect("lock");
        if self.image_path(job_id).exists() {
            return;
        }
        if let Err(e) = self.checkpoint() {
            tracing::error!(job = job_id, "checkpointing the finished job failed (it stays in memory, retried): {e:#}");
        }
        let snapshot = {
            let sched = self.scheduler.lock().expect("lock");
            let Some(job) = sched.job(job_id) else { return };
            if job.state != JobState::Done {
                return;
            }
            JobImage::of(job, self.now())
        };
        let bytes = match snapshot.encode_exr() {
            Ok(b) => b,
            Err(e) => {
                tracing::error!(job = job_id, "encoding the final image failed: {e:#}");
                return;
            }
        };
        if let Err(e) = write_atomically(&self.image_path(job_id), &bytes) {
            tracing::error!(job = job_id, "writing the final image failed (it is encoded on request instead): {e}");
        }
        tracing::info!(job = job_id, "job done");
    }
}

/// A copy of a job's merged sums and metadata, taken under the scheduler lock so that encoding
/// (tens of milliseconds and up) happens outside it.
pub struct JobImage {
    pub width: u32,
    pub height: u32,
    pub frame: Vec<PixelSums>,
    meta: Vec<(String, MetaValue)>,
}

impl JobImage {
    pub fn of(job: &JobRun, now: u64) -> JobImage {
        let p = &job.cfg.params;
        JobImage { width: p.width, height: p.height, frame: job.frame(), meta: exr_meta(job, now) }
    }

    pub fn encode_exr(&self) -> anyhow::Result<Vec<u8>> {
        output::encode_exr(&image::layers(self.width, self.height, &self.frame), &self.meta)
    }

    pub fn encode_png(&self) -> Vec<u8> {
        let layers = image::layers(self.width, self.height, &self.frame);
        output::encode_png_preview(layers.width, layers.height, &layers.rgb)
    }
}

fn exr_meta(job: &JobRun, now: u64) -> Vec<(String, MetaValue)> {
    let p = &job.cfg.params;
    vec![
        ("software".to_string(), MetaValue::Text(format!("tessera {}", env!("CARGO_PKG_VERSION")))),
        ("tessera.job".into(), MetaValue::Text(job.cfg.id.clone())),
        ("tessera.scene".into(), MetaValue::Text(job.cfg.scene_id.clone())),
        ("tessera.spp".into(), MetaValue::Double(job.samples_done())),
        ("tessera.seed".into(), MetaValue::Text(p.seed.to_string())),
        ("tessera.estimator".into(), MetaValue::Text(p.estimator.clone())),
        ("tessera.sampler".into(), MetaValue::Text(p.sampler.clone())),
        ("tessera.effects".into(), MetaValue::Text(job.cfg.effects.join(","))),
        ("tessera.dropped_samples".into(), MetaValue::Text(job.dropped().to_string())),
        ("tessera.max_sample_weight".into(), MetaValue::Double(job.max_weight())),
        ("tessera.render_time_s".into(), MetaValue::Double(job.elapsed_ms(now) as f64 / 1000.0)),
        ("tessera.noise".into(), MetaValue::Double(job.noise().unwrap_or(0.0))),
    ]
}

/// The client's view of a job.
pub fn job_status(job: &JobRun, now: u64, workers: u32, max_failures: u32) -> Job {
    let elapsed_ms = job.elapsed_ms(now);
    let elapsed_s = elapsed_ms as f64 / 1000.0;
    let done = job.samples_done();
    let target = job.cfg.spp as f64;
    let noise = job.noise();
    let mut fraction = (done / target).min(1.0);
    if let (Some(t), Some(n)) = (job.cfg.noise_target, noise) {
        fraction = fraction.max((t / n).min(1.0));
    }
    if let Some(limit) = job.cfg.time_limit_ms {
        fraction = fraction.max((elapsed_ms as f64 / limit as f64).min(1.0));
    }
    if job.state == JobState::Done {
        fraction = 1.0;
    }
    let rate = if elapsed_s > 0.0 { done / elapsed_s } else { 0.0 };
    let eta_s = eta(job, done, rate, noise, elapsed_s);
    Job {
        id: job.cfg.id.clone(),
        state: job.state,
        scene: job.cfg.scene_id.clone(),
        request: job.cfg.request.clone(),
        progress: Progress { samples_done: done, samples_target: target, fraction },
        noise,
        elapsed_s,
        eta_s,
        samples_per_s: rate * job.pixel_count() as f64,
        workers,
        effects: job.cfg.effects.clone(),
        history: job.history.iter().map(|r| [r[0], r[1], if r[2].is_finite() { r[2] } else { 0.0 }]).collect(),
        dropped_samples: job.dropped(),
        max_sample_weight: job.max_weight(),
        message: job.message.clone(),
        created_unix_ms: job.cfg.created_unix_ms,
        worker_failures: job
            .failures
            .iter()
            .map(|(id, f)| WorkerFailures { worker_id: id.clone(), name: f.name.clone(), failures: f.count, blocked: f.count >= max_failures })
            .collect(),
        contributions: job.contributions.iter().map(|(id, (name, n))| WorkerContribution { worker_id: id.clone(), name: name.clone(), samples: *n }).collect(),
    }
}

/// Seconds left: to the spp target at the current rate, to the noise target assuming noise ∝ 1/spp,
/// and to the time limit — whichever comes first.
fn eta(job: &JobRun, done: f64, rate: f64, noise: Option<f64>, elapsed_s: f64) -> Option<f64> {
    if job.state.is_final() {
        return Some(0.0);
    }
    if rate <= 0.0 {
        return None;
    }
    let mut samples_needed = job.cfg.spp as f64;
    if let (Some(t), Some(n)) = (job.cfg.noise_target, noise) {
        samples_needed = samples_needed.min(done * n / t);
    }
    let mut eta = ((samples_needed - done) / rate).max(0.0);
    if let Some(limit) = job.cfg.time_limit_ms {
        eta = eta.min((limit as f64 / 1000.0 - elapsed_s).max(0.0));
    }
    Some(eta)
}
