use super::*;
use tessera_proto::{JobRequest, Lease, PartialSums, RenderParams, WirePixel};

const TIMEOUT: u64 = 1000;

pub(super) fn config(id: &str, spp: u32, priority: i32) -> JobConfig {
    JobConfig {
        id: id.into(),
        scene_id: "s".into(),
        params: RenderParams {
            width: 10,
            height: 6,
            seed: 1,
            estimator: "mis".into(),
            sampler: "sobol".into(),
            camera: None,
            max_depth: 8,
            roulette_depth: None,
            light_sampler: None,
            background: [0.0; 3],
            animation: None,
            fps: tessera_proto::job::DEFAULT_FPS,
        },
        spp,
        spp_given: true,
        noise_target: None,
        time_limit_ms: None,
        tile_size: 4,
        batch_spp: 4,
        priority,
        effects: vec![],
        request: JobRequest::default(),
        created_unix_ms: 0,
        frames: vec![0],
    }
}

/// Sums for a unit whose every sample has radiance `v` (+ a per-batch wobble so order matters).
pub(super) fn sums(g: &Lease, v: f64) -> PartialSums {
    let n = (g.samples[1] - g.samples[0]) as f64;
    let x = v + g.samples[0] as f64 * 1e-3;
    let p = WirePixel {
        sum: [x * n; 3],
        sum_sq: [x * x * n + 1e-4; 3],
        sum_lum_sq: x * x * n,
        count: n as u64,
    };
    PartialSums {
        tile: g.tile,
        samples: g.samples,
        dropped: 0,
        max_weight: 1.0,
        pixels: vec![p; g.tile.pixel_count()],
    }
}

pub(super) fn drain(s: &mut Scheduler, w: &str, now: u64) -> Vec<Lease> {
    std::iter::from_fn(|| s.lease(w, now).unwrap()).collect()
}

#[test]
fn every_unit_is_leased_once_breadth_first_and_the_job_completes() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 8, 0));
    let grants = drain(&mut s, &w, 0);
    assert_eq!(grants.len(), 6 * 2, "6 tiles × 2 batches");
    assert!(grants[..6].iter().all(|g| g.samples == [0, 4]), "all first batches before any second");
    assert_eq!(s.job("j").unwrap().state, JobState::Running);
    for g in &grants {
        assert!(s.complete(&g.lease_id, sums(g, 1.0), 5).unwrap().merged);
    }
    let job = s.job("j").unwrap();
    assert_eq!(job.state, JobState::Done);
    assert_eq!(job.samples_done(), 8.0);
    assert!(job.frame_sums(0).iter().all(|p| p.count == 8));
}

#[test]
fn an_expired_lease_is_reissued_and_its_late_result_ignored() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 4, 0));
    let first = s.lease(&w, 0).unwrap().unwrap();
    assert_eq!(s.heartbeat(&first.lease_id, 900), Some(TIMEOUT), "heartbeat extends to 1900");
    assert!(s.tick(1899).is_empty());
    s.tick(1900);
    assert_eq!(s.heartbeat(&first.lease_id, 1901), None, "expired");
    let again = s.lease(&w, 1901).unwrap().unwrap();
    assert_eq!((again.tile, again.samples), (first.tile, first.samples), "same unit, same samples");
    assert!(matches!(
        s.complete(&first.lease_id, sums(&first, 1.0), 1902),
        Err(ResultError::Stale(_))
    ));
    assert!(s.complete(&again.lease_id, sums(&again, 1.0), 1903).is_ok());
    assert!(
        matches!(s.complete(&again.lease_id, sums(&again, 1.0), 1904), Err(ResultError::Stale(_))),
        "duplicate"
    );
    assert_eq!(s.job("j").unwrap().tiles[0].merged[0].count, 4, "counted once");
}

#[test]
fn a_mismatched_result_is_refused_and_the_unit_reissued() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 4, 0));
    let g = s.lease(&w, 0).unwrap().unwrap();
    let mut bad = sums(&g, 1.0);
    bad.samples = [4, 8];
    assert!(
        matches!(s.complete(&g.lease_id, bad, 1), Err(ResultError::Malformed(m)) if m.contains("samples"))
    );
    let grants = drain(&mut s, &w, 2);
    assert!(grants.iter().any(|x| x.tile == g.tile && x.samples == g.samples));
    assert_eq!(s.workers().next().unwrap().1.failures, 1);
}

#[test]
fn arrival_order_does_not_change_a_bit_of_the_image() {
    let run = |order: &dyn Fn(Vec<Lease>) -> Vec<Lease>| {
        let mut s = Scheduler::new(TIMEOUT);
        let w = s.register_worker("a", 2, 0);
        s.submit(config("j", 12, 0));
        for g in order(drain(&mut s, &w, 0)) {
            s.complete(&g.lease_id, sums(&g, 0.37), 1).unwrap();
        }
        s.job("j").unwrap().frame_sums(0)
    };
    let forward = run(&|g| g);
    let backward = run(&|mut g| {
        g.reverse();
        g
    });
    let shuffled = run(&|mut g| {
        g.rotate_left(7);
        g.swap(0, 5);
        g
    });
    assert_eq!(forward, backward);
    assert_eq!(forward, shuffled);
}

