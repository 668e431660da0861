//! One job inside the scheduler: its tiles, their batches, and the in-order merge.
//!
//! Unit boundaries are fixed when the job is accepted: batch `b` of a tile covers sample indices
//! [b·B, min((b+1)·B, spp)). Each tile merges its batches strictly in batch order, buffering
//! early arrivals, so its f64 sums — and the image — do not depend on who rendered what, when.
//! A noise target is decided on that same order (after merging batch k, is the tile's relMSE at
//! or below the target?), so it is deterministic too.
use super::frames::FramePrepare;
use super::history::History;
use super::tile::{NoiseStop, TileRun};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, HashMap};
use tessera_proto::{JobRequest, JobState, PartialSums, RenderParams, TileRect};
#[cfg(test)]
use tessera_render::tracer::PixelSums;

/// Fewest samples per pixel merged before a tile may stop on its noise estimate: with fewer, the
/// variance estimate itself is too noisy to trust.
pub const MIN_SPP_FOR_NOISE_STOP: u32 = 16;

/// A validated job, as accepted. Serialized into the coordinator's store (`crate::store`), so
/// a restarted coordinator resumes with exactly the unit boundaries it promised.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct JobConfig {
    pub id: String,
    pub scene_id: String,
    pub params: RenderParams,
    /// Samples per pixel at most (the spp given, or the cap for noise/time-limited jobs).
    pub spp: u32,
    pub spp_given: bool,
    pub noise_target: Option<f64>,
    pub time_limit_ms: Option<u64>,
    pub tile_size: u32,
    pub batch_spp: u32,
    pub priority: i32,
    pub effects: Vec<String>,
    pub request: JobRequest,
    pub created_unix_ms: u64,
    /// Animation frames in render order (a still: `[0]`); unit tiles are numbered frame-major.
    #[serde(default = "still")]
    pub frames: Vec<u32>,
}

fn still() -> Vec<u32> {
    vec![0]
}

/// Units of one job a worker failed (lease expired, malformed result).
#[derive(Clone, Debug, Default)]
pub struct Failures {
    pub name: String,
    pub count: u32,
}

/// Who rendered a unit: the worker's id, name and renderer id, kept with the job so its status
/// can say who contributed (and with which renderer) even after the worker is gone.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Contributor {
    pub id: String,
    pub name: String,
    pub renderer: String,
}

pub struct JobRun {
    pub(super) cfg: JobConfig,
    pub(super) seq: u64,
    pub(super) state: JobState,
    /// Every frame's tiles, frame-major: tile `i` is tile `i % tiles_per_frame` of frame index
    /// `i / tiles_per_frame`, so a unit (job, frame, tile, batch) is (job, i, batch).
    pub(super) tiles: Vec<TileRun>,
    pub(super) tiles_per_frame: usize,
    /// Scene preparation reported by workers, per frame index (kept in memory only).
    pub(super) prepare: Vec<FramePrepare>,
    /// Render time spent before this coordinator started (restored from a checkpoint).
    pub(super) elapsed_before_ms: u64,
    pub(super) started_ms: Option<u64>,
    pub(super) finished_ms: Option<u64>,
    pub(super) history: History,
    pub(super) message: Option<String>,
    /// Failures by worker id; a worker with too many is kept off the job.
    pub(super) failures: BTreeMap<String, Failures>,
    /// Bumped on every change a checkpoint must record; `persisted_revision` is the one on disk.
    pub(super) revision: u64,
    pub(super) persisted_revision: u64,
    /// Pixel-samples merged per worker id (with its name).
    pub(super) contributions: BTreeMap<String, (String, u64)>,
    /// Renderer ids of the workers whose samples are merged, in order of their first merge:
    /// one, unless the job outlived every live worker of its renderer (`renderers.rs`).
    pub(super) renderers: Vec<String>,
    /// Wall-clock time (ms since the Unix epoch) the coordinator saw the job ended, for
    /// `--delete-ended-after`; stamped by `Shared::finalize`.
    pub(super) ended_unix_ms: Option<u64>,
    /// Who rendered each buffered (tile, batch), credited when it merges in order.
    pending_by: HashMap<(usize, u32), Contributor>,
    /// Frames before this index are complete (every tile has all it will get): the lease path
    /// starts looking here, and the job is done when it reaches the frame count.
    pub(super) open_frame: usize,
}

