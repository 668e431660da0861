//! The worker process: pulls units of work from a coordinator, renders them, returns the sums.
//!
//! ```text
//! register ──► lease ──► scene (cached) ──► render on the pool ──► upload (in the background)
//!    ▲          │  ▲                                │                 at most one in flight; its
//!    └── 404 ───┘  └──── prefetch: the next lease ◄─┘                 answer carries a lease
//!                        as the unit starts (the last upload's answer's, else asked for), its
//!                        unit queued on the pool behind it, held (heartbeated) until it ends
//!  204 (no work): poll again after a short backoff
//!  heartbeats every heartbeat_ms/3 (≤ 1 s) for each lease held, rendering or prefetched;
//!  409 drops it (a rendering unit is canceled)
//! ```
//!
//! # Layout
//! - this file: [`run`] and the loop: registration, the next lease, the unit in hand, its upload.
//! - `unit`: one unit's life: queued on the pool, rendered under heartbeats, how it ended.
//! - `lease`: heartbeats and giving a lease back, for every lease held.
//! - `api`: one function per endpoint, answers sorted into what the loop acts on.
//! - `prefetch`: the next lease, requested, its unit queued and kept alive in the background
//!   while a unit renders.
//! - `upload`: result uploads in the background, and the next lease their answers carry.
//! - `queue`: units on the render pool (a `RowQueue` worked by one job per pool thread).
//! - `retry`: backoff with jitter, the shutdown signal, retry-until-done.
//! - `cache`: parsed scene files by id and the last few frame scenes (with their BVHs).
//! - `prepare`: the scene of a lease's frame: cached, refitted from the last frame, or built.
//! - `convert`: proto ⇄ tracer types ([`to_wire`], [`render_settings`]).
//!
//! # Rules
//! - The tracer stays pure: rendering runs on a dedicated rayon pool of `threads` threads (each
//!   unit queued on it directly, its result sent back through a channel: `queue`); tokio and
//!   reqwest live here only.
//! - A coordinator that is down, restarting or failing (connection errors, 5xx) never stops the
//!   worker: calls retry with exponential backoff (100 ms → 5 s) for as long as it runs. Only a
//!   refusal that retrying cannot fix (e.g. 401 for a wrong token) ends [`run`] with an error.
//! - A lease that cannot be worked (scene missing or broken, bad parameters) is given back with
//!   `DELETE` and the worker carries on.
//! - Prefetch: as soon as a unit is leased, the next lease is taken in the background (the
//!   one the last result's answer carried, else by a lease request) and,
//!   once the unit in hand is queued, the next one is queued behind it, so the pool goes
//!   straight from one unit's last rows to the next one's first (no lease round trip, no
//!   hand-over in between). A worker holds at most two leases: the unit in hand and one
//!   prefetched. The prefetched lease is heartbeated while it waits; lost meanwhile (409,
//!   deadline) it is dropped, its unit canceled, and another asked for. Units start in the order
//!   they were leased and overlap only at their boundary.
//! - Uploads run in the background, at most one in flight: the next unit's result waits for the
//!   previous upload to end.
//! - Shutdown: no new leases; a prefetched lease is given back at once; the unit in hand gets
//!   [`SHUTDOWN_GRACE`] to finish (and is then uploaded) or is canceled and given back.
mod api;
mod cache;
mod convert;
mod lease;
mod prefetch;
mod prepare;
mod queue;
mod retry;
#[cfg(test)]
mod tests;
mod unit;
mod upload;

pub use convert::{render_settings, to_wire};

use anyhow::{Context, anyhow};
use api::{Api, LeaseAnswer};
use cache::SceneCache;
use lease::{heartbeat_every, keep_alive, release};
use prefetch::Prefetch;
use queue::Queued;
use retry::{Backoff, Retried, Stop, until_done};
use std::future::Future;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tessera_proto::{Lease, PROTOCOL_VERSION, Registration, WorkerHello};
use tessera_render::scene::Preparation;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;
use tracing::{debug, info, warn};
use unit::Unit;
use upload::{Uploaded, finish_upload, from_upload_answer, give_back_carried, upload};

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WorkerConfig {
    /// The coordinator's base URL, e.g. `http://127.0.0.1:7878` (plain HTTP).
    pub coordinator: String,
    /// Sent as `Authorization: Bearer <token>` on every request when set.
    pub token: Option<String>,
    /// Render threads; 0 means one per core.
    pub threads: usize,
    /// Shown by the coordinator (`GET /v1/workers`); the host name is a good choice.
    pub name: String,
}

