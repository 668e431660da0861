//! A lease's life: issued to a worker, kept alive by heartbeats, completed with a result,
//! released, expired by `tick`, or revoked when its job no longer wants the unit.
use super::ProcessMemory;
use super::frames::{self, PrepareKind};
use super::job::{Contributor, JobRun};
use super::renderers::{Admission, RendererGate};
use super::{Accepted, ResultError, Scheduler};
use std::collections::HashMap;
use tessera_proto::{JobState, Lease, PartialSums};

/// What keeps a worker off a job that has units left.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Refusal {
    /// Paused: no worker gets its units.
    Paused,
    /// The job's blocklist: this worker failed it too often.
    Blocklisted,
    /// The job is kept on another renderer (`renderers.rs`).
    OtherRenderer,
}

#[derive(Clone, Debug)]
pub(super) struct LeaseRec {
    /// Issue order (the lease id's counter).
    pub(super) number: u64,
    pub(super) job_seq: u64,
    pub(super) tile: usize,
    pub(super) batch: u32,
    pub(super) worker: String,
    pub(super) deadline: u64,
}

impl Scheduler {
    /// Hands the worker its next unit, or None when there is nothing to do.
    /// Err when the worker is unknown (e.g. registered with a previous coordinator).
    pub fn lease(&mut self, worker: &str, now: u64) -> Result<Option<Lease>, String> {
        self.tick(now);
        let w = self.workers.get_mut(worker).ok_or_else(|| format!("unknown worker {worker:?}"))?;
        w.last_seen = now;
        w.lapsed = false;
        let last_frame = w.last_frame;
        let mine = w.renderer.clone();
        let gate = self.renderer_gate(&mine, now);
        let mut in_flight: HashMap<u64, usize> = HashMap::new();
        for l in self.leases.values() {
            *in_flight.entry(l.job_seq).or_default() += 1;
        }
        let pick = self
            .jobs
            .values()
            .filter_map(|j| {
                let unit = j.next_unit(self.affinity(j, last_frame).as_ref())?;
                self.admission(j, worker, &gate).ok().map(|admission| (j, unit, admission))
            })
            // Reverse, not negation: −i32::MIN overflows (a panic in debug builds, the lowest
            // priority first in release ones).
            .min_by_key(|(j, _, _)| {
                (
                    std::cmp::Reverse(j.cfg.priority),
                    in_flight.get(&j.seq).copied().unwrap_or(0),
                    j.seq,
                )
            })
            .map(|(j, (tile, batch), admission)| (j.seq, tile, batch, admission));
        drop(gate);
        let Some((seq, tile, batch, admission)) = pick else { return Ok(None) };
        let job = self.jobs.get_mut(&seq).expect("picked job exists");
        // Units leased to a worker that died unmerged mix nothing: only merged samples count.
        if admission == Admission::Mixes && !job.renderers.is_empty() {
            tracing::warn!(job = %job.cfg.id, worker, renderer = %mine, had = ?job.renderers, "no live worker of this job's renderer is left: it goes on with another, and its image mixes renderers");
        }
        job.mark_issued(tile, batch, now);
        let frame_index = job.frame_index_of(tile);
        self.next_lease += 1;
        let lease_id = format!("l{}-{}-{}", self.epoch, self.next_lease, seq);
        let deadline = now + self.lease_timeout_ms;
        let rec = LeaseRec {
            number: self.next_lease,
            job_seq: seq,
            tile,
            batch,
            worker: worker.to_string(),
            deadline,
        };
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

    /// Whether `worker` may take units of `job` (which has units left), or what keeps it off:
    /// the one rule both [`Scheduler::lease`] and [`Scheduler::idle_reason`] apply.
    pub(super) fn admission(
        &self,
        job: &JobRun,
        worker: &str,
        gate: &RendererGate,
    ) -> Result<Admission, Refusal> {
        if job.state == JobState::Paused {
            return Err(Refusal::Paused);
        }
        if job.is_blocked(worker, self.max_failures) {
            return Err(Refusal::Blocklisted);
        }
        match gate.admits(job) {
            Admission::Refused => Err(Refusal::OtherRenderer),
            admission => Ok(admission),
        }
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

    /// Records how the worker holding `lease_id` prepared its scene (reported with the result).
    pub fn note_prepare(&mut self, lease_id: &str, kind: PrepareKind, ms: f64) {
        if let Some(l) = self.leases.get(lease_id)
            && let Some(job) = self.jobs.get_mut(&l.job_seq)
        {
            job.note_prepare(l.tile, kind, ms);
        }
    }

    /// Records the resident memory the worker holding `lease_id` reported with its result: the
    /// worker's latest figures, and the peak for the unit's frame.
    pub fn note_memory(&mut self, lease_id: &str, memory: ProcessMemory) {
        let Some(l) = self.leases.get(lease_id) else { return };
        let memory =
            ProcessMemory { peak_rss_bytes: memory.peak_rss_bytes.max(memory.rss_bytes), ..memory };
        if let Some(w) = self.workers.get_mut(&l.worker) {
            w.memory = Some(memory);
        }
        if let Some(job) = self.jobs.get_mut(&l.job_seq) {
            job.note_peak_rss(l.tile, memory.peak_rss_bytes);
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

    pub fn complete(
        &mut self,
        lease_id: &str,
        sums: PartialSums,
        now: u64,
    ) -> Result<Accepted, ResultError> {
        self.tick(now);
        let l = self.leases.remove(lease_id).ok_or_else(|| {
            ResultError::Stale(format!(
                "lease {lease_id} is not active (expired, revoked or already completed)"
            ))
        })?;
        let job = self.jobs.get(&l.job_seq).expect("leases refer to live jobs");
        let want_rect = job.tiles[l.tile].rect;
        let want_samples = job.samples_of(l.batch);
        let problem = if sums.tile != want_rect {
            Some(format!(
                "result is for tile {:?} but lease {lease_id} is for {:?}",
                sums.tile, want_rect
            ))
        } else if sums.samples != want_samples {
            Some(format!(
                "result covers samples {:?} but lease {lease_id} is for {:?}",
                sums.samples, want_samples
            ))
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
            return Ok(Accepted {
                job_id,
                worker: l.worker,
                merged: false,
                job_finished: false,
                frame_completed: None,
            });
        }
        let (name, renderer) = self
            .workers
            .get(&l.worker)
            .map(|w| (w.name.clone(), w.renderer.clone()))
            .unwrap_or_default();
        let by = Contributor { id: l.worker.clone(), name, renderer };
        let merged_batches = job.accept(l.tile, l.batch, sums, by, now);
        let job_finished = job.state.is_final();
        let frame = job.frame_index_of(l.tile);
        let frame_completed =
            (merged_batches > 0 && !job_finished && job.frame_complete(frame)).then_some(frame);
        self.revoke_unwanted(l.job_seq);
        Ok(Accepted { job_id, worker: l.worker, merged: true, job_finished, frame_completed })
    }

    /// Expires overdue leases and ends jobs whose time limit ran out. Returns the ids of jobs
    /// that finished here.
    pub fn tick(&mut self, now: u64) -> Vec<String> {
        let expired: Vec<String> =
            self.leases.iter().filter(|(_, l)| l.deadline <= now).map(|(k, _)| k.clone()).collect();
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

    /// Counts a failed unit against its worker on that job (the blocklist).
    fn count_failure(&mut self, l: &LeaseRec) {
        let name = self.workers.get(&l.worker).map(|w| w.name.clone()).unwrap_or_default();
        if let Some(job) = self.jobs.get_mut(&l.job_seq)
            && job.count_failure(&l.worker, &name, self.max_failures)
        {
            tracing::warn!(job = %job.cfg.id, worker = %l.worker, %name, "worker failed {} units of this job: kept off it", self.max_failures);
        }
    }

    fn requeue(&mut self, l: &LeaseRec) {
        if let Some(job) = self.jobs.get_mut(&l.job_seq) {
            job.requeue(l.tile, l.batch);
        }
    }

    /// Drops leases whose unit the job no longer wants (finished job, tile past its noise stop).
    pub(super) fn revoke_unwanted(&mut self, seq: u64) {
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
        let current = oldest.and_then(|l| {
            self.jobs.get(&l.job_seq).map(|j| format!("{}/{}/{}", j.cfg.id, l.tile, l.batch))
        });
        if let Some(w) = self.workers.get_mut(worker) {
            w.current = current;
        }
    }
}
