//! What a checkpoint holds and how the scheduler is rebuilt from one — still without I/O: the
//! caller (`crate::persist`) writes and reads the files and the store.
//!
//! A checkpoint of a tile is its merged sums after exactly batches 0..upto. Because tiles merge
//! in batch order and f64 sums are stored bit for bit, resuming from a checkpoint and merging
//! batches upto.. gives the same bits as never stopping. Buffered out-of-order batches and units
//! in flight are not saved: they are issued again.
use super::Scheduler;
use super::history::History;
use super::job::{JobConfig, JobRun};
use serde::{Deserialize, Serialize};
use tessera_proto::JobState;
use tessera_render::tracer::PixelSums;

/// A job as stored: its settings and how far each tile's durable sums go.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobRecord {
    pub cfg: JobConfig,
    pub seq: u64,
    pub state: JobState,
    pub elapsed_ms: u64,
    pub history: Vec<[f64; 3]>,
    pub message: Option<String>,
    pub tiles: Vec<TileMark>,
    /// Pixel-samples merged per worker id (with its name), as of the checkpointed merges.
    #[serde(default)]
    pub contributions: std::collections::BTreeMap<String, (String, u64)>,
    /// The job's renderers (`JobRun::renderers`), so a restarted coordinator keeps it on them.
    #[serde(default)]
    pub renderers: Vec<String>,
    /// When the job ended, by the wall clock (`JobRun::ended_unix_ms`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ended_unix_ms: Option<u64>,
}

/// How many batches a tile's checkpoint file holds (0: no file), and its noise stop. A released
/// tile (its job ended and its image is written) has no file: `released` keeps what the job's
/// status reports of it, and `upto` how many batches it merged.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TileMark {
    pub upto: u32,
    pub stop_at: Option<u32>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub released: Option<ReleasedTile>,
}

impl TileMark {
    /// The batch count of the tile's checkpoint file, if it has one.
    pub fn file_upto(&self) -> Option<u32> {
        (self.upto > 0 && self.released.is_none()).then_some(self.upto)
    }
}

/// A released tile's figures, kept in its job's record instead of its sums.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ReleasedTile {
    pub noise: Option<f64>,
    pub dropped: u64,
    pub max_weight: f64,
}

/// A tile whose merged sums moved past its last checkpoint.
pub struct TileCheckpoint {
    pub tile: u32,
    pub upto: u32,
    /// The batch count of the file this one supersedes (0: none), to delete once committed.
    pub previous_upto: u32,
    pub sums: Vec<PixelSums>,
    pub dropped: u64,
    pub max_weight: f64,
}

pub struct JobCheckpoint {
    pub record: JobRecord,
    pub revision: u64,
    pub tiles: Vec<TileCheckpoint>,
    /// (tile, batches) of the files of tiles released since they were written: once the record
    /// saying so is committed, the image on disk replaces them and they are deleted.
    pub released_files: Vec<(u32, u32)>,
}

/// A tile's sums read back from its checkpoint file.
pub struct RestoredTile {
    pub sums: Vec<PixelSums>,
    pub dropped: u64,
    pub max_weight: f64,
}

impl JobRun {
    fn record(&self, now: u64) -> JobRecord {
        JobRecord {
            cfg: self.cfg.clone(),
            seq: self.seq,
            state: self.state,
            elapsed_ms: self.elapsed_ms(now),
            history: self.history.rows.clone(),
            message: self.message.clone(),
            tiles: self
                .tiles
                .iter()
                .map(|t| TileMark {
                    upto: t.merged_upto,
                    stop_at: t.stop_at,
                    released: t.summary(),
                })
                .collect(),
            contributions: self.contributions.clone(),
            renderers: self.renderers.clone(),
            ended_unix_ms: self.ended_unix_ms,
        }
    }

    fn checkpoint(&self, now: u64) -> JobCheckpoint {
        let tiles = self
            .tiles
            .iter()
            .enumerate()
            .filter(|(_, t)| !t.released && t.merged_upto != t.persisted_upto)
            .map(|(i, t)| TileCheckpoint {
                tile: i as u32,
                upto: t.merged_upto,
                previous_upto: t.persisted_upto,
                sums: t.merged.clone(),
                dropped: t.dropped,
                max_weight: t.max_weight,
            })
            .collect();
        let released_files = self
            .tiles
            .iter()
            .enumerate()
            .filter(|(_, t)| t.released && t.persisted_upto > 0)
            .map(|(i, t)| (i as u32, t.persisted_upto))
            .collect();
        JobCheckpoint { record: self.record(now), revision: self.revision, tiles, released_files }
    }
}