impl JobRun {
    pub fn new(cfg: JobConfig, seq: u64) -> JobRun {
        let (w, h, t) = (cfg.params.width, cfg.params.height, cfg.tile_size);
        let batches = cfg.spp.div_ceil(cfg.batch_spp);
        let mut rects = Vec::new();
        for y0 in (0..h).step_by(t as usize) {
            for x0 in (0..w).step_by(t as usize) {
                rects.push(TileRect { x0, y0, w: t.min(w - x0), h: t.min(h - y0) });
            }
        }
        let frames = cfg.frames.len().max(1);
        let tiles =
            (0..frames).flat_map(|_| rects.iter().map(|&r| TileRun::new(r, batches))).collect();
        JobRun {
            cfg,
            seq,
            state: JobState::Queued,
            tiles,
            tiles_per_frame: rects.len(),
            prepare: vec![FramePrepare::default(); frames],
            elapsed_before_ms: 0,
            started_ms: None,
            finished_ms: None,
            history: History::default(),
            message: None,
            failures: BTreeMap::new(),
            revision: 1,
            persisted_revision: 0,
            contributions: BTreeMap::new(),
            renderers: Vec::new(),
            ended_unix_ms: None,
            pending_by: HashMap::new(),
            open_frame: 0,
        }
    }

    /// The job's configuration, as accepted.
    pub fn cfg(&self) -> &JobConfig {
        &self.cfg
    }

    /// The job's state (queued, running, paused, or how it ended).
    pub fn state(&self) -> JobState {
        self.state
    }

    /// Every frame's tiles, frame-major (see `frame_tiles`).
    pub fn tiles(&self) -> &[TileRun] {
        &self.tiles
    }

    /// The job's noise against time: rows of (render seconds, mean spp, relMSE).
    pub fn history(&self) -> &History {
        &self.history
    }

    /// Why the job ended as it did, when it says (failed, canceled).
    pub fn message(&self) -> Option<&str> {
        self.message.as_deref()
    }

    /// Wall-clock time (ms since the Unix epoch) the coordinator saw the job ended.
    pub fn ended_unix_ms(&self) -> Option<u64> {
        self.ended_unix_ms
    }

    /// Failed units by worker id.
    pub fn failures(&self) -> &BTreeMap<String, Failures> {
        &self.failures
    }

    /// Pixel-samples merged per worker id, with the worker's name.
    pub fn contributions(&self) -> &BTreeMap<String, (String, u64)> {
        &self.contributions
    }

    /// Renderer ids of the workers whose samples are merged, in order of their first merge.
    pub fn renderers(&self) -> &[String] {
        &self.renderers
    }

    /// Scene preparation workers reported for frame index `index`.
    pub fn frame_prepare(&self, index: usize) -> FramePrepare {
        self.prepare[index]
    }

    pub fn samples_of(&self, batch: u32) -> [u32; 2] {
        let b = self.cfg.batch_spp;
        [batch * b, ((batch + 1) * b).min(self.cfg.spp)]
    }

    pub fn mark_issued(&mut self, tile: usize, batch: u32, now: u64) {
        self.tiles[tile].issue(batch);
        if self.state == JobState::Queued {
            self.state = JobState::Running;
            self.started_ms = Some(now);
            self.revision += 1;
        }
    }

    pub fn requeue(&mut self, tile: usize, batch: u32) {
        if !self.state.is_final() {
            self.tiles[tile].requeue(batch);
        }
    }

