//! Checkpoints: the scheduler's merged sums and job records go to the store (`crate::store`),
//! and come back when the coordinator starts on the same data directory.
//!
//! When: every `Config::checkpoint_ms` (stretched to 10× the last checkpoint's duration, so
//! large frames cost at most ~10 % of a disk), and at once when a job is submitted (it is not
//! accepted until it is durable), canceled, or finished (before its EXR is written). What a crash
//! loses is at most the merges since the last checkpoint; their units are issued again, and
//! because tiles merge in batch order the final image is the same bits.
use crate::scheduler::Scheduler;
use crate::state::Shared;
use crate::store::Store;
use std::time::{Duration, Instant};

impl Shared {
    /// Writes every job changed since the last checkpoint; returns how many.
    pub fn checkpoint(&self) -> anyhow::Result<usize> {
        let Some(store) = &self.store else { return Ok(0) };
        let _one_at_a_time = self.persist_lock.lock().expect("lock");
        let t0 = Instant::now();
        let jobs = self.scheduler.lock().expect("lock").checkpoint(self.now());
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
            self.counters.checkpoint_failures.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            *self.last_checkpoint_error.lock().expect("lock") = Some(format!("{e:#}"));
            return Err(e);
        }
        *self.last_checkpoint_error.lock().expect("lock") = None;
        {
            let mut s = self.scheduler.lock().expect("lock");
            for j in &jobs {
                let tiles: Vec<(u32, u32)> = j.tiles.iter().map(|t| (t.tile, t.upto)).collect();
                s.mark_persisted(j.record.seq, j.revision, &tiles, &j.released_files);
            }
        }
        for j in &jobs {
            store.remove_superseded(&j.record.cfg.id, &j.tiles);
            store.remove_tile_files(&j.record.cfg.id, &j.released_files);
        }
        *self.checkpoint_cost.lock().expect("lock") = t0.elapsed();
        Ok(jobs.len())
    }

    /// The pause before the next periodic checkpoint.
    pub fn checkpoint_interval(&self) -> Option<Duration> {
        let base = Duration::from_millis(self.config.checkpoint_ms?);
        Some(base.max(*self.checkpoint_cost.lock().expect("lock") * 10))
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
