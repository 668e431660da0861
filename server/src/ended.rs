//! What becomes of a job's pixels when its frames or the job end: each frame's EXR written once
//! (`finalize` for an ended job, `write_frame` for an animation's frame that completes while the
//! job goes on), then its sums dropped (invariant 16 in ARCHITECTURE.md); at start, files that a
//! crash left ahead of the checkpoints removed; jobs deleted on request or by age.
use crate::scenes::write_atomically;
use crate::state::{JobImage, Shared, unix_ms};
use std::path::PathBuf;

impl Shared {
    /// Removes the image of every frame of a running job that the restored checkpoints leave
    /// incomplete: it was written after merges that the crash lost, and is written again when
    /// the frame completes again (the same pixels). Returns the complete frames whose release
    /// the crash lost, to write and release again.
    pub(crate) fn remove_stale_frames(&self) -> Vec<(String, usize)> {
        let sched = self.scheduler.lock().expect("lock");
        let mut complete = Vec::new();
        for job in sched.jobs_newest_first().filter(|j| !j.state().is_final()) {
            for i in (0..job.frame_count()).filter(|&i| !job.frame_released(i)) {
                if job.frame_complete(i) {
                    complete.push((job.cfg().id.clone(), i));
                } else {
                    let _ = std::fs::remove_file(self.frame_file(job, i));
                }
            }
        }
        complete
    }

    /// Makes an ended job (done, canceled or failed) durable, writes each frame's EXR once (see
    /// [`Self::image_path`]), then drops the job's merged sums: every later request serves those
    /// files, so a job's EXR is the same bytes however often it is fetched (the `exr` crate writes
    /// attributes in hash order, so two encodings can differ), and a coordinator that has run
    /// many jobs holds none of their pixels. An image that cannot be written keeps the sums
    /// (encoded on request, and retried on the next request or start).
    pub fn finalize(&self, job_id: &str) {
        let _one_at_a_time = self.finalize_lock.lock().expect("lock");
        let missing: Vec<(usize, PathBuf)> = {
            let mut sched = self.scheduler.lock().expect("lock");
            sched.note_ended_at(job_id, unix_ms());
            let Some(job) = sched.job(job_id) else { return };
            if !job.state().is_final() || job.sums_released() {
                return;
            }
            // A frame released while the job ran has its file already (unless it was removed).
            let unreleased = (0..job.frame_count()).filter(|&i| !job.frame_released(i));
            unreleased
                .map(|i| (i, self.frame_file(job, i)))
                .filter(|(_, path)| !path.exists())
                .collect()
        };
        if !missing.is_empty()
            && let Err(e) = self.checkpoint()
        {
            tracing::error!(job = job_id, "checkpointing the ended job failed (retried): {e:#}");
        }
        for (index, path) in missing {
            let snapshot = {
                let sched = self.scheduler.lock().expect("lock");
                let Some(job) = sched.job(job_id) else { return };
                JobImage::of(job, index, self.now())
            };
            if let Err(e) = write_image(&snapshot, &path) {
                tracing::error!(
                    job = job_id,
                    "writing the final image failed (it is encoded on request instead): {e:#}"
                );
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
            if job.state().is_final() || job.frame_released(index) || !job.frame_complete(index) {
                return; // an ended job's frames are `finalize`'s
            }
            (JobImage::of(job, index, self.now()), self.frame_file(job, index))
        };
        match write_image(&snapshot, &path) {
            Ok(()) => {
                self.scheduler.lock().expect("lock").release_frame(job_id, index);
                if self.config.purge_each_frame {
                    crate::purge::return_freed_pages();
                }
                tracing::debug!(
                    job = job_id,
                    frame = index,
                    "frame complete: image written, sums released"
                );
            }
            Err(e) => tracing::error!(
                job = job_id,
                frame = index,
                "writing a complete frame's image failed (it is kept in memory and written when the job ends): {e:#}"
            ),
        }
    }

    /// Deletes the jobs that ended at least `Config::delete_ended_after_ms` before `now_unix_ms`
    /// (the ticker calls it with the wall clock); returns how many.
    pub fn delete_expired(&self, now_unix_ms: u64) -> usize {
        let Some(keep) = self.config.delete_ended_after_ms else { return 0 };
        let expired =
            self.scheduler.lock().expect("lock").ended_by(now_unix_ms.saturating_sub(keep));
        let mut deleted = 0;
        for id in expired {
            match self.purge(&id) {
                Ok(true) => {
                    deleted += 1;
                    tracing::info!(job = %id, "deleted: ended longer ago than --delete-ended-after");
                    self.notify(&id);
                }
                Ok(false) => {}
                Err(e) => {
                    tracing::error!(job = %id, "deleting an expired job failed (retried): {e:#}")
                }
            }
        }
        deleted
    }

    /// Deletes a job for good: it is canceled if it still runs, then its record, checkpoints
    /// and images go. False for an unknown job. The record goes first, so a crash midway leaves
    /// at worst files that no job names, never a job whose files are gone.
    pub fn purge(&self, job_id: &str) -> anyhow::Result<bool> {
        // Neither a finalize (which writes images) nor a checkpoint (which writes the record
        // back) may run in between.
        let _no_finalize = self.finalize_lock.lock().expect("lock");
        let images = self.durable.exclusive(|store| {
            let images: Vec<PathBuf> = {
                let sched = self.scheduler.lock().expect("lock");
                let Some(job) = sched.job(job_id) else { return Ok(None) };
                (0..job.frame_count()).map(|i| self.frame_file(job, i)).collect()
            };
            if let Some(store) = store {
                store.delete_job(job_id)?;
            }
            let mut sched = self.scheduler.lock().expect("lock");
            sched.cancel(job_id, self.now());
            sched.forget(job_id);
            Ok(Some(images))
        })?;
        let Some(images) = images else { return Ok(false) };
        for path in images {
            match std::fs::remove_file(&path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                    tracing::warn!(job = job_id, "removing {}: {e}", path.display())
                }
                _ => {}
            }
        }
        tracing::info!(job = job_id, "job deleted");
        Ok(true)
    }
}

/// Encodes a frame's EXR and writes it atomically (a reader sees the old file or the whole new one).
fn write_image(image: &JobImage, path: &std::path::Path) -> anyhow::Result<()> {
    let bytes = image.encode_exr()?;
    write_atomically(path, &bytes).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}
