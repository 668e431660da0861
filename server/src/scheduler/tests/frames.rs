//! Jobs of several animation frames: unit numbering, frame affinity, spreading, time limits.
use super::super::tests::{config, drain, sums};
use super::super::*;
use tessera_proto::FrameRange;

const TIMEOUT: u64 = 1000;
/// `config` makes 10×6 frames of 4×4 tiles: 6 tiles per frame, 2 batches of 4 spp each.
const TILES: usize = 6;

fn animation(id: &str, frames: &[u32]) -> JobConfig {
    let mut cfg = config(id, 8, 0);
    cfg.frames = frames.to_vec();
    cfg.request.frames =
        Some(FrameRange { start: frames[0], end: *frames.last().unwrap(), step: None, fps: None });
    cfg
}

#[test]
fn every_frame_gets_every_unit_and_leases_name_their_frame() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(animation("j", &[10, 12, 14]));
    let grants = drain(&mut s, &w, 0);
    assert_eq!(grants.len(), 3 * TILES * 2);
    for f in [10, 12, 14] {
        assert_eq!(grants.iter().filter(|g| g.frame == f).count(), TILES * 2, "frame {f}");
    }
    for g in &grants {
        s.complete(&g.lease_id, sums(g, f64::from(g.frame)), 1).unwrap();
    }
    let job = s.job("j").unwrap();
    assert_eq!(job.state, JobState::Done);
    for (i, f) in [10.0, 12.0, 14.0].into_iter().enumerate() {
        assert!(job.frame_complete(i));
        assert_eq!(job.frame_samples_done(i), 8.0);
        // Each frame holds its own results only (the sums carry the frame number as radiance).
        let px = job.frame_sums(i);
        assert!(px.iter().all(|p| p.count == 8 && (p.sum[0] / 8.0 - f).abs() < 0.01), "frame {f}");
    }
    assert_eq!(job.samples_done(), 8.0);
}

#[test]
fn a_worker_keeps_its_frame_and_a_newcomer_takes_a_free_one() {
    let mut s = Scheduler::new(TIMEOUT);
    let a = s.register_worker("a", 2, 0);
    let b = s.register_worker("b", 2, 0);
    s.submit(animation("j", &[0, 1, 2]));
    let first_a = s.lease(&a, 0).unwrap().unwrap();
    let first_b = s.lease(&b, 0).unwrap().unwrap();
    assert_eq!(first_a.frame, 0);
    assert_eq!(first_b.frame, 1, "b takes the frame nobody is on");
    // Each worker now finishes units and asks again: it stays on its frame while it has units.
    let (mut la, mut lb) = (first_a, first_b);
    for now in 1..(TILES as u64 * 2) {
        s.complete(&la.lease_id, sums(&la, 1.0), now).unwrap();
        s.complete(&lb.lease_id, sums(&lb, 1.0), now).unwrap();
        la = s.lease(&a, now).unwrap().unwrap();
        lb = s.lease(&b, now).unwrap().unwrap();
        assert_eq!((la.frame, lb.frame), (0, 1), "unit {now}");
    }
    // Frame 0 is fully issued: a moves on to the frame nobody holds.
    s.complete(&la.lease_id, sums(&la, 1.0), 50).unwrap();
    assert_eq!(s.lease(&a, 50).unwrap().unwrap().frame, 2);
}

#[test]
fn without_affinity_units_go_out_frame_by_frame() {
    let mut s = Scheduler::new(TIMEOUT);
    s.set_frame_affinity(false);
    let a = s.register_worker("a", 2, 0);
    let b = s.register_worker("b", 2, 0);
    s.submit(animation("j", &[0, 1, 2]));
    let ga = s.lease(&a, 0).unwrap().unwrap();
    let gb = s.lease(&b, 0).unwrap().unwrap();
    assert_eq!((ga.frame, gb.frame), (0, 0), "both on the first frame with units");
    let rest = drain(&mut s, &a, 1);
    let frames: Vec<u32> = rest.iter().map(|g| g.frame).collect();
    assert!(frames.is_sorted(), "frame-major order: {frames:?}");
}

