//! The farm across hosts: a coordinator and workers in containers with their own addresses,
//! on a compose network, driven from the host over HTTP. Each test prints its duration.
//! Ignored unless asked for (`cargo test -- --include-ignored`, as `.ci/run` does where a Docker
//! engine answers); asked for without one, they fail and say so.
use crate::compose_farm::{ComposeFarm, engine, run, static_bin};
use crate::harness::temp_dir;
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};
use tessera_proto::{Job, JobRequest, JobState, WorkerInfo};
use tessera_server::output::decode_exr;

/// One job for every test: 9 tiles × 8 batches. Units of 64×64×32 samples take a few tenths of
/// a second on one thread, so a kill lands mid-unit; the whole job takes 7 to 20 s on two cores
/// (idle or shared).
const SPP: u32 = 256;
const UNITS: f64 = 9.0 * 8.0;

fn job() -> JobRequest {
    JobRequest {
        scene: "cornell-box".into(),
        width: 160,
        height: 160,
        spp: Some(SPP),
        seed: Some(7),
        tile_size: Some(64),
        batch_spp: Some(32),
        ..JobRequest::default()
    }
}

type Layers = (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<f32>);

/// Mean, variance and sample-count layers (the metadata holds render times, which differ).
fn layers(exr: &[u8]) -> Layers {
    let (img, _) = decode_exr(exr).expect("an EXR");
    (img.rgb, img.variance, img.samples)
}

/// `tessera render` of the same job on the host (the image's binary), rendered once.
fn reference() -> &'static Layers {
    static REFERENCE: OnceLock<Layers> = OnceLock::new();
    REFERENCE.get_or_init(|| {
        let out = temp_dir("compose-reference").join("reference.exr");
        let started = Instant::now();
        let args = [
            "render",
            "cornell-box",
            "--width",
            "160",
            "--height",
            "160",
            "--spp",
            "256",
            "--seed",
            "7",
            "--tile-size",
            "64",
            "--batch-spp",
            "32",
            "-o",
        ];
        run(Command::new(static_bin()).args(args).arg(&out));
        eprintln!("[compose] reference render in {:.1}s", started.elapsed().as_secs_f64());
        let l = layers(&std::fs::read(&out).unwrap());
        assert!(l.2.iter().all(|&s| s == SPP as f32), "every pixel has {SPP} samples");
        l
    })
}

fn rt() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap()
}

/// Polls `f` every 100 ms until it returns Some, for at most `limit`.
async fn wait_for<T, F: Future<Output = Option<T>>>(
    what: &str,
    limit: Duration,
    mut f: impl FnMut() -> F,
) -> T {
    let start = Instant::now();
    loop {
        if let Some(v) = f().await {
            return v;
        }
        assert!(start.elapsed() < limit, "waited {limit:?} for {what}");
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
}

/// Waits for the job to end and checks its image against `tessera render`.
async fn finish_and_compare(farm: &ComposeFarm, id: &str) -> Job {
    let c = farm.client();
    let done = c.wait(id, |_| {}).await.expect("job status");
    assert_eq!(done.state, JobState::Done, "{done:?}");
    let exr = c.bytes(&format!("/v1/jobs/{id}/image.exr")).await.expect("the EXR");
    assert!(layers(&exr) == *reference(), "the farm's image differs from tessera render's");
    done
}

fn report(test: &str, started: Instant) {
    eprintln!("[compose] {test}: {:.1}s", started.elapsed().as_secs_f64());
}

#[test]
#[ignore = "needs a Docker engine and Compose: cargo test -- --include-ignored runs it (.ci/run does where Docker answers)"]
fn compose_three_workers_render_the_same_bits_as_tessera_render() {
    let test = "compose_three_workers_render_the_same_bits_as_tessera_render";
    let _turn = engine(test);
    let started = Instant::now();
    let farm = ComposeFarm::up("three", 3, 10);
    reference();
    rt().block_on(async {
        let job = farm.client().submit(&job()).await.expect("submit");
        finish_and_compare(&farm, &job.id).await;
        // Each worker found the coordinator by its service name and rendered.
        let workers = farm.workers().await;
        assert_eq!(workers.len(), 3, "{workers:?}");
        assert!(workers.iter().all(|w| w.units_done > 0), "{workers:?}");
        assert_eq!(farm.metrics().await["tessera_units_merged_total"], UNITS);
    });
    // `tessera healthcheck` works inside the image, against the coordinator and the workers
    // (their first check comes 5 s after they start).
    for c in farm.containers("coordinator").iter().chain(&farm.containers("worker")) {
        let health = || {
            String::from_utf8_lossy(
                &farm.docker(&["inspect", "-f", "{{.State.Health.Status}}", c]).stdout,
            )
            .trim()
            .to_string()
        };
        let until = Instant::now() + Duration::from_secs(20);
        while health() == "starting" && Instant::now() < until {
            std::thread::sleep(Duration::from_millis(500));
        }
        assert_eq!(health(), "healthy", "container {c}");
    }
    report(test, started);
}

#[test]
#[ignore = "needs a Docker engine and Compose: cargo test -- --include-ignored runs it (.ci/run does where Docker answers)"]
fn compose_killed_and_cut_off_workers_change_nothing() {
    let test = "compose_killed_and_cut_off_workers_change_nothing";
    let _turn = engine(test);
    let started = Instant::now();
    let lease_s = 3;
    let farm = ComposeFarm::up("faults", 3, lease_s);
    reference();
    rt().block_on(async {
        let job = farm.client().submit(&job()).await.expect("submit");
        let busy = wait_for("three workers holding units", Duration::from_secs(30), || async {
            let w: Vec<WorkerInfo> =
                farm.workers().await.into_iter().filter(|w| w.current.is_some()).collect();
            (w.len() == 3).then_some(w)
        })
        .await;
        let (killed, cut) = (&busy[0], &busy[1]);
        farm.docker(&["kill", &farm.container_of(&killed.name)]);
        let (net, cut_container) = (farm.network(), farm.container_of(&cut.name));
        farm.docker(&["network", "disconnect", &net, &cut_container]);
        // Longer than the lease: the coordinator must give both units to someone else.
        tokio::time::sleep(Duration::from_secs(lease_s as u64 + 3)).await;
        let before = find(&farm.workers().await, &cut.id).clone();
        // Its unit either expired on the coordinator (a failure) or, on a loaded machine, was
        // uploaded in the instant between the snapshot above and the disconnect.
        let expired_or_landed = before.failures >= 1 || before.units_done > cut.units_done;
        assert!(
            expired_or_landed && before.current.is_none(),
            "the cut-off worker's lease expired: {before:?} (was {cut:?})"
        );
        assert!(before.last_seen_ms_ago >= 1000 * lease_s as u64, "{before:?}");
        farm.docker(&["network", "connect", &net, &cut_container]);
        // Back on the network, the same worker asks for work again (a dead connection times out within 6 s, retries back off ≤ 5 s).
        wait_for("the reconnected worker to call again", Duration::from_secs(20), || async {
            (find(&farm.workers().await, &cut.id).last_seen_ms_ago < 1000).then_some(())
        })
        .await;
        let done = finish_and_compare(&farm, &job.id).await;
        assert_eq!(done.progress.samples_done, SPP as f64);
        let killed = find(&farm.workers().await, &killed.id).clone();
        assert!(killed.failures >= 1 && killed.current.is_none(), "{killed:?}");
        // Every unit merged exactly once; the two lost units were leased again.
        let m = farm.metrics().await;
        assert_eq!(m["tessera_units_merged_total"], UNITS, "{m:?}");
        assert!(m["tessera_leases_granted_total"] >= UNITS + 2.0, "{m:?}");
        eprintln!(
            "[compose] {test}: late results ignored (409): {}, leases granted {} for {UNITS} units",
            m["tessera_results_stale_total"], m["tessera_leases_granted_total"]
        );
    });
    report(test, started);
}

fn find<'a>(workers: &'a [WorkerInfo], id: &str) -> &'a WorkerInfo {
    workers
        .iter()
        .find(|w| w.id == id)
        .unwrap_or_else(|| panic!("worker {id} is not listed: {workers:?}"))
}