impl Scheduler {
    /// Every job changed since its last checkpoint, with the tiles whose sums moved on.
    pub fn checkpoint(&self, now: u64) -> Vec<JobCheckpoint> {
        self.jobs
            .values()
            .filter(|j| j.revision != j.persisted_revision)
            .map(|j| j.checkpoint(now))
            .collect()
    }

    /// The record of one job (e.g. to store a new job before accepting it).
    pub fn record_of(&self, id: &str, now: u64) -> Option<JobRecord> {
        self.job(id).map(|j| j.record(now))
    }

    /// Notes that a checkpoint is on disk, and that the files of the released tiles it names
    /// are gone.
    pub fn mark_persisted(
        &mut self,
        seq: u64,
        revision: u64,
        tiles: &[(u32, u32)],
        released_files: &[(u32, u32)],
    ) {
        let Some(job) = self.jobs.get_mut(&seq) else { return };
        job.persisted_revision = job.persisted_revision.max(revision);
        for &(tile, upto) in tiles {
            let t = &mut job.tiles[tile as usize];
            t.persisted_upto = t.persisted_upto.max(upto);
        }
        for &(tile, _) in released_files {
            job.tiles[tile as usize].persisted_upto = 0;
        }
    }

    /// Puts a stored job back. `read(tile, mark, pixels)` gives a tile's checkpoint, or None
    /// where it is unusable: that tile starts over (deterministically, so the image is unchanged).
    pub fn restore(
        &mut self,
        rec: JobRecord,
        now: u64,
        mut read: impl FnMut(u32, TileMark, usize) -> Option<RestoredTile>,
    ) -> JobState {
        let mut job = JobRun::new(rec.cfg, rec.seq);
        let (batch_spp, spp) = (job.cfg.batch_spp, job.cfg.spp);
        for (i, (t, mark)) in job.tiles.iter_mut().zip(&rec.tiles).enumerate() {
            let samples = (mark.upto * batch_spp).min(spp) as u64;
            if let Some(summary) = &mark.released {
                t.restore_released(mark.upto, mark.stop_at, summary, samples);
                continue;
            }
            if mark.upto == 0 {
                continue;
            }
            if let Some(r) = read(i as u32, *mark, t.rect.pixel_count()) {
                t.restore(mark.upto, mark.stop_at, r.sums, r.dropped, r.max_weight, samples);
            }
        }
        job.state = rec.state;
        job.history = History::from_rows(rec.history);
        job.message = rec.message;
        job.elapsed_before_ms = rec.elapsed_ms;
        job.contributions = rec.contributions;
        job.renderers = rec.renderers;
        job.ended_unix_ms = rec.ended_unix_ms;
        match job.state {
            JobState::Queued | JobState::Paused => {}
            JobState::Running => job.started_ms = Some(now),
            _ => (job.started_ms, job.finished_ms) = (Some(now), Some(now)),
        }
        let open_frame = job.advance_open_frame();
        if job.state == JobState::Done && open_frame < job.frame_count() {
            // A checkpoint file went missing: render those tiles again rather than lie.
            job.state = JobState::Running;
            (job.started_ms, job.finished_ms) = (Some(now), None);
            job.message = Some(
                "resumed: some checkpointed tiles were unreadable and are rendered again".into(),
            );
        }
        job.persisted_revision = job.revision;
        self.next_seq = self.next_seq.max(rec.seq);
        self.by_id.insert(job.cfg.id.clone(), rec.seq);
        let state = job.state;
        self.jobs.insert(rec.seq, job);
        state
    }

    /// Drops a job and its leases: one that was never accepted (its record could not be
    /// stored), or one deleted (`Shared::purge`).
    pub fn forget(&mut self, id: &str) {
        if let Some(seq) = self.by_id.remove(id) {
            self.jobs.remove(&seq);
            self.leases.retain(|_, l| l.job_seq != seq);
        }
    }
}
