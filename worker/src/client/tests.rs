//! The worker loop against a mock coordinator (axum on 127.0.0.1:0) that serves the bundled
//! furnace scene, hands out a scripted sequence of answers and records what the worker sends.
use super::*;
use tessera_proto::{PartialSums, RenderParams, TileRect};
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::render_tile;
use tokio::sync::oneshot;

mod mock;
use mock::{Mock, Step, serve_on, start};

const TOKEN: &str = "s3cret";
const SCENE_ID: &str = "furnace";
const SLOW_RESULT: Duration = Duration::from_millis(500);

const ANIMATED_ID: &str = "cornell-animated";

fn animated_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-animated.gltf")
}

fn furnace_path() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/furnace.gltf")
}

fn config(base: &str) -> WorkerConfig {
    WorkerConfig {
        coordinator: base.into(),
        token: Some(TOKEN.into()),
        threads: 2,
        name: "test-worker".into(),
    }
}

/// A running worker and the switch that shuts it down.
struct Running {
    shutdown: Option<oneshot::Sender<()>>,
    task: JoinHandle<anyhow::Result<WorkerReport>>,
}

fn spawn_worker(base: &str) -> Running {
    let (tx, rx) = oneshot::channel::<()>();
    let task = tokio::spawn(run(config(base), async move {
        let _ = rx.await;
    }));
    Running { shutdown: Some(tx), task }
}

impl Running {
    /// Requests shutdown; returns the report and how long `run` took to return.
    async fn stop(mut self, limit: Duration) -> (WorkerReport, Duration) {
        let t0 = Instant::now();
        self.shutdown.take().unwrap().send(()).unwrap();
        let report = tokio::time::timeout(limit, self.task)
            .await
            .expect("run returns after shutdown")
            .unwrap()
            .unwrap();
        (report, t0.elapsed())
    }
}

