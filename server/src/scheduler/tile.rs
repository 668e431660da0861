//! One tile of a job: which batches are issued, buffered and merged, and its f64 sums.
use super::durable::ReleasedTile;
use crate::image::rel_mse;
use std::cell::Cell;
use std::collections::{BTreeMap, BTreeSet};
use tessera_proto::{PartialSums, TileRect};
use tessera_render::tracer::PixelSums;

pub struct TileRun {
    pub rect: TileRect,
    batches: u32,
    next_new: u32,
    requeued: BTreeSet<u32>,
    /// The merged sums: empty until the first batch merges (a queued job holds no sums), and
    /// again once released (`release`: the tile's image is on disk and it takes no more batches).
    pub merged: Vec<PixelSums>,
    /// The sums were dropped after the image was written; `rel_mse` keeps their noise.
    pub(super) released: bool,
    pub(super) merged_upto: u32,
    /// Batches whose sums are on disk (see `crate::persist`); merged_upto > persisted_upto
    /// means the tile needs a checkpoint.
    pub(super) persisted_upto: u32,
    pending: BTreeMap<u32, PartialSums>,
    pub(super) stop_at: Option<u32>,
    /// Pixel-samples merged (including dropped ones).
    pub(super) merged_samples: u64,
    /// Non-finite samples dropped, and the largest sample weight, over the merged batches only
    /// (so a checkpoint of the merged sums carries exactly its own counts).
    pub(super) dropped: u64,
    pub(super) max_weight: f64,
    /// relMSE of `merged`, computed lazily (None: not yet computed since the last merge).
    rel_mse: Cell<Option<f64>>,
}

impl TileRun {
    pub fn new(rect: TileRect, batches: u32) -> TileRun {
        TileRun {
            rect,
            batches,
            next_new: 0,
            requeued: BTreeSet::new(),
            merged: Vec::new(),
            released: false,
            merged_upto: 0,
            persisted_upto: 0,
            pending: BTreeMap::new(),
            stop_at: None,
            merged_samples: 0,
            dropped: 0,
            max_weight: 0.0,
            rel_mse: Cell::new(None),
        }
    }

    /// Puts back a checkpoint: `sums` hold batches 0..upto; everything after is issued afresh.
    pub fn restore(
        &mut self,
        upto: u32,
        stop_at: Option<u32>,
        sums: Vec<PixelSums>,
        dropped: u64,
        max_weight: f64,
        samples_per_pixel: u64,
    ) {
        debug_assert_eq!(sums.len(), self.rect.pixel_count());
        self.restore_counts(upto, stop_at, dropped, max_weight, samples_per_pixel);
        self.merged = sums;
        self.persisted_upto = upto;
        self.rel_mse.set(None);
    }

    /// Puts back a tile that was released before the checkpoint: its counts and noise, no sums.
    pub fn restore_released(
        &mut self,
        upto: u32,
        stop_at: Option<u32>,
        summary: &ReleasedTile,
        samples_per_pixel: u64,
    ) {
        self.restore_counts(upto, stop_at, summary.dropped, summary.max_weight, samples_per_pixel);
        self.persisted_upto = 0;
        self.rel_mse.set(summary.noise);
        self.released = true;
    }

    /// What both restores put back: batches 0..upto merged, the noise stop, the counts.
    fn restore_counts(
        &mut self,
        upto: u32,
        stop_at: Option<u32>,
        dropped: u64,
        max_weight: f64,
        samples_per_pixel: u64,
    ) {
        self.merged_upto = upto;
        self.next_new = upto;
        self.stop_at = stop_at;
        self.dropped = dropped;
        self.max_weight = max_weight;
        self.merged_samples = samples_per_pixel * self.rect.pixel_count() as u64;
    }

    /// Drops the sums once the tile's image is written and it takes no more batches, keeping
    /// its counts and noise for the job's status.
    pub(super) fn release(&mut self) {
        self.noise();
        self.merged = Vec::new();
        self.released = true;
        self.drain();
    }

    /// What a checkpoint keeps of a released tile instead of its sums.
    pub(super) fn summary(&self) -> Option<ReleasedTile> {
        self.released.then(|| ReleasedTile {
            noise: self.rel_mse.get(),
            dropped: self.dropped,
            max_weight: self.max_weight,
        })
    }

