//! A job's noise-against-time rows: spaced by what the last row recomputed (`history.rs`).
use super::super::history::{History, NoiseSeen};
use super::super::tests::{config, drain, sums};
use super::super::*;

#[test]
fn rows_come_every_100_ms_at_least_and_1_us_later_per_recomputed_pixel() {
    let mut h = History::default();
    assert!(h.due(0), "the first row is due at once");
    h.record([0.0, 1.0, 0.5], 20_000, NoiseSeen::default());
    assert_eq!(h.gap_ms(), 100, "20,000 pixels cost less than the floor");
    assert!(!h.due(99) && h.due(100));
    h.record([0.1, 2.0, 0.4], 2_500_000, NoiseSeen::default());
    assert_eq!(h.gap_ms(), 2500);
    assert!(!h.due(2599) && h.due(2600), "the gap counts from the last row's time (0.1 s)");
}

#[test]
fn past_512_rows_every_other_goes_and_the_newest_stays() {
    let mut h = History::default();
    for i in 0..513 {
        h.record([i as f64, 0.0, 0.0], 0, NoiseSeen::default());
    }
    assert_eq!(h.rows.len(), 257, "every other of the first 512, and the newest");
    assert_eq!(h.rows[1][0], 2.0);
    assert_eq!(h.rows.last().unwrap()[0], 512.0);
}

/// 30 tiles of 100×100: the first row recomputes one tile, the second all 30 (300,000 pixels),
/// so the third waits 300 ms after it.
#[test]
fn a_jobs_rows_wait_for_the_pixels_the_last_row_recomputed() {
    let mut s = Scheduler::new(1_000_000);
    let w = s.register_worker("a", 2, 0);
    let mut cfg = config("j", 12, 0);
    (cfg.params.width, cfg.params.height, cfg.tile_size) = (600, 500, 100);
    s.submit(cfg);
    let units = drain(&mut s, &w, 0);
    let (first, second, third) = (&units[..30], &units[30..60], &units[60..]);
    for (i, g) in first.iter().enumerate() {
        s.complete(&g.lease_id, sums(g, 1.0), i as u64).unwrap();
    }
    assert_eq!(
        s.job("j").unwrap().history.rows.len(),
        1,
        "one row at 0 ms, the next not due before 100"
    );
    s.complete(&second[0].lease_id, sums(&second[0], 1.0), 150).unwrap();
    let job = s.job("j").unwrap();
    assert_eq!(job.history.rows.len(), 2);
    assert_eq!(job.history.gap_ms(), 300, "all 30 tiles merged since the first row");
    s.complete(&second[1].lease_id, sums(&second[1], 1.0), 449).unwrap();
    let job = s.job("j").unwrap();
    assert_eq!(job.history.rows.len(), 2, "not due before 150 + 300 ms");
    let seen = job.history.rows[1][2];
    assert_eq!(
        (job.reported_noise(), job.reported_frame_noise(0)),
        (Some(seen), Some(seen)),
        "status reports the last row's noise"
    );
    assert!(job.noise().unwrap() < seen, "a tile with 8 spp merged since: its noise fell");
    s.complete(&second[2].lease_id, sums(&second[2], 1.0), 450).unwrap();
    let job = s.job("j").unwrap();
    assert_eq!(job.history.rows.len(), 3);
    assert_eq!(job.history.gap_ms(), 100, "two tiles recomputed: the floor");
    for g in second[3..].iter().chain(third) {
        s.complete(&g.lease_id, sums(g, 1.0), 451).unwrap();
    }
    let job = s.job("j").unwrap();
    assert_eq!(job.state, JobState::Done);
    assert_eq!(job.history.rows.len(), 4, "the last merge always adds a row");
    assert_eq!(job.history.rows.last().unwrap()[1], 12.0, "at the job's full spp");
    assert_eq!(job.reported_noise(), job.noise(), "the last row's noise is the job's final noise");
}

#[test]
fn a_cancelled_job_reports_its_noise_afresh() {
    let mut s = Scheduler::new(1_000_000);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 8, 0));
    let units = drain(&mut s, &w, 0);
    s.complete(&units[0].lease_id, sums(&units[0], 1.0), 0).unwrap();
    s.complete(&units[1].lease_id, sums(&units[1], 3.0), 1).unwrap();
    let job = s.job("j").unwrap();
    assert_ne!(job.reported_noise(), job.noise(), "one tile as of the row at 0 ms, two now");
    s.cancel("j", 2).unwrap();
    let job = s.job("j").unwrap();
    assert_eq!(job.reported_noise(), job.noise());
}