async fn wait_until(what: &str, limit: Duration, mut done: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !done() {
        assert!(t0.elapsed() < limit, "timed out waiting until {what}");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

fn params(width: u32, height: u32) -> RenderParams {
    RenderParams {
        width,
        height,
        seed: 11,
        estimator: "mis".into(),
        sampler: "sobol".into(),
        camera: None,
        max_depth: 64,
        roulette_depth: None,
        light_sampler: None,
        background: [0.0; 3],
        animation: None,
        fps: tessera_proto::job::DEFAULT_FPS,
    }
}

fn unit(id: &str, params: RenderParams, tile: TileRect, samples: [u32; 2]) -> Step {
    Step::Lease(Box::new(Lease {
        lease_id: id.into(),
        job_id: "job-1".into(),
        scene_id: SCENE_ID.into(),
        params,
        frame: 0,
        tile,
        samples,
        deadline_ms: 30_000,
    }))
}

/// A small unit of a 16×8 image (cheap to render).
fn small(id: &str, x0: u32, samples: [u32; 2]) -> Step {
    unit(id, params(16, 8), TileRect { x0, y0: 0, w: 8, h: 8 }, samples)
}

/// A unit far too long to finish during a test (a column of 1×50000 pixels × 2048 samples, minutes of work),
/// whose rows are short so cancellation (checked between rows) is quick.
fn long(id: &str) -> Step {
    unit(id, params(1, 50_000), TileRect { x0: 0, y0: 0, w: 1, h: 50_000 }, [0, 2048])
}

/// Checks an uploaded body against `render_tile` of the same unit, bit for bit.
fn assert_bit_exact(body: &[u8], step_params: &RenderParams) {
    let got = PartialSums::decode(body).expect("the upload decodes");
    let scene = tessera_render::scene::load_path(&furnace_path()).unwrap();
    let settings = render_settings(step_params).unwrap();
    let expected = render_tile(
        &scene,
        &settings,
        convert::tile(got.tile),
        got.samples[0]..got.samples[1],
        &RenderOptions::default(),
    )
    .unwrap();
    assert_eq!(
        body,
        to_wire(&expected, got.samples).encode().as_slice(),
        "upload for {:?} {:?}",
        got.tile,
        got.samples
    );
}

#[test]
fn run_is_send() {
    fn assert_send<T: Send>(_: &T) {}
    let f = run(config("http://127.0.0.1:1"), std::future::pending());
    assert_send(&f);
}

#[tokio::test]
async fn refuses_a_bad_coordinator_address() {
    for bad in ["not a url", "https://example.com", "ftp://example.com"] {
        let mut c = config(bad);
        c.coordinator = bad.into();
        assert!(run(c, async {}).await.is_err(), "{bad}");
    }
}

/// (1) All leases are rendered and uploaded bit-exactly; the scene is downloaded once; a 409
/// on a result counts as stale; every request carries the token. Uploads overlap the next
/// lease, one at a time.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn renders_every_lease_bit_exactly_with_one_scene_download() {
    let mock = Mock::new(
        3000,
        vec![
            small("a", 0, [0, 4]),
            small("b", 8, [0, 4]),
            small("c", 0, [4, 9]),
            small("d", 8, [4, 6]),
        ],
    );
    mock.log().stale_results.insert("d".into());
    mock.log().slow_results.insert("a".into());
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("four results arrive", Duration::from_secs(30), || mock.log().results.len() == 4)
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(
        report,
        WorkerReport {
            units_done: 3,
            units_stale: 1,
            units_canceled: 0,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    let log = mock.log();
    let ids: Vec<&str> = log.results.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(ids, ["a", "b", "c", "d"]);
    // "a"'s upload answers after 500 ms; meanwhile the worker already leased (and rendered) "b",
    // but waited for "a"'s upload to end before uploading "b".
    let a_sent = log.results[0].3;
    assert!(
        log.lease_requests[1].0 < a_sent + SLOW_RESULT,
        "the next lease is requested during the upload"
    );
    assert!(log.results[1].3 >= a_sent + SLOW_RESULT, "one upload at a time");
    for (_, content_type, body, _) in &log.results {
        assert_eq!(content_type, tessera_proto::sums::CONTENT_TYPE);
        assert_bit_exact(body, &params(16, 8));
    }
    assert_eq!(log.scene_downloads, 1, "the scene is cached across leases");
    assert_eq!((log.registrations, log.unauthorized), (1, 0));
    assert!(log.released.is_empty());
}

/// (2) A 409 on a heartbeat cancels a long unit: the render stops and the worker goes on with
/// the next unit (prefetched meanwhile) well within a second.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_409_heartbeat_cancels_a_long_unit_quickly() {
    // Heartbeats every 100 ms. Once "long" renders (the worker prefetches the next lease as it
    // starts a unit, so the third lease request means "long" is in hand), its heartbeats answer 409.
    let mock =
        Mock::new(300, vec![small("warm", 0, [0, 2]), long("long"), small("next", 8, [0, 2])]);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("\"long\" is in hand", Duration::from_secs(30), || {
        mock.log().lease_requests.len() >= 3
    })
    .await;
    mock.log().kill_on_heartbeat.insert("long".into());
    wait_until("the next unit's result arrives", Duration::from_secs(30), || {
        mock.log().results.len() == 2
    })
    .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(
        report,
        WorkerReport {
            units_done: 2,
            units_stale: 0,
            units_canceled: 1,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    let log = mock.log();
    let killed = log.killed_at.expect("a heartbeat was refused");
    let reaction = log.results[1].3 - killed;
    assert!(
        reaction < Duration::from_secs(1),
        "the next unit's result came {reaction:?} after the 409"
    );
    let ids: Vec<&str> = log.results.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(ids, ["warm", "next"], "the canceled unit is never uploaded");
    assert_bit_exact(&log.results[1].2, &params(16, 8));
    assert_eq!(
        log.heartbeats.iter().filter(|h| h.1 == "long" && h.0 >= killed).count(),
        1,
        "no heartbeats after the 409"
    );
    assert!(log.released.is_empty(), "a lost lease is dropped, not released");
}

/// (3) 204 (no work) is polled again with a backoff, and work is picked up when it comes.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn polls_through_204_and_picks_up_work() {
    let mock =
        Mock::new(3000, vec![Step::NoWork, Step::NoWork, Step::NoWork, small("a", 0, [0, 2])]);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("the result arrives", Duration::from_secs(30), || mock.log().results.len() == 1)
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(report.units_done, 1);
    let log = mock.log();
    assert!(log.lease_requests.len() >= 4);
    // Not a busy loop: the polls after a 204 are spaced by the (jittered, ≥ 25 ms) backoff.
    for pair in log.lease_requests[..4].windows(2) {
        assert!(
            pair[1].0 - pair[0].0 >= Duration::from_millis(20),
            "polled again after {:?}",
            pair[1].0 - pair[0].0
        );
    }
    assert_bit_exact(&log.results[0].2, &params(16, 8));
}

/// (4) The coordinator is down when the worker starts; the worker keeps retrying, then
/// registers and works once it is up.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn waits_for_a_coordinator_that_is_down_at_start() {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let base = format!("http://127.0.0.1:{port}");
    let worker = spawn_worker(&base);
    tokio::time::sleep(Duration::from_millis(800)).await; // several refused registrations

    let mock = Mock::new(3000, vec![small("a", 0, [0, 2])]);
    let listener =
        tokio::net::TcpListener::bind(("127.0.0.1", port)).await.expect("the port is still free");
    serve_on(mock.clone(), listener).await;
    wait_until("the result arrives", Duration::from_secs(30), || mock.log().results.len() == 1)
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(report.units_done, 1);
    assert_eq!(mock.log().registrations, 1);
}

/// (5) A 404 on /v1/leases (the coordinator forgot the worker) makes it register again.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn reregisters_after_a_404_on_lease() {
    let mock = Mock::new(3000, vec![small("a", 0, [0, 2]), Step::Forget, small("b", 8, [0, 2])]);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("both results arrive", Duration::from_secs(30), || mock.log().results.len() == 2)
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(report.units_done, 2);
    let log = mock.log();
    assert_eq!(log.registrations, 2);
    let workers: Vec<&str> = log.lease_requests.iter().map(|r| r.1.as_str()).collect();
    assert_eq!(&workers[..3], ["w1", "w1", "w2"], "leases are requested as w2 after the 404");
}

/// A worker registers with its protocol version and renderer id; a coordinator that speaks
/// another version refuses it, and the worker stops with that refusal at once instead of
/// retrying or leasing units it could misread.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_coordinator_of_another_protocol_version_refuses_the_worker_which_stops_saying_why() {
    let mock = Mock::new(3000, vec![small("a", 0, [0, 2])]);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("the result arrives", Duration::from_secs(30), || mock.log().results.len() == 1)
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;
    assert_eq!(report.units_done, 1);
    assert_eq!(
        mock.log().renderers,
        [tessera_render::renderer_id()],
        "registered with its renderer id"
    );

    let newer = Mock::new(3000, vec![small("a", 0, [0, 2])]);
    newer.log().speaks_protocols =
        Some(tessera_proto::PROTOCOL_VERSION + 1..=tessera_proto::PROTOCOL_VERSION + 1);
    let base = start(&newer).await;
    let (_tx, rx) = oneshot::channel::<()>();
    let outcome = tokio::time::timeout(
        Duration::from_secs(10),
        run(config(&base), async move {
            let _ = rx.await;
        }),
    )
    .await
    .expect("a refused worker stops by itself");
    let err = outcome.expect_err("a refused registration is an error").to_string();
    assert!(err.contains("refused to register") && err.contains("worker protocol 1"), "{err}");
    assert_eq!(newer.log().registrations, 0);
    assert!(newer.log().lease_requests.is_empty(), "no lease is asked for");
}