    fn limit(&self) -> u32 {
        self.stop_at.unwrap_or(self.batches)
    }

    pub fn next_issuable(&self) -> Option<u32> {
        let requeued = self.requeued.first().copied().filter(|&b| b < self.limit());
        let fresh = (self.next_new < self.limit()).then_some(self.next_new);
        requeued.or(fresh)
    }

    /// Records that `batch` was handed out.
    pub(super) fn issue(&mut self, batch: u32) {
        if !self.requeued.remove(&batch) {
            debug_assert_eq!(batch, self.next_new);
            self.next_new += 1;
        }
    }

    pub(super) fn requeue(&mut self, batch: u32) {
        self.requeued.insert(batch);
    }

    pub(super) fn complete(&self) -> bool {
        self.merged_upto >= self.limit()
    }

    /// Whether the batch is still wanted (not past a noise stop, not merged or buffered).
    pub(super) fn wants(&self, batch: u32) -> bool {
        batch < self.limit() && batch >= self.merged_upto && !self.pending.contains_key(&batch)
    }

    /// The tile's relMSE, None before anything is merged.
    pub fn noise(&self) -> Option<f64> {
        if self.merged_upto == 0 {
            return None;
        }
        if self.rel_mse.get().is_none() {
            self.rel_mse.set(Some(rel_mse(&self.merged, self.rect.w as usize)));
        }
        self.rel_mse.get()
    }

    /// The pixels whose relMSE [`TileRun::noise`] would compute afresh: the tile's, when it has
    /// merged batches since its relMSE was last computed.
    pub(super) fn stale_noise_pixels(&self) -> u64 {
        if self.merged_upto > 0 && self.rel_mse.get().is_none() {
            self.rect.pixel_count() as u64
        } else {
            0
        }
    }

    /// Buffers a batch and merges every batch now contiguous, stopping early once the noise
    /// target is met. Returns how many batches merged.
    pub(super) fn accept(
        &mut self,
        batch: u32,
        sums: PartialSums,
        noise_stop: Option<NoiseStop>,
    ) -> u32 {
        self.pending.insert(batch, sums);
        let mut merged = 0;
        while let Some(next) = self.pending.remove(&self.merged_upto) {
            self.merge_next(next, noise_stop);
            merged += 1;
        }
        merged
    }

    fn merge_next(&mut self, sums: PartialSums, noise_stop: Option<NoiseStop>) {
        debug_assert!(!self.released, "a released tile takes no batches");
        if self.merged.is_empty() {
            self.merged = vec![PixelSums::default(); self.rect.pixel_count()];
        }
        let per_pixel = (sums.samples[1] - sums.samples[0]) as u64;
        for (acc, p) in self.merged.iter_mut().zip(&sums.pixels) {
            acc.merge(&PixelSums {
                sum: p.sum,
                sum_sq: p.sum_sq,
                sum_lum_sq: p.sum_lum_sq,
                count: p.count,
            });
        }
        self.merged_upto += 1;
        self.merged_samples += per_pixel * self.rect.pixel_count() as u64;
        self.dropped += sums.dropped;
        self.max_weight = self.max_weight.max(sums.max_weight);
        self.rel_mse.set(None);
        if let Some(stop) = noise_stop {
            let may_stop = self.stop_at.is_none() && sums.samples[1] >= stop.min_spp;
            if may_stop && self.noise().is_some_and(|rel| rel <= stop.target) {
                self.stop_at = Some(self.merged_upto);
                self.pending.clear();
            }
        }
    }

    /// Takes no batch past those merged (the job ended by its time limit).
    pub(super) fn stop_here(&mut self) {
        if !self.complete() {
            self.stop_at = Some(self.merged_upto);
        }
    }

    /// Forgets buffered and queued work (the job ended).
    pub(super) fn drain(&mut self) {
        self.pending.clear();
        self.requeued.clear();
    }
}

/// A tile stops at the first merged batch where its relMSE ≤ `target`, once `min_spp` are in.
#[derive(Clone, Copy, Debug)]
pub(super) struct NoiseStop {
    pub target: f64,
    pub min_spp: u32,
}
