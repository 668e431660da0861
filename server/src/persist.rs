//! Checkpoints: the scheduler's merged sums and job records go to the store (`crate::store`),
//! and come back when the coordinator starts on the same data directory.
//!
//! When: every `Config::checkpoint_ms` (stretched to 10× the last checkpoint's duration, so
//! large frames cost at most ~10 % of a disk), and at once when a job is submitted (it is not
//! accepted until it is durable), canceled, or finished (before its EXR is written). What a crash
//! loses is at most the merges since the last checkpoint; their units are issued again, and
//! because tiles merge in batch order the final image is the same bits.
use crate::scheduler::Scheduler;
use crate::store::Store;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

/// The coordinator's durable state and how it is kept: the store (None when checkpoints are
/// off), one writer at a time, the last checkpoint's cost and failure. Only its methods touch
/// them.
pub struct Durability {
    store: Option<Store>,
    interval_ms: Option<u64>,
    /// One checkpoint or job deletion at a time: a checkpoint writes a job's record back.
    writing: Mutex<()>,
    /// How long the last checkpoint took, which stretches the next interval.
    cost: Mutex<Duration>,
    /// Why the last checkpoint failed (cleared by the next that succeeds); shown by /healthz.
    last_error: Mutex<Option<String>>,
    /// Checkpoints that failed since start (`/metrics`).
    failures: AtomicU64,
}

impl Durability {
    /// Opens the store under `data_dir` when checkpoints are on (every `interval_ms`), counts a
    /// boot, and returns it with the boot count lease and worker ids carry (0 without a store).
    pub fn open(data_dir: &Path, interval_ms: Option<u64>) -> anyhow::Result<(Durability, u64)> {
        let store = interval_ms.map(|_| Store::open(data_dir)).transpose()?;
        let epoch = store.as_ref().map(Store::next_boot).transpose()?.unwrap_or(0);
        let durability = Durability {
            store,
            interval_ms,
            writing: Mutex::new(()),
            cost: Mutex::new(Duration::ZERO),
            last_error: Mutex::new(None),
            failures: AtomicU64::new(0),
        };
        Ok((durability, epoch))
    }

    /// Rebuilds `sched` from the store (see [`restore`]); no jobs without a store.
    pub fn restore(&self, sched: &mut Scheduler) -> anyhow::Result<Vec<String>> {
        match &self.store {
            Some(store) => restore(store, sched, 0),
            None => Ok(Vec::new()),
        }
    }

    /// Writes every job changed since the last checkpoint; returns how many.
    pub fn checkpoint(&self, scheduler: &Mutex<Scheduler>, now: u64) -> anyhow::Result<usize> {
        let Some(store) = &self.store else { return Ok(0) };
        let _one_at_a_time = self.writing.lock().expect("lock");
        let t0 = Instant::now();
        let jobs = scheduler.lock().expect("lock").checkpoint(now);
        if jobs.is_empty() {
            return Ok(0);
        }
        let outcome = (|| {
            for j in &jobs {
                store.write_tiles(&j.record.cfg.id, &j.tiles)?;
            }
            store.commit(&jobs.iter().map(|j| &j.record).collect::<Vec<_>>())
        })();
        if let Err(e) = outcome {
            self.failures.fetch_add(1, Ordering::Relaxed);
            *self.last_error.lock().expect("lock") = Some(format!("{e:#}"));
            return Err(e);
        }
        *self.last_error.lock().expect("lock") = None;
        {
            let mut s = scheduler.lock().expect("lock");
            for j in &jobs {
                let tiles: Vec<(u32, u32)> = j.tiles.iter().map(|t| (t.tile, t.upto)).collect();
                s.mark_persisted(j.record.seq, j.revision, &tiles, &j.released_files);
            }
        }
        for j in &jobs {
            store.remove_superseded(&j.record.cfg.id, &j.tiles);
            store.remove_tile_files(&j.record.cfg.id, &j.released_files);
        }
        *self.cost.lock().expect("lock") = t0.elapsed();
        Ok(jobs.len())
    }

    /// The pause before the next periodic checkpoint.
    pub fn interval(&self) -> Option<Duration> {
        let base = Duration::from_millis(self.interval_ms?);
        Some(base.max(*self.cost.lock().expect("lock") * 10))
    }

    /// How many checkpoints have failed since start.
    pub fn failures(&self) -> u64 {
        self.failures.load(Ordering::Relaxed)
    }

    /// Why the last checkpoint failed, if it did.
    pub fn last_error(&self) -> Option<String> {
        self.last_error.lock().expect("lock").clone()
    }

    /// Runs `f` with the store (None when checkpoints are off) while no checkpoint runs, so
    /// nothing writes a job's record back while `f` deletes it.
    pub fn exclusive<T>(
        &self,
        f: impl FnOnce(Option<&Store>) -> anyhow::Result<T>,
    ) -> anyhow::Result<T> {
        let _no_checkpoint: MutexGuard<()> = self.writing.lock().expect("lock");
        f(self.store.as_ref())
    }
}

/// Rebuilds the scheduler from the store: every job with its durable tiles. Returns the ids of
/// finished jobs (their EXR may need writing again).
pub fn restore(store: &Store, sched: &mut Scheduler, now: u64) -> anyhow::Result<Vec<String>> {
    let mut finished = Vec::new();
    for rec in store.load_jobs()? {
        let id = rec.cfg.id.clone();
        store.remove_orphans(&id, &rec.tiles);
        let state = sched.restore(rec, now, |tile, mark, pixels| match store.read_tile(&id, tile, mark, pixels) {
            Ok(t) => Some(t),
            Err(e) => {
                tracing::warn!(job = %id, tile, "checkpoint unreadable, the tile is rendered again: {e}");
                None
            }
        });
        tracing::info!(job = %id, ?state, "job restored");
        if state.is_final() {
            finished.push(id);
        }
    }
    Ok(finished)
}
