//! Keeping a job on one renderer, so its image's bits do not depend on who rendered what.
//!
//! Workers name their renderer when they register (`tessera_render::renderer_id`: the source
//! hash of the build and a probe of its libm). Two workers of one renderer give the same bits
//! for a unit; two of different renderers may not, and an image merged from both would then
//! depend on which worker took which unit. So a job's units go to workers of the renderer it
//! already has — the renderers of its merged units and of the units leased now — and a worker
//! of another renderer is offered other jobs.
//!
//! A farm upgraded while a job runs would leave that job waiting forever for a renderer no
//! worker has any more. So the rule holds while the job's renderer has a *live* worker that may
//! take its units (seen within [`LIVE_WITHIN_MS`] or a lease timeout, whichever is longer, and
//! not kept off the job by the blocklist); once none is left, any
//! worker may go on with the job, the job's `renderers` lists both, and the coordinator logs a
//! warning. Mixing is then visible in the job's status and the EXR's `tessera.renderers`.
//!
//! `tessera serve --mix-renderers` turns the rule off, for farms that want every worker busy
//! more than bit-identical images: no worker is refused, and the lists still say who mixed.
use super::{JobRun, Scheduler};
use std::collections::{BTreeSet, HashMap};

/// Idle workers poll at least every ~2 s (a 1 s long poll, then at most 1 s of backoff), busy
/// ones heartbeat: a worker unheard of for longer than this (or a lease timeout) is gone.
pub const LIVE_WITHIN_MS: u64 = 5_000;

/// What a worker asking for a unit may take, as seen at one instant.
pub(super) struct RendererGate<'a> {
    mine: &'a str,
    /// Renderers of the units each job has leased now, by job seq.
    leased: HashMap<u64, BTreeSet<&'a str>>,
    /// Live workers: (id, renderer).
    live: Vec<(&'a str, &'a str)>,
    max_failures: u32,
    /// `--mix-renderers`: refuse nobody.
    mix: bool,
}

/// Whether a worker may take a unit of a job, and what that does to the job's renderers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Admission {
    /// The job has no renderer yet, has the worker's, or may mix (`--mix-renderers`).
    Same,
    /// The job's renderers have no live worker left: this worker adds its own.
    Mixes,
    Refused,
}

impl Scheduler {
    pub(super) fn renderer_gate<'a>(&'a self, mine: &'a str, now: u64) -> RendererGate<'a> {
        let window = LIVE_WITHIN_MS.max(self.lease_timeout_ms);
        let mut leased: HashMap<u64, BTreeSet<&str>> = HashMap::new();
        for l in self.leases.values() {
            if let Some(w) = self.workers.get(&l.worker) {
                leased.entry(l.job_seq).or_default().insert(&w.renderer);
            }
        }
        let live = self
            .workers
            .iter()
            .filter(|(_, w)| now.saturating_sub(w.last_seen) <= window)
            .map(|(id, w)| (id.as_str(), w.renderer.as_str()))
            .collect();
        RendererGate {
            mine,
            leased,
            live,
            max_failures: self.max_failures,
            mix: self.mix_renderers,
        }
    }
}

impl RendererGate<'_> {
    /// The renderers a job has: of its merged units and of the units leased now.
    pub(super) fn renderers_of<'j>(&'j self, job: &'j JobRun) -> impl Iterator<Item = &'j str> {
        let leased = self.leased.get(&job.seq);
        job.renderers.iter().map(String::as_str).chain(leased.into_iter().flatten().copied())
    }

    pub(super) fn admits(&self, job: &JobRun) -> Admission {
        if self.mix {
            return Admission::Same;
        }
        let has = self.renderers_of(job);
        let mut any = false;
        let mut live = false;
        for r in has {
            if r == self.mine {
                return Admission::Same;
            }
            any = true;
            // A worker the blocklist keeps off this job would never take its units.
            live |= self
                .live
                .iter()
                .any(|&(id, renderer)| renderer == r && !job.is_blocked(id, self.max_failures));
        }
        match (any, live) {
            (false, _) => Admission::Same,
            (true, true) => Admission::Refused,
            (true, false) => Admission::Mixes,
        }
    }
}
