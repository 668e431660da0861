//! Frames of an animation job: which frame's units a worker gets, and per-frame views.
//!
//! A job's tiles are numbered frame-major (see [`JobRun::tiles`]), so everything about units —
//! leases, in-order merging, noise stops, checkpoints — is the same for one frame or many.
//! What frames add is the choice of the next unit:
//! - **Affinity**: a worker that rendered frame n last gets frame n's units while it has any,
//!   because its scene for frame n (BVH included) is built; moving costs a refit or rebuild.
//! - **Spreading**: a worker without a frame of its own takes the frame with the fewest workers
//!   on it (then the earliest), so workers do not all rebuild the same frames in turn, and the
//!   frames in flight stay few.
//! - **Time limits** spread work batch-major over all frames instead (every frame gets batch b
//!   before any gets b + 1), so a limit that ends the job leaves every frame equally refined;
//!   affinity then only holds within a batch round.
//!
//! Without affinity (`--frame-affinity off`) units go out in plain order: frame by frame,
//! breadth-first over batches within a frame — the baseline of `tessera-bench frames`.
use super::job::JobRun;
use std::ops::Range;

/// How a worker prepared the scene for a unit, as it reports with the result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrepareKind {
    /// The worker had this frame's scene ready.
    Cached,
    /// Loaded the scene and built its BVH from scratch.
    Build,
    /// Moved the previous frame's BVH to this frame's positions.
    Refit,
}

/// Scene preparation for one frame, summed over the workers' reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FramePrepare {
    pub builds: u32,
    pub refits: u32,
    pub ms: f64,
    /// The largest peak resident set workers reported with this frame's results (0: none).
    pub peak_rss_bytes: u64,
}

/// What the scheduler knows about where workers are, for choosing a frame.
pub struct Affinity {
    /// The frame index this worker rendered last in this job.
    pub last: Option<usize>,
    /// Leases in flight per frame index.
    pub busy: Vec<u32>,
}

impl JobRun {
    /// True for a job given a `frames` range (even of one frame): its files and EXR headers name
    /// frame numbers.
    pub fn is_animation(&self) -> bool {
        self.cfg.request.frames.is_some()
    }

    pub fn frame_count(&self) -> usize {
        self.cfg.frames.len().max(1)
    }

    /// The tile indices of frame index `index`.
    pub fn frame_tiles(&self, index: usize) -> Range<usize> {
        index * self.tiles_per_frame..(index + 1) * self.tiles_per_frame
    }

    pub fn frame_index_of(&self, tile: usize) -> usize {
        tile / self.tiles_per_frame.max(1)
    }

    /// The animation frame number of frame index `index`.
    pub fn frame_number(&self, index: usize) -> u32 {
        self.cfg.frames.get(index).copied().unwrap_or(0)
    }

    /// Animation time of frame index `index`, in seconds.
    pub fn frame_time_s(&self, index: usize) -> f64 {
        self.frame_number(index) as f64 / self.cfg.params.fps
    }

    /// The lowest (batch, tile) issuable among `tiles`.
    fn next_in(&self, tiles: Range<usize>) -> Option<(u32, usize)> {
        tiles.filter_map(|i| self.tiles[i].next_issuable().map(|b| (b, i))).min()
    }

    /// The unit to hand out next, as (tile, batch): breadth-first over batches within a frame,
    /// frames chosen as the module doc says. `affinity` None: plain frame-major order. Frames
    /// before `open_frame` are complete and not looked at, and frame-major order stops at the
    /// first frame that can be the answer, so a lease costs the frames in flight, not the job.
    pub fn next_unit(&self, affinity: Option<&Affinity>) -> Option<(usize, u32)> {
        if self.state.is_final() {
            return None;
        }
        if self.cfg.time_limit_ms.is_some() {
            return self.next_unit_batch_major(affinity);
        }
        if let Some((b, t)) =
            affinity.and_then(|a| a.last).and_then(|last| self.next_in(self.frame_tiles(last)))
        {
            return Some((t, b));
        }
        let busy = |f: usize| affinity.map_or(0, |a| a.busy.get(f).copied().unwrap_or(0));
        let mut best: Option<(u32, (u32, usize))> = None;
        for f in self.open_frame..self.frame_count() {
            let Some(unit) = self.next_in(self.frame_tiles(f)) else { continue };
            let load = busy(f);
            if best.is_none_or(|(least, _)| load < least) {
                best = Some((load, unit));
            }
            if load == 0 {
                break; // no later frame has fewer workers, and ties go to the earliest
            }
        }
        best.map(|(_, (b, t))| (t, b))
    }

