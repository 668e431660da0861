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
//! - Jobs of higher priority go first; equal priorities share workers (fewest leases in flight
//!   first), then first come, first served.
mod durable;
mod frames;
mod job;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_durable;
#[cfg(test)]
mod tests_frames;
#[cfg(test)]
mod tests_numerics;
#[cfg(test)]
mod tests_pause;
mod tile;

pub use durable::{JobCheckpoint, JobRecord, RestoredTile, TileCheckpoint, TileMark};
pub use frames::{FramePrepare, PrepareKind};
pub use job::{Failures, JobConfig, JobRun, MIN_SPP_FOR_NOISE_STOP, Renderer};
pub use tile::TileRun;
use std::collections::{BTreeMap, HashMap};
use tessera_proto::{JobState, Lease, PartialSums};

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
}

#[derive(Clone, Debug)]
struct LeaseRec {
    /// Issue order (the lease id's counter).
    number: u64,
    job_seq: u64,
    tile: usize,
    batch: u32,
    worker: String,
    deadline: u64,
}

#[derive(Clone, Debug)]
pub struct WorkerRec {
    pub name: String,
    pub threads: u32,
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
            finished: Vec::new(),
        }
    }

    pub fn lease_timeout_ms(&self) -> u64 {
        self.lease_timeout_ms
    }

    pub fn register_worker(&mut self, name: &str, threads: u32, now: u64) -> String {
        self.next_worker += 1;
        let id = format!("w{}-{}", self.epoch, self.next_worker);
        let rec = WorkerRec { name: name.to_string(), threads, last_seen: now, units_done: 0, failures: 0, current: None, lapsed: false, last_frame: None };
        self.workers.insert(id.clone(), rec);
        id
    }

    /// A worker leaving: its leases go back to their queues at once (no waiting for them to
    /// expire, no failure counted) and it is forgotten. False for an unknown worker.
    pub fn deregister_worker(&mut self, id: &str) -> bool {
        if self.workers.remove(id).is_none() {
            return false;
        }
        let held: Vec<String> = self.leases.iter().filter(|(_, l)| l.worker == id).map(|(k, _)| k.clone()).collect();
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

    /// Jobs, newest first.
    pub fn jobs_newest_first(&self) -> impl Iterator<Item = &JobRun> {
        self.jobs.values().rev()
    }

    /// Distinct workers holding a lease on the job.
    pub fn workers_on(&self, id: &str) -> u32 {
        let Some(&seq) = self.by_id.get(id) else { return 0 };
        let mut w: Vec<&str> = self.leases.values().filter(|l| l.job_seq == seq).map(|l| l.worker.as_str()).collect();
        w.sort_unstable();
        w.dedup();
        w.len() as u32
    }

    /// Hands the worker its next unit, or None when there is nothing to do.
    /// Err when the worker is unknown (e.g. registered with a previous coordinator).
    pub fn lease(&mut self, worker: &str, now: u64) -> Result<Option<Lease>, String> {
        self.tick(now);
        let w = self.workers.get_mut(worker).ok_or_else(|| format!("unknown worker {worker:?}"))?;
        w.last_seen = now;
        w.lapsed = false;
        let last_frame = w.last_frame;
        let mut in_flight: HashMap<u64, usize> = HashMap::new();
        for l in self.leases.values() {
            *in_flight.entry(l.job_seq).or_default() += 1;
        }
        let pick = self
            .jobs
            .values()
            .filter(|j| j.state != JobState::Paused && !j.is_blocked(worker, self.max_failures))
            .filter_map(|j| j.next_unit(self.affinity(j, last_frame).as_ref()).map(|u| (j, u)))
            .min_by_key(|(j, _)| (-j.cfg.priority, in_flight.get(&j.seq).copied().unwrap_or(0), j.seq))
            .map(|(j, (tile, batch))| (j.seq, tile, batch));
        let Some((seq, tile, batch)) = pick else { return Ok(None) };
        let job = self.jobs.get_mut(&seq).expect("picked job exists");
        job.mark_issued(tile, batch, now);
        let frame_index = job.frame_index_of(tile);
        self.next_lease += 1;
        let lease_id = format!("l{}-{}-{}", self.epoch, self.next_lease, seq);
        let deadline = now + self.lease_timeout_ms;
        let rec = LeaseRec { number: self.next_lease, job_seq: seq, tile, batch, worker: worker.to_string(), deadline };
        self.leases.insert(lease_id.clone(), rec);
        if let Some(w) = self.workers.get_mut(worker) {
            w.last_frame = Some((seq, frame_index));
        }
        self.refresh_current(worker);
        let job = &self.jobs[&seq];
        Ok(Some(Lease {
            lease_id,
            job_id: job.cfg.id.clone(),
            scene_id: job.cfg.scene_id.clone(),
            params: job.cfg.params.clone(),
            frame: job.frame_number(frame_index),
            tile: job.tiles[tile].rect,
            samples: job.samples_of(batch),
            deadline_ms: self.lease_timeout_ms,
        }))
    }

    /// Where the worker's built scene is and where other workers are, for a job of several
    /// frames (None for stills, or with frame affinity off).
    fn affinity(&self, job: &JobRun, last_frame: Option<(u64, usize)>) -> Option<frames::Affinity> {
        if !self.frame_affinity || job.frame_count() < 2 {
            return None;
        }
        let mut busy = vec![0; job.frame_count()];
        for l in self.leases.values().filter(|l| l.job_seq == job.seq) {
            busy[job.frame_index_of(l.tile)] += 1;
        }
        let last = last_frame.filter(|(seq, _)| *seq == job.seq).map(|(_, f)| f);
        Some(frames::Affinity { last, busy })
    }

    /// Turns frame affinity on or off (on by default).
    pub fn set_frame_affinity(&mut self, on: bool) {
        self.frame_affinity = on;
    }

    /// Records how the worker holding `lease_id` prepared its scene (reported with the result).
    pub fn note_prepare(&mut self, lease_id: &str, kind: PrepareKind, ms: f64) {
        if let Some(l) = self.leases.get(lease_id)
            && let Some(job) = self.jobs.get_mut(&l.job_seq)
        {
            job.note_prepare(l.tile, kind, ms);
        }
    }

    /// Extends a live lease; None when it is gone (the worker should stop).
    pub fn heartbeat(&mut self, lease_id: &str, now: u64) -> Option<u64> {
        self.tick(now);
        let timeout = self.lease_timeout_ms;
        let l = self.leases.get_mut(lease_id)?;
        l.deadline = now + timeout;
        if let Some(w) = self.workers.get_mut(&l.worker) {
            w.last_seen = now;
            w.lapsed = false;
        }
        Some(timeout)
    }

    /// A worker gives a unit back unrendered.
    pub fn release(&mut self, lease_id: &str) -> bool {
        match self.leases.remove(lease_id) {
            Some(l) => {
                self.requeue(&l);
                self.refresh_current(&l.worker);
                true
            }
            None => false,
        }
    }

    pub fn complete(&mut self, lease_id: &str, sums: PartialSums, now: u64) -> Result<Accepted, ResultError> {
        self.tick(now);
        let l = self.leases.remove(lease_id).ok_or_else(|| ResultError::Stale(format!("lease {lease_id} is not active (expired, revoked or already completed)")))?;
        let job = self.jobs.get(&l.job_seq).expect("leases refer to live jobs");
        let want_rect = job.tiles[l.tile].rect;
        let want_samples = job.samples_of(l.batch);
        let problem = if sums.tile != want_rect {
            Some(format!("result is for tile {:?} but lease {lease_id} is for {:?}", sums.tile, want_rect))
        } else if sums.samples != want_samples {
            Some(format!("result covers samples {:?} but lease {lease_id} is for {:?}", sums.samples, want_samples))
        } else {
            None
        };
        self.refresh_current(&l.worker);
        if let Some(w) = self.workers.get_mut(&l.worker) {
            w.last_seen = now;
            w.lapsed = false;
            if problem.is_some() {
                w.failures += 1;
            } else {
                w.units_done += 1;
            }
        }
        let job = self.jobs.get_mut(&l.job_seq).expect("leases refer to live jobs");
        if let Some(p) = problem {
            job.requeue(l.tile, l.batch);
            self.count_failure(&l);
            return Err(ResultError::Malformed(p));
        }
        let job_id = job.cfg.id.clone();
        if !job.wants(l.tile, l.batch) {
            return Ok(Accepted { job_id, worker: l.worker, merged: false, job_finished: false });
        }
        let by = Renderer { name: self.workers.get(&l.worker).map(|w| w.name.clone()).unwrap_or_default(), id: l.worker.clone() };
        job.accept(l.tile, l.batch, sums, by, now);
        let job_finished = job.state.is_final();
        self.revoke_unwanted(l.job_seq);
        Ok(Accepted { job_id, worker: l.worker, merged: true, job_finished })
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
    pub fn set_paused(&mut self, id: &str, pause: bool, now: u64) -> Option<Result<JobState, JobState>> {
        let job = self.jobs.get_mut(self.by_id.get(id)?)?;
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

    /// Expires overdue leases and ends jobs whose time limit ran out. Returns the ids of jobs
    /// that finished here.
    pub fn tick(&mut self, now: u64) -> Vec<String> {
        let expired: Vec<String> = self.leases.iter().filter(|(_, l)| l.deadline <= now).map(|(k, _)| k.clone()).collect();
        for id in expired {
            let l = self.leases.remove(&id).expect("listed");
            self.refresh_current(&l.worker);
            self.requeue(&l);
            let Some(w) = self.workers.get_mut(&l.worker) else { continue };
            if !std::mem::replace(&mut w.lapsed, true) {
                w.failures += 1;
                self.count_failure(&l);
            }
        }
        let mut finished = Vec::new();
        for job in self.jobs.values_mut() {
            if !job.state.is_final() && job.out_of_time(now) {
                job.finish(JobState::Done, now, Some("time limit reached".into()));
                finished.push(job.cfg.id.clone());
            }
        }
        let seqs: Vec<u64> = finished.iter().map(|id| self.by_id[id]).collect();
        for s in seqs {
            self.revoke_unwanted(s);
        }
        self.finished.extend(finished.iter().cloned());
        finished
    }

    /// Jobs that ended by their time limit since the last call (whichever call noticed it).
    pub fn take_finished(&mut self) -> Vec<String> {
        std::mem::take(&mut self.finished)
    }

    /// Counts a failed unit against its worker on that job (the blocklist).
    fn count_failure(&mut self, l: &LeaseRec) {
        let name = self.workers.get(&l.worker).map(|w| w.name.clone()).unwrap_or_default();
        if let Some(job) = self.jobs.get_mut(&l.job_seq)
            && job.count_failure(&l.worker, &name, self.max_failures)
        {
            tracing::warn!(job = %job.cfg.id, worker = %l.worker, %name, "worker failed {} units of this job: kept off it", self.max_failures);
        }
    }

    pub fn max_failures(&self) -> u32 {
        self.max_failures
    }

    fn requeue(&mut self, l: &LeaseRec) {
        if let Some(job) = self.jobs.get_mut(&l.job_seq) {
            job.requeue(l.tile, l.batch);
        }
    }

    /// Drops leases whose unit the job no longer wants (finished job, tile past its noise stop).
    fn revoke_unwanted(&mut self, seq: u64) {
        let Some(job) = self.jobs.get(&seq) else { return };
        let mut holders = Vec::new();
        self.leases.retain(|_, l| {
            let keep = l.job_seq != seq || job.wants(l.tile, l.batch);
            if !keep {
                holders.push(l.worker.clone());
            }
            keep
        });
        for w in holders {
            self.refresh_current(&w);
        }
    }

    /// Sets a worker's `current` to its oldest lease's unit (None without leases).
    fn refresh_current(&mut self, worker: &str) {
        let oldest = self.leases.values().filter(|l| l.worker == worker).min_by_key(|l| l.number);
        let current = oldest.and_then(|l| self.jobs.get(&l.job_seq).map(|j| format!("{}/{}/{}", j.cfg.id, l.tile, l.batch)));
        if let Some(w) = self.workers.get_mut(worker) {
            w.current = current;
        }
    }
}
