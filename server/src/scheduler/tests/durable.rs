//! Checkpoints, restarts, epochs and the blocklist.
use super::super::tests::{config, drain, sums};
use super::super::*;
use std::collections::HashMap;

const TIMEOUT: u64 = 1000;

/// A checkpoint kept in memory, as the store would keep it on disk.
#[derive(Default)]
struct Disk {
    records: HashMap<String, JobRecord>,
    tiles: HashMap<(String, u32, u32), TileRecord>,
}

/// A tile's merged sums, batches merged and largest path weight.
type TileRecord = (Vec<tessera_render::tracer::PixelSums>, u64, f64);

impl Disk {
    fn save(&mut self, s: &mut Scheduler, now: u64) -> usize {
        let cps = s.checkpoint(now);
        for cp in &cps {
            for t in &cp.tiles {
                self.tiles.insert(
                    (cp.record.cfg.id.clone(), t.tile, t.upto),
                    (t.sums.clone(), t.dropped, t.max_weight),
                );
            }
            for t in cp.tiles.iter().filter(|t| t.previous_upto > 0) {
                self.tiles.remove(&(cp.record.cfg.id.clone(), t.tile, t.previous_upto)); // superseded
            }
            self.records.insert(cp.record.cfg.id.clone(), cp.record.clone());
            s.mark_persisted(
                cp.record.seq,
                cp.revision,
                &cp.tiles.iter().map(|t| (t.tile, t.upto)).collect::<Vec<_>>(),
                &cp.released_files,
            );
            for &(tile, upto) in &cp.released_files {
                self.tiles
                    .remove(&(cp.record.cfg.id.clone(), tile, upto))
                    .expect("a released tile's file was written");
            }
        }
        cps.len()
    }

    fn boot(&self, epoch: u64, lose_tile: Option<u32>) -> Scheduler {
        let mut s = Scheduler::with_epoch(TIMEOUT, 3, epoch);
        let mut recs: Vec<_> = self.records.values().cloned().collect();
        recs.sort_by_key(|r| r.seq);
        for rec in recs {
            let id = rec.cfg.id.clone();
            s.restore(rec, 0, |tile, mark, _| {
                if Some(tile) == lose_tile {
                    return None;
                }
                let (sums, dropped, max_weight) =
                    self.tiles.get(&(id.clone(), tile, mark.upto))?.clone();
                Some(RestoredTile { sums, dropped, max_weight })
            });
        }
        s
    }
}

fn frame_bits(s: &Scheduler, id: &str) -> Vec<u64> {
    s.job(id)
        .unwrap()
        .frame_sums(0)
        .iter()
        .flat_map(|p| p.sum.iter().chain(&p.sum_sq).map(|v| v.to_bits()).chain([p.count]))
        .collect()
}

/// Renders a job from start to end on one scheduler, completing units in lease order.
fn undisturbed() -> Vec<u64> {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 1, 0);
    s.submit(config("j", 16, 0));
    for g in drain(&mut s, &w, 0) {
        s.complete(&g.lease_id, sums(&g, 0.5), 1).unwrap();
    }
    assert_eq!(s.job("j").unwrap().state, JobState::Done);
    frame_bits(&s, "j")
}

