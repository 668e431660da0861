//! A unit as a queue of rows that threads claim one at a time, so that a pool can go from the
//! last rows of one unit straight to the first rows of the next.
//!
//! [`render_tile`](super::render_tile) splits a unit with a rayon `join` tree: the thread that
//! started it waits for the others at the end, and a thread waiting in a join may pick up an
//! unrelated job (the next unit) and finish its own only after that one. A [`RowQueue`] has no
//! join: each thread that works on it claims rows until none are left and returns, so the next
//! unit's work, queued behind it, starts on each thread as soon as that thread runs dry. The
//! caller learns that the unit is complete from [`RowQueue::work`] returning true on the thread
//! that finished its last row.
//!
//! The sums are bit-identical to [`render_tile`](super::render_tile)'s: a row is rendered by one
//! thread, each pixel's samples in index order, and the per-row totals are integer sums and a
//! maximum.
use crate::dispatch_kernel;
use crate::tracer::film::{PixelSums, Tile, TileSums};
use crate::tracer::integrator::Integrator;
use crate::tracer::render::{RenderError, RenderSettings, RowStats, UnitPlan, render_row};
use crate::tracer::scene::Scene;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Mutex, PoisonError};

/// One unit (a tile over a range of sample indices), shared by the threads that render it.
pub struct RowQueue {
    scene: Arc<Scene>,
    settings: RenderSettings,
    tile: Tile,
    samples: Range<u32>,
    plan: UnitPlan,
    canceled: AtomicBool,
    /// The next row to claim; past the tile's height once all are claimed.
    next_row: AtomicU32,
    /// Rows not finished yet (claimed or not).
    rows_left: AtomicU32,
    out: Mutex<TileSums>,
}

impl RowQueue {
    /// A unit ready to be worked on; errors as [`render_tile`](super::render_tile) does for a
    /// tile outside the image or an unknown camera.
    pub fn new(
        scene: Arc<Scene>,
        settings: RenderSettings,
        tile: Tile,
        samples: Range<u32>,
    ) -> Result<RowQueue, RenderError> {
        let plan = UnitPlan::new(&scene, &settings, tile, None)?;
        Ok(RowQueue {
            scene,
            settings,
            tile,
            samples,
            plan,
            canceled: AtomicBool::new(false),
            next_row: AtomicU32::new(0),
            rows_left: AtomicU32::new(tile.h),
            out: Mutex::new(TileSums::new(tile)),
        })
    }

    /// Claims rows and renders them until none is left to claim. True on the one call that
    /// finished the unit's last row: the unit is then complete, and [`RowQueue::take`] has it.
    /// A row that panics still counts as finished (the panic goes on to the caller).
    pub fn work(&self) -> bool {
        let Some(mut row) = self.claim() else { return false };
        // Made once a row is in hand: a thread that arrives after the last claim costs nothing.
        let integrator = Integrator::new(&self.scene, self.settings.background, self.plan.path);
        let mut row_buf = vec![PixelSums::default(); self.tile.w as usize];
        loop {
            let finishing = RowFinishing(&self.rows_left);
            if !self.canceled.load(Ordering::Relaxed) {
                row_buf.fill(PixelSums::default());
                let stats = self.render_row(&integrator, row, &mut row_buf);
                self.store_row(row, &row_buf, stats);
            }
            let finished_unit = finishing.finish();
            match self.claim() {
                Some(next) => row = next,
                None => return finished_unit,
            }
        }
    }

    /// Makes the remaining rows end at once (their pixels left empty) and [`RowQueue::take`]
    /// answer None; callable from any thread, at any time.
    pub fn cancel(&self) {
        self.canceled.store(true, Ordering::Relaxed);
    }

    /// The next unclaimed row, if any.
    fn claim(&self) -> Option<u32> {
        Some(self.next_row.fetch_add(1, Ordering::Relaxed)).filter(|&row| row < self.tile.h)
    }

    /// The unit's sums once [`RowQueue::work`] has answered true; None if it was canceled.
    pub fn take(&self) -> Option<TileSums> {
        if self.canceled.load(Ordering::Relaxed) {
            return None;
        }
        let mut out = self.out.lock().unwrap_or_else(PoisonError::into_inner);
        Some(std::mem::replace(&mut *out, TileSums::new(Tile { w: 0, h: 0, ..self.tile })))
    }

    fn render_row(&self, integrator: &Integrator, row: u32, pixels: &mut [PixelSums]) -> RowStats {
        let (camera, settings, py) = (&self.plan.camera, &self.settings, self.tile.y0 + row);
        dispatch_kernel!(
            self.plan.kernel,
            render_row(
                integrator,
                camera,
                settings,
                self.tile.x0,
                py,
                self.samples.clone(),
                pixels
            )
        )
    }

    fn store_row(&self, row: u32, pixels: &[PixelSums], stats: RowStats) {
        let mut out = self.out.lock().unwrap_or_else(PoisonError::into_inner);
        let start = row as usize * self.tile.w as usize;
        out.pixels[start..start + pixels.len()].copy_from_slice(pixels);
        stats.add_to(&mut out);
    }
}

/// Counts a claimed row as finished when dropped, also when its rendering panicked, so that a
/// panic cannot leave the unit waiting for a row forever.
struct RowFinishing<'a>(&'a AtomicU32);

impl RowFinishing<'_> {
    /// Finishes the row; true if it was the unit's last.
    fn finish(self) -> bool {
        let last = self.0.fetch_sub(1, Ordering::AcqRel) == 1;
        std::mem::forget(self);
        last
    }
}

impl Drop for RowFinishing<'_> {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::AcqRel);
    }
}

#[cfg(test)]
mod tests;