    /// Whether the batch is still wanted (not past a noise stop, not merged or buffered).
    pub fn wants(&self, tile: usize, batch: u32) -> bool {
        !self.state.is_final() && self.tiles[tile].wants(batch)
    }

    /// Counts a failed unit against a worker; true when it has now failed `limit` times.
    pub fn count_failure(&mut self, worker: &str, name: &str, limit: u32) -> bool {
        let f = self
            .failures
            .entry(worker.to_string())
            .or_insert_with(|| Failures { name: name.to_string(), count: 0 });
        f.count += 1;
        f.count == limit
    }

    pub fn is_blocked(&self, worker: &str, limit: u32) -> bool {
        self.failures.get(worker).is_some_and(|f| f.count >= limit)
    }

    /// Buffers a batch's sums and merges every batch now contiguous. Returns batches merged.
    pub fn accept(
        &mut self,
        tile: usize,
        batch: u32,
        sums: PartialSums,
        by: Contributor,
        now: u64,
    ) -> u32 {
        self.pending_by.insert((tile, batch), by);
        let first = self.tiles[tile].merged_upto;
        let stop = self
            .cfg
            .noise_target
            .map(|target| NoiseStop { target, min_spp: MIN_SPP_FOR_NOISE_STOP.min(self.cfg.spp) });
        let merged = self.tiles[tile].accept(batch, sums, stop);
        for b in first..first + merged {
            let [s0, s1] = self.samples_of(b);
            self.credit(tile, b, (s1 - s0) as u64 * self.tiles[tile].rect.pixel_count() as u64);
        }
        if merged > 0 {
            self.revision += 1;
        }
        if merged > 0 && self.advance_open_frame() == self.frame_count() {
            self.finish(JobState::Done, now, None);
        }
        if merged > 0 && (self.history.due(self.elapsed_ms(now)) || self.state.is_final()) {
            self.record_history(now);
        }
        merged
    }

    fn credit(&mut self, tile: usize, batch: u32, pixel_samples: u64) {
        let by = self.pending_by.remove(&(tile, batch)).unwrap_or_default();
        if !self.renderers.contains(&by.renderer) {
            self.renderers.push(by.renderer);
        }
        self.contributions.entry(by.id).or_insert((by.name, 0)).1 += pixel_samples;
    }

    /// Holds a queued or running job: its render time stops (a time limit waits too) and it is
    /// offered no units. Err(state) when it has already ended.
    pub fn pause(&mut self, now: u64) -> Result<(), JobState> {
        match self.state {
            JobState::Paused => Ok(()),
            s if s.is_final() => Err(s),
            _ => {
                self.elapsed_before_ms = self.elapsed_ms(now);
                self.started_ms = None;
                self.state = JobState::Paused;
                self.revision += 1;
                Ok(())
            }
        }
    }

    /// Lets a paused job be leased again: `Queued` until its next unit is issued, when the
    /// render time goes on from where it stopped. Err(state) when it has already ended.
    pub fn resume(&mut self) -> Result<(), JobState> {
        match self.state {
            JobState::Paused => {
                self.state = JobState::Queued;
                self.revision += 1;
                Ok(())
            }
            s if s.is_final() => Err(s),
            _ => Ok(()),
        }
    }

    pub fn finish(&mut self, state: JobState, now: u64, message: Option<String>) {
        if self.state.is_final() {
            return;
        }
        self.state = state;
        self.started_ms.get_or_insert(now);
        self.finished_ms = Some(now);
        self.message = message;
        self.revision += 1;
        self.tiles.iter_mut().for_each(TileRun::drain);
        if state == JobState::Done {
            // Ended by its time limit: each tile stops where it is, so a restored record reads
            // as the finished job it is, not as one whose checkpoints went missing.
            self.tiles.iter_mut().for_each(TileRun::stop_here);
        }
        self.pending_by.clear();
        self.forget_reported_noise();
    }

    /// Moves `open_frame` past the frames now complete; returns it.
    pub(super) fn advance_open_frame(&mut self) -> usize {
        while self.open_frame < self.frame_count() && self.frame_complete(self.open_frame) {
            self.open_frame += 1;
        }
        self.open_frame
    }