/// Completes some units out of order, checkpoints, "crashes", resumes on a new scheduler.
fn interrupted(lose_tile: Option<u32>) -> Vec<u64> {
    let mut disk = Disk::default();
    let mut a = Scheduler::with_epoch(TIMEOUT, 3, 1);
    let w = a.register_worker("a", 1, 0);
    a.submit(config("j", 16, 0));
    let grants = drain(&mut a, &w, 0);
    // Batches 0 and 2 of every tile: batch 2 waits for batch 1, so only batch 0 is merged.
    for g in grants.iter().filter(|g| g.samples[0] == 0 || g.samples[0] == 8) {
        a.complete(&g.lease_id, sums(g, 0.5), 600).unwrap();
    }
    assert_eq!(disk.save(&mut a, 600), 1);
    // Merged after the checkpoint, then lost in the crash.
    for g in grants.iter().filter(|g| g.samples[0] == 4) {
        a.complete(&g.lease_id, sums(g, 0.5), 700).unwrap();
    }
    let mut b = disk.boot(2, lose_tile);
    let job = b.job("j").unwrap();
    assert_eq!(job.state, JobState::Running);
    assert_eq!(job.elapsed_ms(0), 600, "render time carries over, downtime does not");
    let lost_px = lose_tile.map_or(0, |t| job.tiles[t as usize].rect.pixel_count()) as f64;
    let expect_done = 4.0 * (1.0 - lost_px / job.pixel_count() as f64);
    assert!(
        (job.samples_done() - expect_done).abs() < 1e-9,
        "only the checkpointed batch 0 survives: {}",
        job.samples_done()
    );
    let w = b.register_worker("b", 1, 0);
    let again = drain(&mut b, &w, 0);
    let expected = if lose_tile.is_some() { 6 * 3 + 1 } else { 6 * 3 };
    assert_eq!(
        again.len(),
        expected,
        "batches 1..3 of each tile are issued again (and the lost tile's batch 0)"
    );
    for g in again.iter().rev() {
        b.complete(&g.lease_id, sums(g, 0.5), 100).unwrap();
    }
    assert_eq!(b.job("j").unwrap().state, JobState::Done);
    frame_bits(&b, "j")
}

#[test]
fn a_job_resumed_from_a_checkpoint_ends_with_the_same_bits() {
    assert_eq!(interrupted(None), undisturbed());
}

#[test]
fn a_tile_whose_checkpoint_is_lost_is_rendered_again_to_the_same_bits() {
    assert_eq!(interrupted(Some(3)), undisturbed());
}

#[test]
fn only_changed_jobs_and_tiles_are_checkpointed() {
    let mut disk = Disk::default();
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 1, 0);
    s.submit(config("j", 8, 0));
    s.submit(config("k", 8, 0));
    assert_eq!(disk.save(&mut s, 0), 2, "new jobs are recorded");
    assert_eq!(disk.save(&mut s, 0), 0, "nothing changed");
    let g = s.lease(&w, 0).unwrap().unwrap();
    s.complete(&g.lease_id, sums(&g, 1.0), 1).unwrap();
    let cps = s.checkpoint(1);
    assert_eq!(cps.len(), 1);
    assert_eq!(cps[0].tiles.len(), 1, "one tile moved on");
    assert_eq!((cps[0].tiles[0].upto, cps[0].tiles[0].previous_upto), (1, 0));
}

#[test]
fn ids_from_before_a_restart_are_unknown_after_it() {
    let mut disk = Disk::default();
    let mut a = Scheduler::with_epoch(TIMEOUT, 3, 1);
    let w = a.register_worker("a", 1, 0);
    a.submit(config("j", 8, 0));
    let g = a.lease(&w, 0).unwrap().unwrap();
    disk.save(&mut a, 0);
    let mut b = disk.boot(2, None);
    let w2 = b.register_worker("b", 1, 0);
    let g2 = b.lease(&w2, 0).unwrap().unwrap();
    assert_ne!(w, w2);
    assert_ne!(g.lease_id, g2.lease_id, "same unit, same counter, different epoch");
    assert!(b.lease(&w, 0).is_err(), "the old worker id must register again");
    assert!(
        matches!(b.complete(&g.lease_id, sums(&g, 1.0), 1), Err(ResultError::Stale(_))),
        "a pre-restart result is ignored"
    );
}

#[test]
fn time_limits_count_render_time_across_restarts() {
    let mut disk = Disk::default();
    let mut a = Scheduler::new(TIMEOUT);
    let w = a.register_worker("a", 1, 0);
    a.submit(JobConfig { time_limit_ms: Some(1000), spp_given: false, ..config("j", 1024, 0) });
    a.lease(&w, 100).unwrap().unwrap();
    disk.save(&mut a, 700);
    let mut b = disk.boot(2, None);
    assert!(b.tick(399).is_empty(), "600 ms used before the restart, 399 after");
    assert_eq!(b.tick(400), vec!["j".to_string()]);
}

