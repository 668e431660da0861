//! Why a worker that asked for work was given none, for its log.
//!
//! "No work" is the common answer and needs no explanation. But a worker can also sit idle
//! beside jobs that still have units: they are pinned to another renderer (`renderers.rs`), or
//! this worker failed them often enough to be kept off them. Its operator would otherwise see
//! an idle machine on a busy farm and no cause; the lease answer carries the reason
//! (`x-tessera-idle-reason`) and the worker logs it when it changes.
use super::Scheduler;
use super::leases::Refusal;
use std::collections::BTreeSet;
use std::fmt;

/// Jobs named in the message, of each kind.
const SHOWN: usize = 5;

/// Jobs with units left that this worker may not take, and why.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct IdleReason {
    /// Jobs kept on other renderers, and those renderers.
    pub pinned: Vec<String>,
    pub renderers: BTreeSet<String>,
    /// Jobs whose blocklist keeps this worker off.
    pub blocklisted: Vec<String>,
}

impl Scheduler {
    /// Why `worker` gets no unit now, when jobs with units left refuse it; None when there is
    /// simply nothing to do (or the worker is unknown). `Scheduler::admission` is the rule, as
    /// in `lease`.
    pub fn idle_reason(&self, worker: &str, now: u64) -> Option<IdleReason> {
        let mine = &self.workers.get(worker)?.renderer;
        let gate = self.renderer_gate(mine, now);
        let mut why = IdleReason::default();
        for job in self.jobs.values().filter(|j| j.next_unit(None).is_some()) {
            match self.admission(job, worker, &gate) {
                Err(Refusal::Blocklisted) => why.blocklisted.push(job.cfg.id.clone()),
                Err(Refusal::OtherRenderer) => {
                    why.pinned.push(job.cfg.id.clone());
                    why.renderers.extend(gate.renderers_of(job).map(str::to_owned));
                }
                // A paused job refuses every worker alike: not this worker's reason.
                Err(Refusal::Paused) | Ok(_) => {}
            }
        }
        (!why.pinned.is_empty() || !why.blocklisted.is_empty()).then_some(why)
    }
}

impl fmt::Display for IdleReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // It travels in a header: a farm with hundreds of queued jobs names the first few.
        let list = |v: &[String]| match v.len() {
            n if n > SHOWN => format!("{} and {} more", v[..SHOWN].join(", "), n - SHOWN),
            _ => v.join(", "),
        };
        if !self.pinned.is_empty() {
            let renderers: Vec<String> = self
                .renderers
                .iter()
                .map(|r| if r.is_empty() { "(unnamed)".to_owned() } else { r.clone() })
                .collect();
            write!(
                f,
                "jobs {} are kept on renderer {} while a worker of it is live",
                list(&self.pinned),
                renderers.join(" / ")
            )?;
        }
        if !self.blocklisted.is_empty() {
            let sep = if self.pinned.is_empty() { "" } else { "; " };
            write!(
                f,
                "{sep}jobs {} keep this worker off after its failures",
                list(&self.blocklisted)
            )?;
        }
        Ok(())
    }
}
