//! Why a worker given no unit is idle (idle.rs).
use super::super::tests::{config, sums};
use super::super::*;
use tessera_proto::JobState;

const OLD: &str = "tessera 0.1.0 src:aaaaaaaaaaaa libm:00000000";
const NEW: &str = "tessera 0.1.0 src:bbbbbbbbbbbb libm:00000000";

#[test]
fn nothing_to_do_needs_no_reason() {
    let mut s = Scheduler::new(1000);
    let w = s.register("w", 1, OLD, 0);
    assert_eq!(s.lease(&w, 0).unwrap(), None);
    assert_eq!(s.idle_reason(&w, 0), None, "no jobs");
    assert_eq!(s.idle_reason("nobody", 0), None, "unknown worker");
}

#[test]
fn a_worker_of_another_renderer_is_told_which_jobs_and_renderer_hold_it_off() {
    let mut s = Scheduler::new(1000);
    let old = s.register("old", 1, OLD, 0);
    let new = s.register("new", 1, NEW, 0);
    s.submit(config("j", 8, 0));
    s.submit(config("paused", 8, 0));
    s.lease(&old, 0).unwrap().unwrap();
    s.lease(&old, 0).unwrap().unwrap();
    assert_eq!(s.set_paused("paused", true, 0), Some(Ok(JobState::Paused)));
    assert_eq!(s.lease(&new, 1).unwrap(), None);
    let why = s.idle_reason(&new, 1).expect("j has units left");
    assert_eq!(why.pinned, ["j"], "a paused job refuses everyone alike: not this worker's reason");
    assert_eq!(why.renderers.iter().collect::<Vec<_>>(), [OLD]);
    assert!(why.blocklisted.is_empty());
    assert_eq!(
        why.to_string(),
        format!("jobs j are kept on renderer {OLD} while a worker of it is live")
    );
    assert_eq!(s.idle_reason(&old, 1), None, "its own renderer's worker is not refused");
}

#[test]
fn a_blocklisted_worker_is_told_which_jobs_keep_it_off() {
    let mut s = Scheduler::new(1000);
    let w = s.register("w", 1, OLD, 0);
    s.submit(config("j", 8, 0));
    let mut now = 0;
    for _ in 0..Scheduler::DEFAULT_MAX_FAILURES {
        let g = s.lease(&w, now).unwrap().expect("a unit of j");
        let mut wrong = sums(&g, 1.0);
        wrong.samples = [0, 1];
        assert!(s.complete(&g.lease_id, wrong, now + 1).is_err());
        now += 2;
    }
    assert_eq!(s.lease(&w, now).unwrap(), None);
    let why = s.idle_reason(&w, now).expect("j has units left");
    assert_eq!(why.blocklisted, ["j"]);
    assert!(why.pinned.is_empty());
    assert_eq!(why.to_string(), "jobs j keep this worker off after its failures");
}

#[test]
fn a_long_list_of_jobs_names_the_first_few() {
    let why = IdleReason {
        pinned: (1..=8).map(|i| format!("j{i}")).collect(),
        renderers: [OLD.to_owned()].into(),
        blocklisted: vec![],
    };
    assert_eq!(
        why.to_string(),
        format!(
            "jobs j1, j2, j3, j4, j5 and 3 more are kept on renderer {OLD} while a worker of it is live"
        )
    );
}