    /// Drops the sums of a complete frame once its image is written, keeping its counts and
    /// noise for the job's status. False when the frame is not complete.
    pub fn release_frame(&mut self, index: usize) -> bool {
        if index >= self.frame_count() || !self.frame_complete(index) {
            return false;
        }
        self.release_tiles(self.frame_tiles(index));
        true
    }

    /// Releases the tiles in `tiles` that still hold sums; a change for the next checkpoint.
    fn release_tiles(&mut self, tiles: std::ops::Range<usize>) {
        let mut released = false;
        for t in self.tiles[tiles].iter_mut().filter(|t| !t.released) {
            t.release();
            released = true;
        }
        if released {
            self.revision += 1;
        }
    }

    /// Whether frame index `index`'s sums were dropped (its image is written).
    pub fn frame_released(&self, index: usize) -> bool {
        self.tiles.get(index * self.tiles_per_frame).is_some_and(|t| t.released)
    }

    /// Drops an ended job's merged sums once its images are written: the job keeps its counts
    /// and noise for its status, and its images are served from their files. False when the job
    /// has not ended (a running job's sums are its image).
    pub fn release_sums(&mut self) -> bool {
        if !self.state.is_final() {
            return false;
        }
        self.release_tiles(0..self.tiles.len());
        true
    }

    /// Whether every frame's sums were dropped (`release_sums`, `release_frame`).
    pub fn sums_released(&self) -> bool {
        (0..self.frame_count()).all(|i| self.frame_released(i))
    }

    /// Pixels of one frame.
    pub fn pixel_count(&self) -> u64 {
        self.cfg.params.width as u64 * self.cfg.params.height as u64
    }

    /// Mean samples per pixel merged, over all frames.
    pub fn samples_done(&self) -> f64 {
        self.tiles.iter().map(|t| t.merged_samples).sum::<u64>() as f64
            / (self.pixel_count() * self.frame_count() as u64) as f64
    }

    /// Non-finite samples dropped in the merged batches.
    pub fn dropped(&self) -> u64 {
        self.tiles.iter().map(|t| t.dropped).sum()
    }

    /// The largest sample weight in the merged batches.
    pub fn max_weight(&self) -> f64 {
        self.tiles.iter().map(|t| t.max_weight).fold(0.0, f64::max)
    }

    /// Pixel-weighted mean of the tiles' relMSE over tiles with at least one merged batch.
    pub fn noise(&self) -> Option<f64> {
        super::frames::weighted_noise(&self.tiles)
    }

    /// Render time: earlier coordinator lives plus this one's (downtime does not count).
    pub fn elapsed_ms(&self, now: u64) -> u64 {
        let here = match self.started_ms {
            Some(s) => self.finished_ms.unwrap_or(now).saturating_sub(s),
            None => 0,
        };
        self.elapsed_before_ms + here
    }

    /// Whether a time limit has run out.
    pub fn out_of_time(&self, now: u64) -> bool {
        self.started_ms.is_some()
            && self.cfg.time_limit_ms.is_some_and(|l| self.elapsed_ms(now) >= l)
    }

    /// One frame's merged sums (by frame index), for tests (output reads the tiles directly).
    #[cfg(test)]
    pub fn frame_sums(&self, index: usize) -> Vec<PixelSums> {
        let w = self.cfg.params.width as usize;
        let mut frame = vec![PixelSums::default(); self.pixel_count() as usize];
        for t in &self.tiles[self.frame_tiles(index)] {
            if t.merged.is_empty() {
                continue;
            }
            for y in 0..t.rect.h as usize {
                for x in 0..t.rect.w as usize {
                    frame[(t.rect.y0 as usize + y) * w + t.rect.x0 as usize + x] =
                        t.merged[y * t.rect.w as usize + x];
                }
            }
        }
        frame
    }
}