#[test]
fn a_paused_job_stays_paused_across_a_restart() {
    let mut disk = Disk::default();
    let mut a = Scheduler::new(TIMEOUT);
    let w = a.register_worker("a", 1, 0);
    a.submit(config("j", 8, 0));
    a.lease(&w, 100).unwrap().unwrap();
    a.set_paused("j", true, 400).unwrap().unwrap();
    disk.save(&mut a, 500);
    let mut b = disk.boot(2, None);
    let w = b.register_worker("a", 1, 0);
    let job = b.job("j").unwrap();
    assert_eq!((job.state, job.elapsed_ms(9_000)), (JobState::Paused, 300));
    assert_eq!(b.lease(&w, 9_000).unwrap(), None, "still paused");
    b.set_paused("j", false, 9_000).unwrap().unwrap();
    assert!(b.lease(&w, 9_001).unwrap().is_some());
}

#[test]
fn a_worker_that_keeps_failing_a_job_is_kept_off_it() {
    let mut s = Scheduler::with_epoch(TIMEOUT, 3, 0);
    let bad = s.register_worker("bad", 1, 0);
    let good = s.register_worker("good", 1, 0);
    s.submit(config("j", 64, 0));
    let mut now = 0;
    for _ in 0..3 {
        assert!(s.lease(&bad, now).unwrap().is_some());
        now += TIMEOUT + 1; // the lease expires: a failure
        s.heartbeat("none", now);
    }
    let job = s.job("j").unwrap();
    assert_eq!(job.failures[&bad].count, 3);
    assert!(s.lease(&bad, now).unwrap().is_none(), "blocked on j");
    assert!(s.lease(&good, now).unwrap().is_some(), "others still get j's units");
    s.submit(config("k", 8, 0));
    let other = s.lease(&bad, now).unwrap().expect("the blocked worker still serves other jobs");
    assert_eq!(other.job_id, "k");
}

/// What a job's status reports of its tiles: samples, noise, dropped samples, largest weight.
fn figures(s: &Scheduler, id: &str) -> (f64, Option<f64>, u64, f64, Option<f64>) {
    let j = s.job(id).unwrap();
    (j.samples_done(), j.noise(), j.dropped(), j.max_weight(), j.frame_noise(0))
}

#[test]
fn released_sums_leave_the_figures_and_their_files_go_once_the_record_says_so() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 1, 0);
    s.submit(config("j", 16, 0));
    assert!(!s.release_sums("j"), "a queued job's sums are its image");
    let mut disk = Disk::default();
    for (i, g) in drain(&mut s, &w, 0).into_iter().enumerate() {
        s.complete(&g.lease_id, sums(&g, 0.5 + (i % 5) as f64), 1).unwrap();
        if i % 7 == 0 {
            disk.save(&mut s, 1);
        }
    }
    assert_eq!(s.job("j").unwrap().state, JobState::Done);
    let before = figures(&s, "j");
    assert!(before.1.unwrap() > 0.0);
    assert!(s.release_sums("j"));
    assert!(s.job("j").unwrap().tiles.iter().all(|t| t.merged.is_empty()));
    assert_eq!(figures(&s, "j"), before, "counts and noise outlive the sums");
    disk.save(&mut s, 2);
    assert!(disk.tiles.is_empty(), "every tile file is replaced by the image");
    assert!(s.checkpoint(3).is_empty(), "nothing left to write or delete");

    let back = disk.boot(1, None);
    let job = back.job("j").unwrap();
    assert_eq!(job.state, JobState::Done, "restored as ended, with no tile to read");
    assert!(job.sums_released());
    assert_eq!(figures(&back, "j"), before);
}

#[test]
fn only_ended_jobs_get_an_end_time_and_it_is_kept_by_checkpoints() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 1, 0);
    s.submit(config("done", 4, 0));
    s.submit(config("later", 4, 0));
    s.note_ended_at("later", 5);
    assert!(s.job("later").unwrap().ended_unix_ms.is_none(), "a queued job has not ended");
    while let Some(g) = s.lease(&w, 0).unwrap().filter(|g| g.job_id == "done") {
        s.complete(&g.lease_id, sums(&g, 0.5), 1).unwrap();
    }
    s.note_ended_at("done", 7);
    s.note_ended_at("done", 9);
    s.cancel("later", 2);
    s.note_ended_at("later", 8);
    assert_eq!(s.ended_by(6), Vec::<String>::new());
    assert_eq!(s.ended_by(8), ["done", "later"], "oldest first; the first stamp kept");
    let mut disk = Disk::default();
    disk.save(&mut s, 3);
    assert_eq!(disk.boot(1, None).ended_by(7), ["done"]);
}