    /// `next_unit` for a time-limited job: the lowest batch over all frames first.
    fn next_unit_batch_major(&self, affinity: Option<&Affinity>) -> Option<(usize, u32)> {
        let candidates: Vec<(usize, (u32, usize))> = (self.open_frame..self.frame_count())
            .filter_map(|f| self.next_in(self.frame_tiles(f)).map(|u| (f, u)))
            .collect();
        let lowest_batch = candidates.iter().map(|(_, (b, _))| *b).min()?;
        let Some(aff) = affinity else {
            return candidates
                .iter()
                .min_by_key(|(f, (b, _))| (*b, *f))
                .map(|(_, (b, t))| (*t, *b));
        };
        if let Some(&(_, (b, t))) =
            aff.last.and_then(|last| candidates.iter().find(|(f, _)| *f == last))
            && b <= lowest_batch
        {
            return Some((t, b));
        }
        let busy = |f: usize| aff.busy.get(f).copied().unwrap_or(0);
        candidates.iter().min_by_key(|(f, (b, _))| (*b, busy(*f), *f)).map(|(_, (b, t))| (*t, *b))
    }

    /// Mean samples per pixel merged in frame index `index`.
    pub fn frame_samples_done(&self, index: usize) -> f64 {
        self.tiles[self.frame_tiles(index)].iter().map(|t| t.merged_samples).sum::<u64>() as f64
            / self.pixel_count() as f64
    }

    /// Non-finite samples dropped in a frame's merged batches.
    pub fn frame_dropped(&self, index: usize) -> u64 {
        self.tiles[self.frame_tiles(index)].iter().map(|t| t.dropped).sum()
    }

    /// The largest sample weight in a frame's merged batches.
    pub fn frame_max_weight(&self, index: usize) -> f64 {
        self.tiles[self.frame_tiles(index)].iter().map(|t| t.max_weight).fold(0.0, f64::max)
    }

    /// Pixel-weighted relMSE of a frame's tiles that have merged something.
    pub fn frame_noise(&self, index: usize) -> Option<f64> {
        weighted_noise(&self.tiles[self.frame_tiles(index)])
    }

    /// Every tile of the frame has all the batches it will get.
    pub fn frame_complete(&self, index: usize) -> bool {
        self.tiles[self.frame_tiles(index)].iter().all(|t| t.complete())
    }

    pub fn note_prepare(&mut self, tile: usize, kind: PrepareKind, ms: f64) {
        let f = self.frame_index_of(tile);
        let Some(p) = self.prepare.get_mut(f) else { return };
        match kind {
            PrepareKind::Build => p.builds += 1,
            PrepareKind::Refit => p.refits += 1,
            PrepareKind::Cached => {}
        }
        p.ms += ms.max(0.0);
    }

    pub fn note_peak_rss(&mut self, tile: usize, bytes: u64) {
        let f = self.frame_index_of(tile);
        if let Some(p) = self.prepare.get_mut(f) {
            p.peak_rss_bytes = p.peak_rss_bytes.max(bytes);
        }
    }
}

/// Pixel-weighted mean of the tiles' relMSE over tiles with at least one merged batch.
pub fn weighted_noise(tiles: &[super::TileRun]) -> Option<f64> {
    let (mut acc, mut px) = (0.0, 0.0);
    for t in tiles {
        if let Some(r) = t.noise() {
            acc += r * t.rect.pixel_count() as f64;
            px += t.rect.pixel_count() as f64;
        }
    }
    (px > 0.0).then(|| acc / px)
}