/// What a worker did before [`run`] returned.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WorkerReport {
    /// Units rendered, uploaded and merged (204).
    pub units_done: u64,
    /// Units rendered but not merged: the coordinator answered 409 (late or duplicate), or the
    /// upload could not get through before the lease's deadline.
    pub units_stale: u64,
    /// Units dropped unfinished: lease lost while rendering (409 on heartbeat, or its deadline
    /// passed with the coordinator unreachable), or given back at shutdown; prefetched leases
    /// lost while waiting or given back at shutdown included.
    pub units_canceled: u64,
    /// Units that were already queued on the pool, behind the unit before them, when their
    /// turn came (the prefetch queued them): the pool went straight from one to the other.
    pub units_queued_ahead: u64,
    /// Results whose answer carried the worker's next lease (one request instead of two).
    pub leases_with_results: u64,
    /// Time the render pool spent rendering units (canceled ones included), as the mean over its
    /// threads of each one's time on units' rows: against the worker's wall time, what it spent
    /// waiting for leases, scenes and the coordinator.
    pub busy: Duration,
}

/// How long the unit in hand may still take once shutdown is requested.
pub const SHUTDOWN_GRACE: Duration = Duration::from_secs(2);
/// How long a lease request in flight at shutdown may still answer: not at all. It is dropped,
/// and a lease the coordinator granted to it meanwhile goes back to the queue when the worker
/// deregisters on its way out (`DELETE /v1/workers/{id}`), instead of waiting to expire.
const LEASE_DRAIN: Duration = Duration::ZERO;
/// Polling while the coordinator has no work (204), and after a unit that could not be worked.
const IDLE: Backoff = Backoff::new(Duration::from_millis(50), Duration::from_secs(1));

/// Runs a worker until `shutdown` resolves (then finishes up as described in the module docs).
///
/// Errors only for a bad configuration (an address that is not an `http://` URL, no threads) or
/// a refusal retrying cannot fix, such as 401 for a wrong token; an unreachable or restarting
/// coordinator is waited for.
pub async fn run(
    config: WorkerConfig,
    shutdown: impl Future<Output = ()> + Send,
) -> anyhow::Result<WorkerReport> {
    let worker = Arc::new(Worker::new(&config)?);
    let (stop_tx, stop) = Stop::new();
    let work = worker.main_loop(stop);
    tokio::pin!(work, shutdown);
    tokio::select! {
        r = &mut work => return r,
        () = &mut shutdown => {
            info!("shutdown requested: taking no new work");
            stop_tx.send_replace(true);
        }
    }
    work.await
}

/// What the loop carries from one unit to the next.
#[derive(Default)]
struct Carry {
    report: WorkerReport,
    /// The last unit's result upload (at most one in flight).
    uploading: Option<JoinHandle<Uploaded>>,
    /// The next lease, fetched while the unit in hand renders (at most one).
    prefetch: Option<Prefetch>,
    /// Where the last upload puts the lease its answer carries (for the next prefetch, or the
    /// loop's next lease when no prefetch is running).
    next_lease: Option<oneshot::Receiver<Box<Lease>>>,
    /// This worker's id with the coordinator, once registered: deregistered at the end.
    worker_id: Option<String>,
}

struct Worker {
    name: String,
    api: Arc<Api>,
    pool: Arc<rayon::ThreadPool>,
    scenes: Arc<Mutex<SceneCache>>,
    /// Nanoseconds the pool spent rendering units (canceled ones included; see `busy`).
    busy_ns: Arc<AtomicU64>,
    /// Told what each frame's scene is about to be (`memory::on_prepare`, the process's).
    prepare_hook: fn(Preparation),
}

