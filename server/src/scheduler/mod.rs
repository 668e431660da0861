//! The coordinator's brain: a plain state machine over jobs, leases and workers.
//!
//! It owns no clock and does no I/O: every operation takes `now` (milliseconds on any monotonic
//! scale), so lease expiry, duplicates and late results are unit-tested without sleeping.
//!
//! Rules it keeps:
//! - A unit (job, tile, batch) is leased to one worker at a time; an expired, released or
//!   refused unit returns to its tile's queue with the same sample range.
//! - A result is accepted once: late (lease gone) and duplicate results are `Stale` and never
//!   counted twice.
//! - A worker that fails `max_failures` units of a job (leases expired, malformed results) gets
//!   no more units of that job. Leases of one worker that expire while it stays silent count as
//!   one failure (a worker may hold two: the unit it renders and the next, prefetched).
//! - A worker's `current` unit is its oldest lease (the one it renders; a newer one waits).
//! - Ids of leases and workers carry the coordinator's `epoch` (its boot count), so an id from
//!   before a restart never names something after it.
//! - A paused job is offered no units; the units it had leased finish and are merged.
//! - A job's units go to workers of one renderer (`renderers.rs`): of the renderer its merged
//!   and leased units have, while a live worker of it is not blocklisted from the job.
//! - Jobs of higher priority go first; equal priorities share workers (fewest leases in flight
//!   first), then first come, first served.
mod durable;
mod frames;
mod history;
mod idle;
mod job;
mod leases;
mod renderers;
#[cfg(test)]
mod tests;
mod tile;