#[test]
fn cancel_revokes_leases() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 8, 0));
    let g = s.lease(&w, 0).unwrap().unwrap();
    assert_eq!(s.cancel("j", 1), Some(JobState::Canceled));
    assert_eq!(s.heartbeat(&g.lease_id, 2), None);
    assert!(s.lease(&w, 2).unwrap().is_none());
    assert!(matches!(s.complete(&g.lease_id, sums(&g, 1.0), 3), Err(ResultError::Stale(_))));
}

#[test]
fn a_time_limit_ends_the_job_and_revokes_its_leases() {
    let mut s = Scheduler::new(TIMEOUT * 100);
    let w = s.register_worker("a", 2, 0);
    s.submit(JobConfig { time_limit_ms: Some(500), ..config("j", 1024, 0) });
    let g = s.lease(&w, 100).unwrap().unwrap();
    s.complete(&g.lease_id, sums(&g, 1.0), 200).unwrap();
    let held = s.lease(&w, 300).unwrap().unwrap();
    assert_eq!(s.tick(599), Vec::<String>::new());
    assert_eq!(s.tick(600), vec!["j".to_string()], "500 ms after the first lease");
    let job = s.job("j").unwrap();
    assert_eq!((job.state, job.message.as_deref()), (JobState::Done, Some("time limit reached")));
    assert_eq!(s.heartbeat(&held.lease_id, 601), None);
}

#[test]
fn higher_priority_first_then_fair_share() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("low", 8, 0));
    s.submit(config("other", 8, 0));
    s.submit(config("high", 8, 5));
    let jobs: Vec<String> = (0..16).map(|_| s.lease(&w, 0).unwrap().unwrap().job_id).collect();
    assert!(jobs[..12].iter().all(|j| j == "high"), "{jobs:?}");
    assert_eq!(&jobs[12..], ["low", "other", "low", "other"], "equal priorities alternate");
}

#[test]
fn the_extreme_priorities_order_like_any_others() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("lowest", 4, i32::MIN));
    s.submit(config("middle", 4, 0));
    s.submit(config("highest", 4, i32::MAX));
    let jobs: Vec<String> = (0..18).map(|_| s.lease(&w, 0).unwrap().unwrap().job_id).collect();
    let first = |id: &str| jobs.iter().position(|j| j == id).unwrap();
    let last = |id: &str| jobs.iter().rposition(|j| j == id).unwrap();
    assert!(last("highest") < first("middle") && last("middle") < first("lowest"), "{jobs:?}");
}

#[test]
fn a_noise_target_stops_tiles_early_and_deterministically() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(JobConfig { noise_target: Some(1e-3), spp_given: false, ..config("j", 64, 0) });
    let mut leased = 0;
    while let Some(g) = s.lease(&w, 0).unwrap() {
        leased += 1;
        s.complete(&g.lease_id, sums(&g, 1.0), 1).unwrap();
    }
    let job = s.job("j").unwrap();
    assert_eq!(job.state, JobState::Done);
    let min_batches = MIN_SPP_FOR_NOISE_STOP / 4;
    assert_eq!(leased, 6 * min_batches, "each tile stops as soon as it may");
    assert!(job.noise().unwrap() <= 1e-3);
}

#[test]
fn unknown_workers_are_told_so() {
    let mut s = Scheduler::new(TIMEOUT);
    assert!(s.lease("w99", 0).unwrap_err().contains("unknown worker"));
}

#[test]
fn contributions_count_each_workers_units_when_they_merge() {
    let mut s = Scheduler::new(TIMEOUT);
    let a = s.register_worker("alpha", 2, 0);
    let b = s.register_worker("beta", 2, 0);
    s.submit(config("j", 8, 0));
    let first = s.lease(&a, 0).unwrap().unwrap(); // tile 0, batch 0
    let rest = drain(&mut s, &b, 0); // every other unit, including tile 0's batch 1
    let tile0_batch1 = rest.iter().find(|g| g.tile == first.tile).unwrap();
    // Beta's batch 1 of tile 0 arrives first: buffered, not merged, so not yet counted.
    s.complete(&tile0_batch1.lease_id, sums(tile0_batch1, 1.0), 1).unwrap();
    let job = s.job("j").unwrap();
    assert!(job.contributions.is_empty(), "{:?}", job.contributions);
    s.complete(&first.lease_id, sums(&first, 1.0), 2).unwrap();
    let px0 = first.tile.pixel_count() as u64;
    let job = s.job("j").unwrap();
    assert_eq!(job.contributions[&a], ("alpha".to_string(), 4 * px0));
    assert_eq!(
        job.contributions[&b],
        ("beta".to_string(), 4 * px0),
        "credited once batch 0 merged"
    );
    for g in rest.iter().filter(|g| g.lease_id != tile0_batch1.lease_id) {
        s.complete(&g.lease_id, sums(g, 1.0), 3).unwrap();
    }
    let job = s.job("j").unwrap();
    assert_eq!(job.state, JobState::Done);
    let total: u64 = job.contributions.values().map(|c| c.1).sum();
    assert_eq!(total, 8 * job.pixel_count(), "every merged pixel-sample credited exactly once");
    assert_eq!(job.contributions[&a].1, 4 * px0);
}