impl Worker {
    fn new(config: &WorkerConfig) -> anyhow::Result<Worker> {
        let api = Api::new(&config.coordinator, config.token.clone())?;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(config.threads)
            .thread_name(|i| format!("tessera-render-{i}"))
            .build()
            .context("cannot start the render threads")?;
        Ok(Worker {
            name: config.name.clone(),
            api: Arc::new(api),
            pool: Arc::new(pool),
            scenes: Arc::new(Mutex::new(SceneCache::default())),
            busy_ns: Arc::new(AtomicU64::new(0)),
            prepare_hook: crate::memory::prepare_hook(),
        })
    }

    async fn main_loop(self: &Arc<Self>, stop: Stop) -> anyhow::Result<WorkerReport> {
        info!(coordinator = self.api.base(), threads = self.pool.current_num_threads(), name = %self.name, "worker starting");
        let mut carry = Carry::default();
        let result = self.serve(&stop, &mut carry).await;
        let Carry { mut report, uploading, prefetch, worker_id, next_lease } = carry;
        if let Some(answer) = next_lease {
            give_back_carried(&self.api, answer).await;
        }
        if let Some(p) = prefetch {
            self.give_back(p, &mut report).await;
        }
        if let Some(upload) = uploading {
            finish_upload(upload, &stop, &mut report).await;
        }
        if let Some(id) = worker_id {
            // Last, so that no upload still in flight loses its lease.
            match self.api.deregister(&id).await {
                Ok(()) => debug!(worker_id = %id, "deregistered"),
                Err(e) => {
                    warn!(worker_id = %id, "cannot deregister ({e}); the coordinator will see this worker's leases expire")
                }
            }
        }
        report.busy = Duration::from_nanos(self.busy_ns.load(Ordering::Relaxed));
        info!(
            units_done = report.units_done,
            units_stale = report.units_stale,
            units_canceled = report.units_canceled,
            units_queued_ahead = report.units_queued_ahead,
            busy_s = report.busy.as_secs_f64(),
            "worker stopped"
        );
        result.map(|()| report)
    }

    /// The loop proper; returns on shutdown or a fatal refusal.
    async fn serve(self: &Arc<Self>, stop: &Stop, carry: &mut Carry) -> anyhow::Result<()> {
        let Some(mut reg) = self.register(stop).await? else { return Ok(()) };
        carry.worker_id = Some(reg.worker_id.clone());
        let mut idle = IDLE;
        loop {
            let worker_id = reg.worker_id.as_str();
            let (answer, queued) = self.next_lease(worker_id, stop, carry).await;
            let lease = match answer {
                Retried::Done(LeaseAnswer::Lease(lease)) => lease,
                Retried::Done(LeaseAnswer::NoWork) => {
                    if !stop.sleep(idle.next_delay()).await {
                        return Ok(());
                    }
                    continue;
                }
                Retried::Done(LeaseAnswer::UnknownWorker) => {
                    info!(
                        worker_id,
                        "the coordinator does not know this worker (it restarted?): registering again"
                    );
                    match self.register(stop).await? {
                        Some(r) => {
                            carry.worker_id = Some(r.worker_id.clone());
                            reg = r;
                        }
                        None => return Ok(()),
                    }
                    continue;
                }
                Retried::Fatal(e) => {
                    return Err(anyhow!("the coordinator refused to lease work: {e}"));
                }
                Retried::Stopped(late) => {
                    if let Some(LeaseAnswer::Lease(lease)) = late {
                        self.release(&lease.lease_id).await;
                    }
                    return Ok(());
                }
            };
            // The next lease is fetched, and its unit queued on the pool, while this one renders;
            // its scene is prepared only once this unit's is (so one build serves both, and an
            // animation's next frame is refitted from this one).
            carry.report.units_queued_ahead += u64::from(queued.is_some());
            let (scene_ready, after) = tokio::sync::oneshot::channel();
            let from_upload = carry.next_lease.take();
            carry.prefetch = Some(Prefetch::start(
                self.clone(),
                worker_id.to_owned(),
                heartbeat_every(&reg),
                stop.clone(),
                after,
                from_upload,
            ));
            match self.run_unit(&lease, queued, scene_ready, heartbeat_every(&reg), stop).await {
                Unit::Rendered { sums, deadline, prepared } => {
                    idle.reset();
                    if let Some(previous) = carry.uploading.take() {
                        finish_upload(previous, stop, &mut carry.report).await;
                    }
                    // Encoded in the upload's task, so the pool starts the next unit meanwhile. Its
                    // answer brings the lease after the prefetched one.
                    let (api, lease_id, samples) =
                        (self.api.clone(), lease.lease_id.clone(), lease.samples);
                    let (next_tx, next_rx) = oneshot::channel();
                    carry.next_lease = Some(next_rx);
                    carry.uploading = Some(tokio::spawn(async move {
                        let body = bytes::Bytes::from(to_wire(&sums, samples).encode());
                        upload(api, lease_id, body, prepared, deadline, next_tx).await
                    }));
                }
                Unit::Canceled => {
                    carry.report.units_canceled += 1;
                    idle.reset();
                }
                Unit::Failed => {
                    // Back off: the coordinator may hand the same broken unit straight back.
                    if !stop.sleep(idle.next_delay()).await {
                        return Ok(());
                    }
                }
                Unit::Abandoned => {
                    carry.report.units_canceled += 1;
                    return Ok(());
                }
            }
        }
    }