#[test]
#[ignore = "needs a Docker engine and Compose: cargo test -- --include-ignored runs it (.ci/run does where Docker answers)"]
fn compose_scaling_from_one_to_four_workers_mid_job() {
    let test = "compose_scaling_from_one_to_four_workers_mid_job";
    let _turn = engine(test);
    let started = Instant::now();
    let farm = ComposeFarm::up("scale", 1, 10);
    reference();
    rt().block_on(async {
        let c = farm.client();
        let job = c.submit(&job()).await.expect("submit");
        wait_for("the first worker on the job", Duration::from_secs(30), || async { (c.job(&job.id).await.ok()?.workers > 0).then_some(()) }).await;
        let scale_at = Instant::now();
        farm.compose(&["up", "-d", "--no-recreate", "--scale", "worker=4"]);
        let scaled = scale_at.elapsed();
        // Every new worker holds or has finished a unit while the job still runs.
        wait_for("four workers with units", Duration::from_secs(20), || async {
            let w = farm.workers().await;
            (w.len() == 4 && w.iter().all(|w| w.current.is_some() || w.units_done > 0)).then_some(())
        })
        .await;
        let working = scale_at.elapsed();
        eprintln!("[compose] {test}: `up --scale worker=4` took {:.1}s; all four had units {:.1}s after it was run", scaled.as_secs_f64(), working.as_secs_f64());
        assert!(working - scaled < Duration::from_secs(5), "new workers waited {:?} for units", working - scaled);
        assert_ne!(c.job(&job.id).await.unwrap().state, JobState::Done, "the job ended before the new workers joined: make it longer");
        finish_and_compare(&farm, &job.id).await;
    });
    report(test, started);
}

#[test]
#[ignore = "needs a Docker engine and Compose: cargo test -- --include-ignored runs it (.ci/run does where Docker answers)"]
fn compose_coordinator_restart_mid_render_resumes_from_the_volume() {
    let test = "compose_coordinator_restart_mid_render_resumes_from_the_volume";
    let _turn = engine(test);
    let started = Instant::now();
    let mut farm = ComposeFarm::up("restart", 3, 10);
    reference();
    let rt = rt();
    let id = rt.block_on(async {
        let c = farm.client();
        let job = c.submit(&job()).await.expect("submit");
        wait_for("a fifth of the job", Duration::from_secs(60), || async {
            (c.job(&job.id).await.ok()?.progress.fraction >= 0.2).then_some(())
        })
        .await;
        job.id
    });
    farm.compose(&["restart", "-t", "10", "coordinator"]);
    farm.find_coordinator();
    rt.block_on(async {
        finish_and_compare(&farm, &id).await;
        // Resumed, not started over: the new process merged fewer units than the job has.
        let merged = farm.metrics().await["tessera_units_merged_total"];
        assert!(merged < UNITS, "{merged} units merged after the restart, of {UNITS}");
    });
    report(test, started);
}
