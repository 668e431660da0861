//! Keeping a job on the renderer of its workers (renderers.rs).
use super::super::renderers::LIVE_WITHIN_MS;
use super::super::tests::{config, drain, sums};
use super::super::*;

const TIMEOUT: u64 = 1000;
const OLD: &str = "tessera 0.1.0 src:aaaaaaaaaaaa libm:00000000";
const NEW: &str = "tessera 0.1.0 src:bbbbbbbbbbbb libm:00000000";

/// A scheduler with a worker of each renderer, "old" and "new".
fn farm_of_two_renderers() -> (Scheduler, String, String) {
    let mut s = Scheduler::new(TIMEOUT);
    let old = s.register("old", 1, OLD, 0);
    let new = s.register("new", 1, NEW, 0);
    (s, old, new)
}

#[test]
fn a_worker_of_another_renderer_gets_other_jobs_and_never_this_ones_units() {
    let (mut s, old, new) = farm_of_two_renderers();
    s.submit(config("first", 8, 5));
    s.submit(config("second", 8, 0));
    let g = s.lease(&old, 0).unwrap().unwrap();
    assert_eq!(g.job_id, "first");
    let grants = drain(&mut s, &new, 1);
    assert!(!grants.is_empty(), "the second job is open to it");
    assert!(
        grants.iter().all(|g| g.job_id == "second"),
        "the first job has a unit leased to the old renderer"
    );
    assert!(s.complete(&g.lease_id, sums(&g, 1.0), 2).unwrap().merged);
    for g in &grants {
        s.complete(&g.lease_id, sums(g, 1.0), 3).unwrap();
    }
    assert_eq!(s.job("first").unwrap().renderers, [OLD]);
    assert_eq!(s.job("second").unwrap().renderers, [NEW]);
    assert_eq!(
        s.lease(&new, 4).unwrap(),
        None,
        "the old worker is live: the first job waits for it"
    );
    let rest = drain(&mut s, &old, 5);
    assert!(rest.iter().all(|g| g.job_id == "first") && !rest.is_empty());
}

#[test]
fn workers_of_one_renderer_share_a_job() {
    let mut s = Scheduler::new(TIMEOUT);
    let a = s.register("a", 1, OLD, 0);
    let b = s.register("b", 1, OLD, 0);
    s.submit(config("j", 8, 0));
    s.lease(&a, 0).unwrap().unwrap();
    assert_eq!(s.lease(&b, 0).unwrap().unwrap().job_id, "j");
}

#[test]
fn once_its_renderer_has_no_live_worker_another_goes_on_and_the_job_names_both() {
    let (mut s, old, new) = farm_of_two_renderers();
    s.submit(config("j", 8, 0));
    let g = s.lease(&old, 0).unwrap().unwrap();
    s.complete(&g.lease_id, sums(&g, 1.0), 10).unwrap();
    assert_eq!(
        s.lease(&new, 10 + LIVE_WITHIN_MS).unwrap(),
        None,
        "heard from {LIVE_WITHIN_MS} ms ago: live"
    );
    let g = s.lease(&new, 11 + LIVE_WITHIN_MS).unwrap().expect("the old worker has gone quiet");
    s.complete(&g.lease_id, sums(&g, 1.0), 12 + LIVE_WITHIN_MS).unwrap();
    assert_eq!(s.job("j").unwrap().renderers, [OLD, NEW]);
    assert!(
        s.lease(&old, 13 + LIVE_WITHIN_MS).unwrap().is_some(),
        "the job has both now: both may go on"
    );
}

#[test]
fn a_worker_that_left_leaves_the_job_to_the_others_at_once() {
    let (mut s, old, new) = farm_of_two_renderers();
    s.submit(config("j", 8, 0));
    s.lease(&old, 0).unwrap().unwrap();
    assert_eq!(s.lease(&new, 1).unwrap(), None);
    assert!(s.deregister_worker(&old));
    let g = s.lease(&new, 2).unwrap().expect("no worker of the job's renderer is left");
    assert_eq!(g.job_id, "j");
    s.complete(&g.lease_id, sums(&g, 1.0), 3).unwrap();
    assert_eq!(s.job("j").unwrap().renderers, [NEW], "the old unit was given back, never merged");
}

#[test]
fn a_restarted_coordinator_keeps_a_job_on_its_renderer() {
    let mut s = Scheduler::new(TIMEOUT);
    let old = s.register("old", 1, OLD, 0);
    s.submit(config("j", 8, 0));
    let g = s.lease(&old, 0).unwrap().unwrap();
    s.complete(&g.lease_id, sums(&g, 1.0), 1).unwrap();
    let rec = s.record_of("j", 2).unwrap();
    let mut s = Scheduler::with_epoch(TIMEOUT, Scheduler::DEFAULT_MAX_FAILURES, 1);
    s.restore(rec, 0, |_, _, _| None);
    assert_eq!(s.job("j").unwrap().renderers, [OLD]);
    let old = s.register("old", 1, OLD, 0);
    let new = s.register("new", 1, NEW, 0);
    assert_eq!(s.lease(&new, 1).unwrap(), None);
    assert!(s.lease(&old, 1).unwrap().is_some());
}

#[test]
fn with_mixing_allowed_every_worker_gets_units_and_the_job_names_both() {
    let (mut s, old, new) = farm_of_two_renderers();
    s.set_mix_renderers(true);
    s.submit(config("j", 8, 0));
    let a = s.lease(&old, 0).unwrap().unwrap();
    let b = s.lease(&new, 0).unwrap().expect("not refused");
    s.complete(&a.lease_id, sums(&a, 1.0), 1).unwrap();
    s.complete(&b.lease_id, sums(&b, 1.0), 1).unwrap();
    assert_eq!(s.job("j").unwrap().renderers, [OLD, NEW]);
}

#[test]
fn a_renderer_whose_only_worker_is_blocked_from_the_job_does_not_hold_it() {
    let (mut s, old, new) = farm_of_two_renderers();
    s.submit(config("j", 8, 0));
    let g = s.lease(&old, 0).unwrap().unwrap();
    s.complete(&g.lease_id, sums(&g, 1.0), 1).unwrap();
    assert_eq!(s.lease(&new, 1).unwrap(), None, "the job has the old renderer");
    let mut now = 2;
    for _ in 0..Scheduler::DEFAULT_MAX_FAILURES {
        let g = s.lease(&old, now).unwrap().expect("a unit of j");
        let mut wrong = sums(&g, 1.0);
        wrong.samples = [0, 1];
        assert!(matches!(s.complete(&g.lease_id, wrong, now + 1), Err(ResultError::Malformed(_))));
        now += 2;
    }
    assert!(s.job("j").unwrap().is_blocked(&old, Scheduler::DEFAULT_MAX_FAILURES));
    let g = s.lease(&new, now).unwrap().expect("the old worker is live but kept off the job");
    assert_eq!(g.job_id, "j");
}