/// (6) Shutdown while idle (204s) returns promptly, as does shutdown while the coordinator is
/// unreachable and registration keeps failing.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_while_idle_returns_promptly() {
    let mock = Mock::new(3000, vec![]);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("the worker polls", Duration::from_secs(10), || {
        mock.log().lease_requests.len() >= 3
    })
    .await;
    let (report, took) = worker.stop(Duration::from_secs(5)).await;
    assert_eq!(report, WorkerReport::default());
    assert!(took < Duration::from_secs(1), "idle shutdown took {took:?}");
    assert_eq!(
        mock.log().deregistered.iter().map(|d| d.1.as_str()).collect::<Vec<_>>(),
        ["w1"],
        "it said it was leaving"
    );

    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port();
    let worker = spawn_worker(&format!("http://127.0.0.1:{port}"));
    tokio::time::sleep(Duration::from_millis(400)).await;
    let (report, took) = worker.stop(Duration::from_secs(5)).await;
    assert_eq!(report, WorkerReport::default());
    assert!(took < Duration::from_secs(1), "shutdown while unregistered took {took:?}");
}

/// Shutdown during a unit that cannot finish within the grace: it is canceled and its lease
/// given back (DELETE), and `run` returns soon after the grace.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_gives_back_an_unfinished_unit() {
    let mock = Mock::new(300, vec![small("warm", 0, [0, 2]), long("long")]);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("the long unit is rendering", Duration::from_secs(30), || {
        mock.log().heartbeats.iter().any(|h| h.1 == "long")
    })
    .await;
    let (report, took) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(
        report,
        WorkerReport {
            units_done: 1,
            units_stale: 0,
            units_canceled: 1,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    assert!(took < SHUTDOWN_GRACE + Duration::from_secs(2), "shutdown took {took:?}");
    let log = mock.log();
    assert_eq!(log.released, ["long"]);
    assert_eq!(log.results.len(), 1, "only the warm-up unit is uploaded");
}

/// Shutdown during a unit that finishes within the grace: it is uploaded, not given back.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_lets_the_unit_in_hand_finish_within_the_grace() {
    // 8×8 pixels × 512 samples: tens of milliseconds, within the 2 s grace even on a loaded machine.
    let mock = Mock::new(300, vec![small("warm", 0, [0, 2]), small("in-hand", 8, [0, 512])]);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    // The third request is the prefetch started as "in-hand" began.
    wait_until("the second unit is in hand", Duration::from_secs(30), || {
        mock.log().lease_requests.len() >= 3
    })
    .await;
    let stopped_at = Instant::now();
    let (report, _) = worker.stop(Duration::from_secs(15)).await;

    assert_eq!(
        report,
        WorkerReport {
            units_done: 2,
            units_stale: 0,
            units_canceled: 0,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    let log = mock.log();
    let ids: Vec<&str> = log.results.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(ids, ["warm", "in-hand"]);
    assert!(log.released.is_empty());
    let last_upload = log.results.iter().map(|r| r.3).max().unwrap();
    assert!(
        matches!(&log.deregistered[..], [(at, id)] if id == "w1" && *at >= last_upload),
        "deregistered once, after its last upload"
    );
    // (A poll issued just as the test asked for shutdown may land a moment later.)
    assert!(
        log.lease_requests.iter().all(|r| r.0 < stopped_at + Duration::from_millis(50)),
        "no new lease request after shutdown"
    );
}

/// A result upload that fails with 503 is retried until it is merged.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn retries_a_failing_upload() {
    let mock = Mock::new(3000, vec![small("a", 0, [0, 2])]);
    mock.log().failing_results = 2;
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("the third attempt arrives", Duration::from_secs(30), || {
        mock.log().results.len() == 3
    })
    .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(
        report,
        WorkerReport {
            units_done: 1,
            units_stale: 0,
            units_canceled: 0,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    let log = mock.log();
    assert!(log.results.iter().all(|r| r.0 == "a" && r.2 == log.results[0].2));
    assert_bit_exact(&log.results[2].2, &params(16, 8));
}

/// Leases that cannot be worked (unknown scene, bad parameters) are given back and the worker
/// carries on with the next one.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn gives_back_leases_it_cannot_work() {
    let Step::Lease(mut missing) = small("missing-scene", 0, [0, 2]) else { unreachable!() };
    missing.scene_id = "no-such-scene".into();
    let Step::Lease(mut bad) = small("bad-params", 0, [0, 2]) else { unreachable!() };
    bad.params.estimator = "magic".into();
    let mock =
        Mock::new(3000, vec![Step::Lease(missing), Step::Lease(bad), small("good", 8, [0, 2])]);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("the good result arrives", Duration::from_secs(30), || {
        mock.log().results.len() == 1
    })
    .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(report.units_done, 1);
    let log = mock.log();
    assert_eq!(log.released, ["missing-scene", "bad-params"]);
    assert_eq!(log.results[0].0, "good");
}

/// A wrong token is a configuration error: `run` fails instead of retrying forever.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_wrong_token_is_an_error() {
    let mock = Mock::new(3000, vec![]);
    let base = start(&mock).await;
    let mut c = config(&base);
    c.token = Some("wrong".into());
    let e = tokio::time::timeout(Duration::from_secs(10), run(c, std::future::pending()))
        .await
        .unwrap()
        .unwrap_err();
    assert!(e.to_string().contains("missing or wrong token"), "{e}");
}

/// Frames of an animated scene: the file is downloaded once; a new frame refits the BVH of
/// the last one, a frame seen before comes from the cache; the upload says which, and every
/// frame is rendered bit-exactly like the frame alone (with its frame seed).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn frames_of_an_animation_refit_and_report_how_their_scene_was_prepared() {
    let frame = |id: &str, n: u32| {
        let Step::Lease(mut l) = small(id, 0, [0, 2]) else { unreachable!() };
        l.scene_id = ANIMATED_ID.into();
        l.frame = n;
        Step::Lease(l)
    };
    let mock = Mock::new(
        3000,
        vec![
            frame("f0", 0),
            frame("f3", 3),
            frame("f3-again", 3),
            frame("f1", 1),
            small("still", 0, [0, 2]),
        ],
    );
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("five results arrive", Duration::from_secs(60), || mock.log().results.len() == 5)
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(report.units_done, 5);
    let log = mock.log();
    let how: Vec<(&str, &str)> =
        log.prepared.iter().map(|(id, how, _)| (id.as_str(), how.as_str())).collect();
    assert_eq!(
        how,
        [
            ("f0", "build"),
            ("f3", "refit"),
            ("f3-again", "cached"),
            ("f1", "refit"),
            ("still", "build")
        ]
    );
    for (id, how, ms) in &log.prepared {
        assert!(
            if how == "cached" { *ms == 0.0 } else { *ms > 0.0 && ms.is_finite() },
            "{id}: {how} in {ms} ms"
        );
    }
    assert_eq!(log.scene_downloads, 2, "each file once");
    #[cfg(target_os = "linux")]
    for (rss, peak) in &log.memory {
        let (rss, peak): (u64, u64) = (
            rss.parse().expect("x-tessera-rss in bytes"),
            peak.parse().expect("x-tessera-peak-rss in bytes"),
        );
        assert!(rss > 0 && peak >= rss, "the process's resident set {rss} and peak {peak}");
    }
    let seq =
        tessera_render::scene::Sequence::parse(&std::fs::read(animated_path()).unwrap(), None)
            .unwrap();
    for ((id, _, body, _), n) in log.results.iter().zip([0u32, 3, 3, 1]) {
        let got = PartialSums::decode(body).unwrap();
        let scene = seq.scene_at(Some(0), f64::from(n) / 24.0).unwrap();
        let mut settings = render_settings(&params(16, 8)).unwrap();
        settings.seed = tessera_render::tracer::sampler::frame_seed(settings.seed, n);
        let expected = render_tile(
            &scene,
            &settings,
            convert::tile(got.tile),
            0..2,
            &RenderOptions::default(),
        )
        .unwrap();
        assert_eq!(body, &to_wire(&expected, got.samples).encode(), "{id}");
    }
}

