//! Pausing and resuming a job.
use super::super::tests::{config, drain, sums};
use super::super::*;

const TIMEOUT: u64 = 1000;

#[test]
fn a_paused_job_is_leased_nothing_while_others_get_the_workers() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 1, 0);
    s.submit(config("held", 8, 5));
    s.submit(config("other", 4, 0));
    assert_eq!(s.set_paused("held", true, 0), Some(Ok(JobState::Paused)));
    let grants = drain(&mut s, &w, 1);
    assert!(
        !grants.is_empty() && grants.iter().all(|g| g.job_id == "other"),
        "the higher-priority job is paused"
    );
    assert_eq!(s.set_paused("held", false, 2), Some(Ok(JobState::Queued)));
    let g = s.lease(&w, 3).unwrap().expect("a unit of the resumed job");
    assert_eq!(g.job_id, "held");
    assert_eq!(s.job("held").unwrap().state, JobState::Running);
}

#[test]
fn units_leased_before_a_pause_finish_and_are_merged() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 1, 0);
    s.submit(config("j", 4, 0));
    let g = s.lease(&w, 0).unwrap().unwrap();
    s.set_paused("j", true, 10).unwrap().unwrap();
    assert_eq!(s.heartbeat(&g.lease_id, 20), Some(TIMEOUT), "the lease stays alive");
    assert!(s.complete(&g.lease_id, sums(&g, 1.0), 30).unwrap().merged);
    let job = s.job("j").unwrap();
    assert_eq!(job.state, JobState::Paused);
    assert!(job.samples_done() > 0.0, "the unit's samples are merged");
    assert_eq!(s.lease(&w, 40).unwrap(), None);
}

#[test]
fn paused_time_is_not_render_time_and_stops_no_time_limit() {
    let mut s = Scheduler::new(TIMEOUT);
    let w = s.register_worker("a", 1, 0);
    s.submit(JobConfig { time_limit_ms: Some(1000), spp_given: false, ..config("j", 1024, 0) });
    s.lease(&w, 100).unwrap().unwrap();
    s.set_paused("j", true, 700).unwrap().unwrap();
    assert!(s.tick(50_000).is_empty(), "600 ms rendered, then paused");
    assert_eq!(s.job("j").unwrap().elapsed_ms(50_000), 600);
    s.set_paused("j", false, 50_000).unwrap().unwrap();
    assert_eq!(s.job("j").unwrap().elapsed_ms(50_100), 600, "the clock waits for the next unit");
    s.lease(&w, 50_100).unwrap().unwrap();
    assert!(s.tick(50_499).is_empty());
    assert_eq!(s.tick(50_500), vec!["j".to_string()], "600 + 400 ms");
}

#[test]
fn an_ended_job_cannot_be_paused_or_resumed_and_a_paused_one_can_be_canceled() {
    let mut s = Scheduler::new(TIMEOUT);
    s.submit(config("a", 4, 0));
    s.submit(config("b", 4, 0));
    s.cancel("a", 0);
    assert_eq!(s.set_paused("a", true, 1), Some(Err(JobState::Canceled)));
    assert_eq!(s.set_paused("a", false, 1), Some(Err(JobState::Canceled)));
    assert_eq!(s.set_paused("nope", true, 1), None);
    assert_eq!(s.set_paused("b", true, 1), Some(Ok(JobState::Paused)));
    assert_eq!(s.set_paused("b", true, 2), Some(Ok(JobState::Paused)), "pausing twice is harmless");
    assert_eq!(s.cancel("b", 3), Some(JobState::Canceled));
    assert_eq!(s.set_paused("b", false, 4), Some(Err(JobState::Canceled)));
}