#[test]
fn units_dropped_unmerged_are_not_credited() {
    let mut s = Scheduler::new(TIMEOUT);
    let a = s.register_worker("alpha", 2, 0);
    s.submit(config("j", 8, 0));
    let grants = drain(&mut s, &a, 0);
    let late = grants.iter().find(|g| g.samples == [4, 8]).unwrap();
    s.complete(&late.lease_id, sums(late, 1.0), 1).unwrap(); // buffered behind batch 0
    s.cancel("j", 2);
    assert!(s.job("j").unwrap().contributions.is_empty());
}

/// A worker may hold two leases (the unit it renders and the next, prefetched): its `current`
/// is the older one until that is done; the units are distinct and both merge.
#[test]
fn a_worker_holding_two_leases_shows_the_older_as_current() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 4, 0));
    let current = |s: &Scheduler| s.workers().next().unwrap().1.current.clone();
    let a = s.lease(&w, 0).unwrap().unwrap();
    let b = s.lease(&w, 1).unwrap().unwrap();
    assert_ne!((a.tile, a.samples), (b.tile, b.samples));
    assert_eq!(current(&s), Some("j/0/0".to_string()));
    assert_eq!(s.workers_on("j"), 1);
    s.complete(&a.lease_id, sums(&a, 1.0), 2).unwrap();
    assert_eq!(
        current(&s),
        Some("j/1/0".to_string()),
        "the prefetched unit is current once the first is done"
    );
    assert!(s.release(&b.lease_id));
    assert_eq!(current(&s), None);
}

/// Two leases of one worker that expire while it is silent count one failure; once it is heard
/// from again, the next expiry counts again.
#[test]
fn leases_expiring_in_one_silence_count_one_failure() {
    let mut s = Scheduler::with_epoch(TIMEOUT, 2, 0);
    let w = s.register_worker("a", 2, 0);
    s.submit(config("j", 64, 0));
    s.lease(&w, 0).unwrap().unwrap();
    let b = s.lease(&w, 0).unwrap().unwrap();
    s.heartbeat(&b.lease_id, 500); // the second lease's deadline is later
    s.tick(TIMEOUT + 1);
    s.tick(TIMEOUT + 501);
    let failures = |s: &Scheduler| {
        (s.workers().next().unwrap().1.failures, s.job("j").unwrap().failures[&w].count)
    };
    assert_eq!(failures(&s), (1, 1), "one silence, one failure");
    assert_eq!(s.workers().next().unwrap().1.current, None);
    let now = TIMEOUT + 502;
    s.lease(&w, now).unwrap().expect("not blocked after one failure");
    s.tick(now + TIMEOUT);
    assert_eq!(failures(&s), (2, 2));
    assert!(s.lease(&w, now + TIMEOUT).unwrap().is_none(), "blocked after two");
}

#[test]
fn a_worker_leaving_hands_its_leases_straight_back() {
    let mut s = Scheduler::new(TIMEOUT);
    let (a, b) = (s.register_worker("a", 2, 0), s.register_worker("b", 2, 0));
    s.submit(config("j", 4, 0));
    let held = [s.lease(&a, 0).unwrap().unwrap(), s.lease(&a, 0).unwrap().unwrap()];
    assert!(s.deregister_worker(&a));
    assert!(!s.deregister_worker(&a), "already gone");
    assert!(s.lease(&a, 1).is_err(), "a is unknown now");
    assert_eq!(s.heartbeat(&held[0].lease_id, 1), None, "its leases are gone");
    assert!(matches!(
        s.complete(&held[1].lease_id, sums(&held[1], 1.0), 1),
        Err(ResultError::Stale(_))
    ));
    // Before any deadline, b gets a's two units back first, in a's order, then the rest.
    let again = drain(&mut s, &b, 1);
    assert_eq!(again.len(), 6, "every unit once");
    assert_eq!(
        again[..2].iter().map(|g| g.tile).collect::<Vec<_>>(),
        held.iter().map(|g| g.tile).collect::<Vec<_>>()
    );
    assert_eq!(
        s.workers().map(|(id, w)| (id.clone(), w.failures)).collect::<Vec<_>>(),
        [(b, 0)],
        "a is forgotten, b blamed for nothing"
    );
}
mod durable;
mod frames;
mod history;
mod idle;
mod numerics;
mod pause;
mod renderers;