/// The next lease is requested as a unit starts, before its result is uploaded, and rendered
/// right after it; every unit is still uploaded bit-exactly, in lease order.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn requests_the_next_lease_while_a_unit_renders() {
    // "a" is as long as "b" (256 samples) so that the prefetch's request, sent as it starts, is
    // not overtaken by its result on a loaded machine.
    let mock = Mock::new(
        3000,
        vec![small("a", 0, [0, 256]), small("b", 8, [0, 256]), small("c", 0, [256, 258])],
    );
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("three results arrive", Duration::from_secs(30), || mock.log().results.len() == 3)
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(
        report,
        WorkerReport {
            units_done: 3,
            units_stale: 0,
            units_canceled: 0,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    assert!(report.busy > Duration::ZERO);
    let log = mock.log();
    let ids: Vec<&str> = log.results.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(ids, ["a", "b", "c"]);
    // Request i answered lease i: "b" was asked for before "a"'s result came, "c" before "b"'s.
    assert!(log.lease_requests[1].0 < log.results[0].3, "\"b\" is requested while \"a\" renders");
    assert!(log.lease_requests[2].0 < log.results[1].3, "\"c\" is requested while \"b\" renders");
    for (_, _, body, _) in &log.results {
        assert_bit_exact(body, &params(16, 8));
    }
    assert!(log.released.is_empty());
}

/// Starts a worker on [warm, long, `then`...] (heartbeats every 100 ms) and waits until the
/// first of `then` is prefetched and has been heartbeated `beats` times while "long" renders.
async fn prefetch_during_long(then: Vec<Step>, beats: usize) -> (Arc<Mock>, Running) {
    let mut script = vec![small("warm", 0, [0, 2]), long("long")];
    script.extend(then);
    let mock = Mock::new(300, script);
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("the prefetched lease is heartbeated", Duration::from_secs(30), || {
        mock.log().heartbeats.iter().filter(|h| h.1 != "warm" && h.1 != "long").count() >= beats
    })
    .await;
    (mock, worker)
}

/// A prefetched lease is kept alive while it waits, then rendered once the unit in hand ends.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_prefetched_lease_is_heartbeated_while_it_waits() {
    let (mock, worker) = prefetch_during_long(vec![small("next", 8, [0, 2])], 3).await;
    assert!(mock.log().results.iter().all(|r| r.0 == "warm"), "\"next\" waits for \"long\"");
    mock.log().kill_on_heartbeat.insert("long".into());
    wait_until("\"next\"'s result arrives", Duration::from_secs(30), || {
        mock.log().results.len() == 2
    })
    .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    assert_eq!(
        report,
        WorkerReport {
            units_done: 2,
            units_stale: 0,
            units_canceled: 1,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    // "next" waited queued on the pool behind "long" ("long" itself may or may not have been
    // queued behind the short "warm").
    assert!((1..=2).contains(&report.units_queued_ahead), "{report:?}");
    let log = mock.log();
    assert_eq!(log.results[1].0, "next");
    assert_bit_exact(&log.results[1].2, &params(16, 8));
    assert!(log.released.is_empty());
}

/// A prefetched lease that answers 409 on a heartbeat is dropped (not released, never
/// rendered); the worker prefetches another and carries on.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_prefetched_lease_lost_while_waiting_is_dropped() {
    let (mock, worker) =
        prefetch_during_long(vec![small("doomed", 8, [0, 2]), small("next", 8, [0, 2])], 1).await;
    mock.log().kill_on_heartbeat.insert("doomed".into());
    wait_until("\"next\" is prefetched and heartbeated", Duration::from_secs(30), || {
        mock.log().heartbeats.iter().any(|h| h.1 == "next")
    })
    .await;
    mock.log().kill_on_heartbeat.insert("long".into());
    wait_until("\"next\"'s result arrives", Duration::from_secs(30), || {
        mock.log().results.len() == 2
    })
    .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    // "doomed" (lost while waiting) and "long" (lost while rendering) count as canceled.
    assert_eq!(
        report,
        WorkerReport {
            units_done: 2,
            units_stale: 0,
            units_canceled: 2,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    let log = mock.log();
    let ids: Vec<&str> = log.results.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(ids, ["warm", "next"]);
    let killed = log.killed_at.expect("a heartbeat was refused");
    assert_eq!(
        log.heartbeats.iter().filter(|h| h.1 == "doomed" && h.0 >= killed).count(),
        1,
        "no heartbeats after the 409"
    );
    assert!(log.released.is_empty(), "a lost lease is dropped, not released");
}

/// Shutdown gives a prefetched lease back at once (DELETE), before the unit in hand's grace ends.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn shutdown_gives_back_a_prefetched_lease() {
    let (mock, worker) = prefetch_during_long(vec![small("next", 8, [0, 2])], 1).await;
    let stopping = tokio::spawn(worker.stop(Duration::from_secs(10)));
    wait_until("\"next\" is given back", SHUTDOWN_GRACE / 2, || {
        mock.log().released.iter().any(|r| r == "next")
    })
    .await;
    let (report, took) = stopping.await.unwrap();

    assert_eq!(
        report,
        WorkerReport {
            units_done: 1,
            units_stale: 0,
            units_canceled: 2,
            busy: report.busy,
            units_queued_ahead: report.units_queued_ahead,
            leases_with_results: 0
        }
    );
    assert!(took < SHUTDOWN_GRACE + Duration::from_secs(2), "shutdown took {took:?}");
    let log = mock.log();
    assert_eq!(log.released, ["next", "long"]);
    assert_eq!(log.results.len(), 1, "only the warm-up unit is uploaded");
}

mod carried;

/// Why the coordinator gives no work is logged when it changes, not on every poll.
#[test]
fn an_idle_reason_is_logged_once_per_change() {
    let api = api::Api::new("http://127.0.0.1:1", None).unwrap();
    let with = |why: &str| {
        let mut h = reqwest::header::HeaderMap::new();
        h.insert(api::IDLE_REASON, why.parse().unwrap());
        h
    };
    let (a, b, plain) = (
        with("jobs j are kept on renderer x"),
        with("jobs j keep this worker off"),
        reqwest::header::HeaderMap::new(),
    );
    assert!(!api.note_idle(Some(&plain)), "a plain 204 while nothing was logged: nothing to say");
    assert!(api.note_idle(Some(&a)));
    assert!(!api.note_idle(Some(&a)), "the same reason on the next poll");
    assert!(api.note_idle(Some(&b)), "a new reason");
    assert!(api.note_idle(None), "work came: the reason is over");
    assert!(!api.note_idle(Some(&plain)));
}

mod scene_cache;
