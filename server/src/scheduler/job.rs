//! One job inside the scheduler: its tiles, their batches, and the in-order merge.
//!
//! Unit boundaries are fixed when the job is accepted: batch `b` of a tile covers sample indices
//! [b·B, min((b+1)·B, spp)). Each tile merges its batches strictly in batch order, buffering
//! early arrivals, so its f64 sums — and the image — do not depend on who rendered what, when.
//! A noise target is decided on that same order (after merging batch k, is the tile's relMSE at
//! or below the target?), so it is deterministic too.
use crate::image::rel_mse;
use std::cell::Cell;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use tessera_proto::{JobRequest, JobState, PartialSums, RenderParams, TileRect};
use tessera_worker::tracer::PixelSums;

/// Fewest samples per pixel merged before a tile may stop on its noise estimate: with fewer, the
/// variance estimate itself is too noisy to trust.
pub const MIN_SPP_FOR_NOISE_STOP: u32 = 16;
const MAX_HISTORY: usize = 512;
const HISTORY_EVERY_MS: u64 = 100;

/// A validated job, as accepted.
#[derive(Clone, Debug)]
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
}

pub struct TileRun {
    pub rect: TileRect,
    batches: u32,
    next_new: u32,
    requeued: BTreeSet<u32>,
    pub merged: Vec<PixelSums>,
    merged_upto: u32,
    pending: BTreeMap<u32, PartialSums>,
    stop_at: Option<u32>,
    /// Pixel-samples merged (including dropped ones).
    merged_samples: u64,
    /// relMSE of `merged`, computed lazily (None: not yet computed since the last merge).
    rel_mse: Cell<Option<f64>>,
}

impl TileRun {
    fn limit(&self) -> u32 {
        self.stop_at.unwrap_or(self.batches)
    }

    pub fn next_issuable(&self) -> Option<u32> {
        let requeued = self.requeued.first().copied().filter(|&b| b < self.limit());
        let fresh = (self.next_new < self.limit()).then_some(self.next_new);
        requeued.or(fresh)
    }

    fn complete(&self) -> bool {
        self.merged_upto >= self.limit()
    }

    /// The tile's relMSE, None before anything is merged.
    fn noise(&self) -> Option<f64> {
        if self.merged_upto == 0 {
            return None;
        }
        if self.rel_mse.get().is_none() {
            self.rel_mse.set(Some(rel_mse(&self.merged)));
        }
        self.rel_mse.get()
    }
}

/// Who rendered a unit: the worker's id and name, kept with the job so its status can say who
/// contributed even after the worker is gone.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Renderer {
    pub id: String,
    pub name: String,
}

pub struct JobRun {
    pub cfg: JobConfig,
    pub seq: u64,
    pub state: JobState,
    pub tiles: Vec<TileRun>,
    pub started_ms: Option<u64>,
    pub finished_ms: Option<u64>,
    pub history: Vec<[f64; 3]>,
    pub dropped: u64,
    pub max_weight: f64,
    pub message: Option<String>,
    /// Pixel-samples merged per worker id (with its name).
    pub contributions: BTreeMap<String, (String, u64)>,
    /// Who rendered each buffered (tile, batch), credited when it merges in order.
    pending_by: HashMap<(usize, u32), Renderer>,
}

impl JobRun {
    pub fn new(cfg: JobConfig, seq: u64) -> JobRun {
        let (w, h, t) = (cfg.params.width, cfg.params.height, cfg.tile_size);
        let batches = cfg.spp.div_ceil(cfg.batch_spp);
        let mut tiles = Vec::new();
        for y0 in (0..h).step_by(t as usize) {
            for x0 in (0..w).step_by(t as usize) {
                let rect = TileRect { x0, y0, w: t.min(w - x0), h: t.min(h - y0) };
                tiles.push(TileRun {
                    rect,
                    batches,
                    next_new: 0,
                    requeued: BTreeSet::new(),
                    merged: vec![PixelSums::default(); rect.pixel_count()],
                    merged_upto: 0,
                    pending: BTreeMap::new(),
                    stop_at: None,
                    merged_samples: 0,
                    rel_mse: Cell::new(None),
                });
            }
        }
        JobRun { cfg, seq, state: JobState::Queued, tiles, started_ms: None, finished_ms: None, history: Vec::new(), dropped: 0, max_weight: 0.0, message: None, contributions: BTreeMap::new(), pending_by: HashMap::new() }
    }

    pub fn samples_of(&self, batch: u32) -> [u32; 2] {
        let b = self.cfg.batch_spp;
        [batch * b, ((batch + 1) * b).min(self.cfg.spp)]
    }

    /// The unit to hand out next: breadth-first over batches, so the preview refines evenly.
    pub fn next_unit(&self) -> Option<(usize, u32)> {
        if self.state.is_final() {
            return None;
        }
        self.tiles.iter().enumerate().filter_map(|(i, t)| t.next_issuable().map(|b| (b, i))).min().map(|(b, i)| (i, b))
    }

    pub fn mark_issued(&mut self, tile: usize, batch: u32, now: u64) {
        let t = &mut self.tiles[tile];
        if !t.requeued.remove(&batch) {
            debug_assert_eq!(batch, t.next_new);
            t.next_new += 1;
        }
        if self.state == JobState::Queued {
            self.state = JobState::Running;
            self.started_ms = Some(now);
        }
    }

    pub fn requeue(&mut self, tile: usize, batch: u32) {
        if !self.state.is_final() {
            self.tiles[tile].requeued.insert(batch);
        }
    }

