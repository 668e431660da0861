//! A job's noise against time: the rows (render seconds, mean spp, relMSE) that its status,
//! the dashboard's chart and `tessera render` show.
//!
//! A row costs a pass over the relMSE of every tile merged since the row before (the tiles keep
//! theirs otherwise), ≈ 25 ns a pixel. Rows are therefore spaced by what the last one cost: at
//! least [`HISTORY_EVERY_MS`] apart, and 1 µs more for each pixel the last row recomputed, so
//! they stay under a few per cent of the coordinator's time however large the frame. At a fixed
//! 100 ms, a 1-megapixel job's rows took about a quarter of it (`tessera-bench roundtrips`,
//! docs/dev/performance-log.md, 2026-12-06).
//!
//! A status request (`GET /v1/jobs/{id}`, and each event of a watched job, up to ten a second)
//! reports the noise as of the last row, for the same reason: computing it afresh would cost a
//! pass over every tile merged since, per request. The figures are fresh before the first row
//! and once the job has ended.
use super::job::JobRun;
use super::tile::TileRun;

/// The shortest gap between two rows.
const HISTORY_EVERY_MS: u64 = 100;
/// The gap added per pixel the last row recomputed.
const GAP_NS_PER_PIXEL: u64 = 1000;
/// Rows kept: past it, every other row goes (the newest stays).
const MAX_HISTORY: usize = 512;

#[derive(Clone, Debug)]
pub struct History {
    pub rows: Vec<[f64; 3]>,
    /// How long after the last row the next one is due.
    gap_ms: u64,
    /// The job's and each frame's noise when the last row was recorded.
    seen: Option<NoiseSeen>,
}

#[derive(Clone, Debug, Default)]
pub(super) struct NoiseSeen {
    job: Option<f64>,
    frames: Vec<Option<f64>>,
}

impl Default for History {
    fn default() -> History {
        History::from_rows(Vec::new())
    }
}

impl History {
    /// Rows restored from a checkpoint.
    pub fn from_rows(rows: Vec<[f64; 3]>) -> History {
        History { rows, gap_ms: HISTORY_EVERY_MS, seen: None }
    }

    /// Whether a row is due at `elapsed_ms` of render time.
    pub fn due(&self, elapsed_ms: u64) -> bool {
        self.rows.last().is_none_or(|r| elapsed_ms >= (r[0] * 1000.0) as u64 + self.gap_ms)
    }

    /// The gap before the next row, in ms.
    pub fn gap_ms(&self) -> u64 {
        self.gap_ms
    }

    /// Adds `row`, whose noise figures (`seen`) recomputed the relMSE of `recomputed_pixels`.
    pub(super) fn record(&mut self, row: [f64; 3], recomputed_pixels: u64, seen: NoiseSeen) {
        self.seen = Some(seen);
        self.gap_ms = (recomputed_pixels * GAP_NS_PER_PIXEL / 1_000_000).max(HISTORY_EVERY_MS);
        self.rows.push(row);
        if self.rows.len() > MAX_HISTORY {
            let last = self.rows.pop().expect("non-empty");
            self.rows = self.rows.iter().step_by(2).copied().collect();
            self.rows.push(last);
        }
    }
}

impl JobRun {
    /// Adds a row for now, keeping the noise figures status requests report until the next.
    pub(super) fn record_history(&mut self, now: u64) {
        let recomputed = self.tiles.iter().map(TileRun::stale_noise_pixels).sum();
        let job = self.noise();
        let row = [self.elapsed_ms(now) as f64 / 1000.0, self.samples_done(), job.unwrap_or(0.0)];
        // Every tile's relMSE is fresh after `noise()`: the frames' figures cost a sum each.
        let frames = (0..self.frame_count()).map(|i| self.frame_noise(i)).collect();
        self.history.record(row, recomputed, NoiseSeen { job, frames });
    }

    /// Makes status requests compute the noise afresh (the job has ended: its tiles will not
    /// change again, so the pass is paid once).
    pub(super) fn forget_reported_noise(&mut self) {
        self.history.seen = None;
    }

    /// The job's noise as status requests report it: as of the last history row.
    pub fn reported_noise(&self) -> Option<f64> {
        match &self.history.seen {
            Some(seen) => seen.job,
            None => self.noise(),
        }
    }

    /// Frame `index`'s noise as of the last history row.
    pub fn reported_frame_noise(&self, index: usize) -> Option<f64> {
        match &self.history.seen {
            Some(seen) => seen.frames.get(index).copied().flatten(),
            None => self.frame_noise(index),
        }
    }
}