#[test]
fn a_time_limited_job_refines_every_frame_before_any_frame_gets_more() {
    let mut s = Scheduler::new(TIMEOUT);
    let a = s.register_worker("a", 2, 0);
    let mut cfg = animation("j", &[0, 1, 2]);
    cfg.time_limit_ms = Some(60_000);
    s.submit(cfg);
    let grants = drain(&mut s, &a, 0);
    let first_round = &grants[..3 * TILES];
    assert!(first_round.iter().all(|g| g.samples == [0, 4]), "batch 0 of every frame first");
    assert!(grants[3 * TILES..].iter().all(|g| g.samples == [4, 8]));
    // Within the round the worker still stays on one frame at a time.
    let frames: Vec<u32> = first_round.iter().map(|g| g.frame).collect();
    assert!(frames.is_sorted(), "{frames:?}");
}

#[test]
fn scene_preparation_reports_add_up_per_frame() {
    let mut s = Scheduler::new(TIMEOUT);
    let a = s.register_worker("a", 2, 0);
    s.submit(animation("j", &[0, 1]));
    let grants = drain(&mut s, &a, 0);
    for g in &grants {
        let kind = if g.frame == 0 { PrepareKind::Build } else { PrepareKind::Refit };
        s.note_prepare(&g.lease_id, kind, 2.5);
        s.complete(&g.lease_id, sums(g, 1.0), 1).unwrap();
    }
    s.note_prepare("no-such-lease", PrepareKind::Build, 1.0);
    let job = s.job("j").unwrap();
    assert_eq!(
        job.prepare[0],
        FramePrepare {
            builds: (TILES * 2) as u32,
            refits: 0,
            ms: 2.5 * (TILES * 2) as f64,
            peak_rss_bytes: 0
        }
    );
    assert_eq!(job.prepare[1].refits, (TILES * 2) as u32);
}

#[test]
fn a_frame_keeps_the_largest_peak_and_a_worker_its_latest_report() {
    let mut s = Scheduler::new(TIMEOUT);
    let a = s.register_worker("a", 2, 0);
    s.submit(animation("j", &[0, 1]));
    let grants = drain(&mut s, &a, 0);
    let frame0: Vec<_> = grants.iter().filter(|g| g.frame == 0).collect();
    s.note_memory(&frame0[0].lease_id, ProcessMemory { rss_bytes: 10, peak_rss_bytes: 40 });
    // A resident set above the reported peak (a report read between two kernel updates)
    // raises the peak to it.
    s.note_memory(&frame0[1].lease_id, ProcessMemory { rss_bytes: 50, peak_rss_bytes: 30 });
    s.note_memory("no-such-lease", ProcessMemory { rss_bytes: 1 << 40, peak_rss_bytes: 1 << 40 });
    let job = s.job("j").unwrap();
    assert_eq!((job.prepare[0].peak_rss_bytes, job.prepare[1].peak_rss_bytes), (50, 0));
    let (_, w) = s.workers().find(|(id, _)| **id == a).unwrap();
    assert_eq!(w.memory, Some(ProcessMemory { rss_bytes: 50, peak_rss_bytes: 50 }));
}

#[test]
fn frames_arrive_in_any_order_with_the_same_bits() {
    let run = |reverse: bool| {
        let mut s = Scheduler::new(TIMEOUT);
        let w = s.register_worker("a", 2, 0);
        s.submit(animation("j", &[3, 4]));
        let mut grants = drain(&mut s, &w, 0);
        if reverse {
            grants.reverse();
        }
        for g in grants {
            s.complete(&g.lease_id, sums(&g, 0.3 + f64::from(g.frame)), 1).unwrap();
        }
        let job = s.job("j").unwrap();
        (0..2)
            .map(|i| job.frame_sums(i).iter().map(|p| p.sum[0].to_bits()).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    };
    assert_eq!(run(false), run(true));
}