    /// Whether the batch is still wanted (not past a noise stop, not merged or buffered).
    pub fn wants(&self, tile: usize, batch: u32) -> bool {
        let t = &self.tiles[tile];
        !self.state.is_final() && batch < t.limit() && batch >= t.merged_upto && !t.pending.contains_key(&batch)
    }

    /// Buffers a batch's sums and merges every batch now contiguous. Returns batches merged.
    pub fn accept(&mut self, tile: usize, batch: u32, sums: PartialSums, by: Renderer, now: u64) -> u32 {
        self.pending_by.insert((tile, batch), by);
        self.dropped += sums.dropped;
        self.max_weight = self.max_weight.max(sums.max_weight);
        self.tiles[tile].pending.insert(batch, sums);
        let mut merged = 0;
        loop {
            let t = &mut self.tiles[tile];
            let upto = t.merged_upto;
            let Some(next) = t.pending.remove(&upto) else { break };
            let pixel_samples = (next.samples[1] - next.samples[0]) as u64 * next.tile.pixel_count() as u64;
            self.merge_next(tile, next);
            self.credit(tile, upto, pixel_samples);
            merged += 1;
        }
        if self.tiles.iter().all(TileRun::complete) {
            self.finish(JobState::Done, now, None);
        }
        // A history row costs a pass over every tile's noise: at most one per HISTORY_EVERY_MS.
        let due = self.history.last().is_none_or(|r| now >= self.started_ms.unwrap_or(0) + (r[0] * 1000.0) as u64 + HISTORY_EVERY_MS);
        if merged > 0 && (due || self.state.is_final()) {
            self.record_history(now);
        }
        merged
    }

    fn merge_next(&mut self, tile: usize, sums: PartialSums) {
        let per_pixel = (sums.samples[1] - sums.samples[0]) as u64;
        let target = self.cfg.noise_target;
        let t = &mut self.tiles[tile];
        for (acc, p) in t.merged.iter_mut().zip(&sums.pixels) {
            acc.merge(&PixelSums { sum: p.sum, sum_sq: p.sum_sq, sum_lum_sq: p.sum_lum_sq, count: p.count });
        }
        t.merged_upto += 1;
        t.merged_samples += per_pixel * t.rect.pixel_count() as u64;
        t.rel_mse.set(None);
        let spp_merged = sums.samples[1];
        if let Some(target) = target {
            let may_stop = t.stop_at.is_none() && spp_merged >= MIN_SPP_FOR_NOISE_STOP.min(self.cfg.spp);
            if may_stop && t.noise().is_some_and(|rel| rel <= target) {
                t.stop_at = Some(t.merged_upto);
                t.pending.clear();
            }
        }
    }

    fn credit(&mut self, tile: usize, batch: u32, pixel_samples: u64) {
        let by = self.pending_by.remove(&(tile, batch)).unwrap_or_default();
        self.contributions.entry(by.id).or_insert((by.name, 0)).1 += pixel_samples;
    }

    pub fn finish(&mut self, state: JobState, now: u64, message: Option<String>) {
        if self.state.is_final() {
            return;
        }
        self.state = state;
        self.finished_ms = Some(now);
        self.message = message;
        for t in &mut self.tiles {
            t.pending.clear();
            t.requeued.clear();
        }
        self.pending_by.clear();
    }

    fn record_history(&mut self, now: u64) {
        let row = [self.elapsed_ms(now) as f64 / 1000.0, self.samples_done(), self.noise().unwrap_or(f64::NAN)];
        self.history.push(row);
        if self.history.len() > MAX_HISTORY {
            // Thin evenly but keep the newest row.
            let last = self.history.pop().expect("non-empty");
            self.history = self.history.iter().step_by(2).copied().collect();
            self.history.push(last);
        }
    }

    pub fn pixel_count(&self) -> u64 {
        self.cfg.params.width as u64 * self.cfg.params.height as u64
    }

    /// Mean samples per pixel merged.
    pub fn samples_done(&self) -> f64 {
        self.tiles.iter().map(|t| t.merged_samples).sum::<u64>() as f64 / self.pixel_count() as f64
    }

    /// Pixel-weighted mean of the tiles' relMSE over tiles with at least one merged batch.
    pub fn noise(&self) -> Option<f64> {
        let (mut acc, mut px) = (0.0, 0.0);
        for t in &self.tiles {
            if let Some(r) = t.noise() {
                acc += r * t.rect.pixel_count() as f64;
                px += t.rect.pixel_count() as f64;
            }
        }
        (px > 0.0).then(|| acc / px)
    }

    pub fn elapsed_ms(&self, now: u64) -> u64 {
        match self.started_ms {
            Some(s) => self.finished_ms.unwrap_or(now).saturating_sub(s),
            None => 0,
        }
    }

    /// Whether a time limit has run out.
    pub fn out_of_time(&self, now: u64) -> bool {
        matches!((self.cfg.time_limit_ms, self.started_ms), (Some(l), Some(s)) if now >= s + l)
    }

    /// The whole frame of merged sums, for output.
    pub fn frame(&self) -> Vec<PixelSums> {
        let w = self.cfg.params.width as usize;
        let mut frame = vec![PixelSums::default(); self.pixel_count() as usize];
        for t in &self.tiles {
            for y in 0..t.rect.h as usize {
                for x in 0..t.rect.w as usize {
                    frame[(t.rect.y0 as usize + y) * w + t.rect.x0 as usize + x] = t.merged[y * t.rect.w as usize + x];
                }
            }
        }
        frame
    }
}