pub use durable::{JobCheckpoint, JobRecord, ReleasedTile, RestoredTile, TileCheckpoint, TileMark};
pub use frames::{FramePrepare, PrepareKind};
pub use history::History;
pub use idle::IdleReason;
pub use job::{Contributor, Failures, JobConfig, JobRun, MIN_SPP_FOR_NOISE_STOP};
use leases::LeaseRec;
use std::collections::{BTreeMap, HashMap};
use tessera_proto::JobState;
/// A worker's resident memory, as it reports with a result (read by `tessera_worker::memory`).
pub use tessera_worker::memory::ProcessMemory;
pub use tile::TileRun;

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ResultError {
    /// The lease is unknown, expired, revoked or already completed: ignore the result.
    Stale(String),
    /// The result does not match its lease; the unit is queued again.
    Malformed(String),
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Accepted {
    pub job_id: String,
    /// The worker that held the lease.
    pub worker: String,
    /// False when the result was valid but no longer needed (its tile reached its noise target).
    pub merged: bool,
    pub job_finished: bool,
    /// The frame index this merge completed while the job goes on (an animation's frame whose
    /// tiles have all they will get): its image can be written and its sums dropped
    /// (`Scheduler::release_frame`).
    pub frame_completed: Option<usize>,
}

#[derive(Clone, Debug)]
pub struct WorkerRec {
    pub name: String,
    pub threads: u32,
    /// Its renderer id (`tessera_render::renderer_id`; empty from workers older than it).
    pub renderer: String,
    pub last_seen: u64,
    pub units_done: u64,
    pub failures: u64,
    /// Its oldest lease's unit, as "job/tile/batch".
    pub current: Option<String>,
    /// A lease of it expired and it has not been heard from since: further expiries are the
    /// same silence and count no further failure.
    pub lapsed: bool,
    /// The job (seq) and frame index of its last unit: its scene for that frame is built.
    pub last_frame: Option<(u64, usize)>,
    /// What it last reported holding in memory (None until a result says).
    pub memory: Option<ProcessMemory>,
}

pub struct Scheduler {
    jobs: BTreeMap<u64, JobRun>,
    by_id: HashMap<String, u64>,
    leases: HashMap<String, LeaseRec>,
    workers: BTreeMap<String, WorkerRec>,
    next_seq: u64,
    next_lease: u64,
    next_worker: u64,
    lease_timeout_ms: u64,
    max_failures: u32,
    epoch: u64,
    frame_affinity: bool,
    mix_renderers: bool,
    /// Jobs that ended inside `tick` (time limits), for the caller to finalize.
    finished: Vec<String>,
}

impl Scheduler {
    /// Failures of one worker on one job before it is kept off that job.
    pub const DEFAULT_MAX_FAILURES: u32 = 3;

    pub fn new(lease_timeout_ms: u64) -> Scheduler {
        Scheduler::with_epoch(lease_timeout_ms, Self::DEFAULT_MAX_FAILURES, 0)
    }

    pub fn with_epoch(lease_timeout_ms: u64, max_failures: u32, epoch: u64) -> Scheduler {
        Scheduler {
            jobs: BTreeMap::new(),
            by_id: HashMap::new(),
            leases: HashMap::new(),
            workers: BTreeMap::new(),
            next_seq: 0,
            next_lease: 0,
            next_worker: 0,
            lease_timeout_ms,
            max_failures: max_failures.max(1),
            epoch,
            frame_affinity: true,
            mix_renderers: false,
            finished: Vec::new(),
        }
    }

    pub fn lease_timeout_ms(&self) -> u64 {
        self.lease_timeout_ms
    }

    /// A worker of this process's renderer (tests).
    #[cfg(test)]
    pub fn register_worker(&mut self, name: &str, threads: u32, now: u64) -> String {
        self.register(name, threads, tessera_render::renderer_id(), now)
    }

    pub fn register(&mut self, name: &str, threads: u32, renderer: &str, now: u64) -> String {
        self.next_worker += 1;
        let id = format!("w{}-{}", self.epoch, self.next_worker);
        let rec = WorkerRec {
            name: name.to_string(),
            threads,
            renderer: renderer.to_string(),
            last_seen: now,
            units_done: 0,
            failures: 0,
            current: None,
            lapsed: false,
            last_frame: None,
            memory: None,
        };
        self.workers.insert(id.clone(), rec);
        id
    }

    /// A worker leaving: its leases go back to their queues at once (no waiting for them to
    /// expire, no failure counted) and it is forgotten. False for an unknown worker.
    pub fn deregister_worker(&mut self, id: &str) -> bool {
        if self.workers.remove(id).is_none() {
            return false;
        }
        let held: Vec<String> =
            self.leases.iter().filter(|(_, l)| l.worker == id).map(|(k, _)| k.clone()).collect();
        for lease in &held {
            self.release(lease);
        }
        true
    }

    pub fn workers(&self) -> impl Iterator<Item = (&String, &WorkerRec)> {
        self.workers.iter()
    }

    pub fn submit(&mut self, cfg: JobConfig) {
        self.next_seq += 1;
        self.by_id.insert(cfg.id.clone(), self.next_seq);
        self.jobs.insert(self.next_seq, JobRun::new(cfg, self.next_seq));
    }

    pub fn job(&self, id: &str) -> Option<&JobRun> {
        self.by_id.get(id).and_then(|s| self.jobs.get(s))
    }

    fn job_mut(&mut self, id: &str) -> Option<&mut JobRun> {
        self.by_id.get(id).and_then(|s| self.jobs.get_mut(s))
    }

    /// Jobs, newest first.
    pub fn jobs_newest_first(&self) -> impl Iterator<Item = &JobRun> {
        self.jobs.values().rev()
    }

    /// Distinct workers holding a lease on the job.
    pub fn workers_on(&self, id: &str) -> u32 {
        let Some(&seq) = self.by_id.get(id) else { return 0 };
        let mut w: Vec<&str> =
            self.leases.values().filter(|l| l.job_seq == seq).map(|l| l.worker.as_str()).collect();
        w.sort_unstable();
        w.dedup();
        w.len() as u32
    }

    /// Turns frame affinity on or off (on by default).
    pub fn set_frame_affinity(&mut self, on: bool) {
        self.frame_affinity = on;
    }

    /// Lets workers of any renderer share a job (off by default; see `renderers.rs`).
    pub fn set_mix_renderers(&mut self, on: bool) {
        self.mix_renderers = on;
    }

    /// Cancels a job; its leases are revoked (their heartbeats answer "gone").
    pub fn cancel(&mut self, id: &str, now: u64) -> Option<JobState> {
        let seq = *self.by_id.get(id)?;
        let job = self.jobs.get_mut(&seq)?;
        job.finish(JobState::Canceled, now, Some("canceled by request".into()));
        let state = job.state;
        self.revoke_unwanted(seq);
        Some(state)
    }

    /// Pauses (`pause`) or resumes a job; None for an unknown job, Err(state) for one that has
    /// ended. The job's state after it otherwise.
    pub fn set_paused(
        &mut self,
        id: &str,
        pause: bool,
        now: u64,
    ) -> Option<Result<JobState, JobState>> {
        let job = self.job_mut(id)?;
        let done = if pause { job.pause(now) } else { job.resume() };
        Some(done.map(|()| job.state))
    }

    /// Marks a job failed (e.g. its scene cannot be loaded).
    pub fn fail(&mut self, id: &str, now: u64, why: String) {
        if let Some(&seq) = self.by_id.get(id) {
            self.jobs.get_mut(&seq).expect("indexed").finish(JobState::Failed, now, Some(why));
            self.revoke_unwanted(seq);
        }
    }

    /// Drops an ended job's merged sums (its images are written; see `JobRun::release_sums`).
    /// False for an unknown job or one still running.
    pub fn release_sums(&mut self, id: &str) -> bool {
        self.job_mut(id).is_some_and(JobRun::release_sums)
    }

    /// Stamps the wall-clock time an ended job was seen ended (once; later calls keep the first).
    pub fn note_ended_at(&mut self, id: &str, unix_ms: u64) {
        let Some(job) = self.job_mut(id) else { return };
        if job.state.is_final() && job.ended_unix_ms.is_none() {
            job.ended_unix_ms = Some(unix_ms);
            job.revision += 1;
        }
    }

    /// Ended jobs stamped at or before `unix_ms`, oldest first (for `--delete-ended-after`).
    pub fn ended_by(&self, unix_ms: u64) -> Vec<String> {
        let mut old: Vec<(u64, &str)> = self
            .jobs
            .values()
            .filter_map(|j| {
                j.ended_unix_ms.filter(|&t| t <= unix_ms).map(|t| (t, j.cfg.id.as_str()))
            })
            .collect();
        old.sort();
        old.into_iter().map(|(_, id)| id.to_string()).collect()
    }

    /// Drops the sums of a complete frame of a running job once its image is written. False
    /// when the job is unknown or the frame not complete.
    pub fn release_frame(&mut self, id: &str, index: usize) -> bool {
        self.job_mut(id).is_some_and(|j| j.release_frame(index))
    }

    /// Jobs that ended by their time limit since the last call (whichever call noticed it).
    pub fn take_finished(&mut self) -> Vec<String> {
        std::mem::take(&mut self.finished)
    }

    pub fn max_failures(&self) -> u32 {
        self.max_failures
    }
}