    /// The prefetched lease (or the answer of the prefetch's request) with its unit when the
    /// prefetch queued it, else the lease the last upload's answer carried, else a lease
    /// request now.
    async fn next_lease(
        &self,
        worker_id: &str,
        stop: &Stop,
        carry: &mut Carry,
    ) -> (Retried<LeaseAnswer>, Option<Queued>) {
        if let Some(p) = carry.prefetch.take()
            && let Some(fetched) = p.take(&mut carry.report.units_canceled).await
        {
            return fetched;
        }
        if let Some(from_upload) = carry.next_lease.take() {
            match from_upload_answer(&self.api, from_upload, stop).await {
                Retried::Done(Some(lease)) => {
                    return (Retried::Done(LeaseAnswer::Lease(lease)), None);
                }
                Retried::Done(None) => {}
                _ => return (Retried::Stopped(None), None),
            }
        }
        (until_done("lease request", stop, LEASE_DRAIN, || self.api.lease(worker_id)).await, None)
    }

    /// Ends a prefetch when the loop has ended; a lease it still got is given back.
    async fn give_back(&self, prefetch: Prefetch, report: &mut WorkerReport) {
        if let Some((
            Retried::Done(LeaseAnswer::Lease(lease))
            | Retried::Stopped(Some(LeaseAnswer::Lease(lease))),
            _queued,
        )) = prefetch.take(&mut report.units_canceled).await
        {
            self.release(&lease.lease_id).await;
            report.units_canceled += 1;
        }
    }

    /// Registers, retrying until it works; None on shutdown. A coordinator that does not speak
    /// this worker's protocol version refuses it, saying which versions it speaks (one that
    /// predates versions refuses the unknown `protocol` field): that is fatal, not retried.
    async fn register(&self, stop: &Stop) -> anyhow::Result<Option<Registration>> {
        let threads = u32::try_from(self.pool.current_num_threads()).unwrap_or(u32::MAX);
        let hello = WorkerHello {
            protocol: PROTOCOL_VERSION,
            name: self.name.clone(),
            threads,
            renderer: tessera_render::renderer_id().to_owned(),
        };
        let answer =
            until_done("registration", stop, Duration::ZERO, || self.api.register(&hello)).await;
        match answer {
            Retried::Done(reg) => {
                info!(worker_id = %reg.worker_id, heartbeat_ms = reg.heartbeat_ms, coordinator = self.api.base(), renderer = %hello.renderer, "registered");
                Ok(Some(reg))
            }
            Retried::Fatal(e) => {
                Err(anyhow!("the coordinator refused to register this worker: {e}"))
            }
            Retried::Stopped(_) => Ok(None),
        }
    }

    /// Heartbeats the lease until it is lost (see [`keep_alive`]).
    async fn keep_alive(&self, id: &str, every: Duration, deadline: &Mutex<Instant>) -> String {
        keep_alive(&self.api, id, every, deadline).await
    }

    /// Gives a lease back (see [`release`]).
    async fn release(&self, id: &str) {
        release(&self.api, id).await;
    }
}
