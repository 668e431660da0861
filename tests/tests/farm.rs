//! The distributed path end to end: a real coordinator process, real worker processes.
use crate::cluster::Farm;
use crate::harness::{temp_dir, tessera_bin};
use std::process::Command;
use std::time::{Duration, Instant};
use tessera_proto::{Job, JobRequest, JobState};
use tessera_server::client::Coordinator;
use tessera_server::output::decode_exr;

fn request(spp: Option<u32>) -> JobRequest {
    JobRequest {
        scene: "cornell-box".into(),
        width: 64,
        height: 48,
        spp,
        seed: Some(42),
        tile_size: Some(32),
        batch_spp: Some(8),
        ..JobRequest::default()
    }
}

fn rt() -> tokio::runtime::Runtime {
    tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap()
}

async fn run_job(farm: &Farm, req: &JobRequest) -> (Job, Vec<u8>) {
    let c = farm.client();
    let job = c.submit(req).await.expect("submit");
    let job = c.wait(&job.id, |_| {}).await.unwrap();
    assert_eq!(job.state, JobState::Done, "{job:?}");
    let exr = c.bytes(&format!("/v1/jobs/{}/image.exr", job.id)).await.unwrap();
    (job, exr)
}

/// The job once `done` holds, polled every 20 ms for at most 20 s (`what` names the wait).
async fn job_when(c: &Coordinator, id: &str, what: &str, done: impl Fn(&Job) -> bool) -> Job {
    let start = Instant::now();
    loop {
        let job = c.job(id).await.unwrap();
        if done(&job) {
            return job;
        }
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "timed out waiting until {what}: {job:?}"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

fn pixels(exr: &[u8]) -> (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<f32>) {
    let (img, _) = decode_exr(exr).unwrap();
    (img.rgb, img.variance, img.samples)
}

#[test]
fn one_worker_three_workers_and_tessera_render_give_the_same_bits() {
    let rt = rt();
    let req = request(Some(32));
    let one = rt.block_on(run_job(&Farm::start("one", 1), &req)).1;
    let (three_job, three) = rt.block_on(run_job(&Farm::start("three", 3), &req));
    // Every worker process registered with the renderer id of this build, and the job says so.
    assert_eq!(three_job.renderers, [tessera_render::renderer_id()]);
    let dir = temp_dir("local");
    let local = dir.join("local.exr");
    let out = Command::new(tessera_bin())
        .args([
            "render",
            "cornell-box",
            "--spp",
            "32",
            "--width",
            "64",
            "--height",
            "48",
            "--seed",
            "42",
            "--tile-size",
            "32",
            "--batch-spp",
            "8",
            "-o",
        ])
        .arg(&local)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let local = std::fs::read(&local).unwrap();
    assert!(pixels(&one) == pixels(&three), "1 worker vs 3 workers");
    assert!(pixels(&one) == pixels(&local), "farm vs tessera render");
    // What `tessera render` prints lets a user make the same check without a reader.
    let printed = String::from_utf8_lossy(&out.stdout);
    let farm_digest = hex::encode(decode_exr(&one).unwrap().0.pixel_digest());
    assert!(
        printed.contains(&format!("pixels sha256: {farm_digest}\n")),
        "prints the farm image's digest: {printed}"
    );
    assert!(pixels(&one).2.iter().all(|&s| s == 32.0));
}

#[test]
fn progress_is_monotone_noise_falls_and_events_and_preview_work() {
    let rt = rt();
    let farm = Farm::start("progress", 2);
    rt.block_on(async {
        let c = farm.client();
        // History rows are at least 100 ms of render time apart, so the job must last long
        // enough for several: 128×96 at 256 spp takes over a second on two workers (a 64×48
        // job at 128 spp ended in 0.21 s with three rows in CI).
        let job =
            c.submit(&JobRequest { width: 128, height: 96, ..request(Some(256)) }).await.unwrap();
        let mut seen = Vec::new();
        let events = sse_events(&farm.url, &job.id);
        let done = c.wait(&job.id, |j| seen.push(j.progress.samples_done)).await.unwrap();
        assert!(seen.windows(2).all(|w| w[0] <= w[1]), "monotone: {seen:?}");
        assert_eq!(done.progress.samples_done, 256.0);
        assert_eq!(done.progress.fraction, 1.0);
        let h = &done.history;
        assert!(h.len() >= 4, "history has rows: {h:?}");
        assert!(
            h.windows(2).all(|w| w[0][0] < w[1][0] && w[0][1] <= w[1][1]),
            "rows in time and spp order: {h:?}"
        );
        // Noise falls roughly as 1/samples: from the first row past 8 spp to the last, by the
        // ratio of their spp within a factor of 2.
        let first = h.iter().find(|r| r[1] >= 8.0 && r[2] > 0.0).unwrap();
        let last = h.last().unwrap();
        let ratio = first[2] / last[2];
        let expected = last[1] / first[1];
        assert!(expected >= 2.0, "rows span the render: {h:?}");
        assert!(
            ratio > expected / 2.0 && ratio < expected * 2.0,
            "noise ratio {ratio} for {expected}× samples"
        );
        let events = events.await.unwrap();
        assert!(
            events.iter().filter(|e| e.starts_with("event: progress")).count() >= 2,
            "{events:?}"
        );
        assert!(events.last().unwrap().starts_with("event: end"));
        let png = c.bytes(&format!("/v1/jobs/{}/preview.png", job.id)).await.unwrap();
        let img = image::load_from_memory(&png).expect("preview decodes");
        assert_eq!((img.width(), img.height()), (128, 96));
    });
}

/// Collects the SSE stream of a job until it ends.
fn sse_events(url: &str, id: &str) -> tokio::task::JoinHandle<Vec<String>> {
    let url = format!("{url}/v1/jobs/{id}/events");
    tokio::spawn(async move {
        let mut resp = reqwest::get(&url).await.unwrap();
        let mut text = String::new();
        while let Some(chunk) = resp.chunk().await.unwrap() {
            text.push_str(&String::from_utf8_lossy(&chunk));
        }
        text.split("\n\n")
            .filter(|e| !e.trim().is_empty() && !e.starts_with(':'))
            .map(str::to_string)
            .collect()
    })
}

#[test]
fn noise_target_and_time_limit_jobs_stop_on_their_own() {
    let rt = rt();
    let farm = Farm::start("stops", 2);
    rt.block_on(async {
        let target = 0.02;
        let (job, _) =
            run_job(&farm, &JobRequest { noise_target: Some(target), ..request(None) }).await;
        assert!(job.noise.unwrap() <= target, "noise {:?} ≤ {target}", job.noise);
        assert!(job.progress.samples_done < 65536.0);
        let c = farm.client();
        let limit = 1.5;
        let job = c
            .submit(&JobRequest {
                time_limit_s: Some(limit),
                width: 128,
                height: 128,
                ..request(None)
            })
            .await
            .unwrap();
        let job = c.wait(&job.id, |_| {}).await.unwrap();
        assert_eq!(job.message.as_deref(), Some("time limit reached"));
        // One unit of 32×32×8 samples takes well under a second here.
        assert!(job.elapsed_s >= limit && job.elapsed_s < limit + 1.0, "elapsed {}", job.elapsed_s);
    });
}

#[test]
fn cancel_frees_workers_within_a_second() {
    let rt = rt();
    let farm = Farm::start("cancel", 2);
    rt.block_on(async {
        let c = farm.client();
        let job = c
            .submit(&JobRequest {
                width: 256,
                height: 256,
                batch_spp: Some(256),
                ..request(Some(4096))
            })
            .await
            .unwrap();
        job_when(&c, &job.id, "both workers took the job", |j| j.workers >= 2).await;
        let http = reqwest::Client::new();
        let resp = http.delete(format!("{}/v1/jobs/{}", farm.url, job.id)).send().await.unwrap();
        assert!(resp.status().is_success());
        // A second job must get both workers within a second.
        let canceled_at = Instant::now();
        let next = c.submit(&request(Some(8))).await.unwrap();
        let done = c.wait(&next.id, |_| {}).await.unwrap();
        assert_eq!(done.state, JobState::Done);
        assert!(
            canceled_at.elapsed() < Duration::from_secs(2),
            "the next job waited {:?}",
            canceled_at.elapsed()
        );
        let workers: Vec<tessera_proto::WorkerInfo> = http
            .get(format!("{}/v1/workers", farm.url))
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        assert_eq!(workers.len(), 2);
        assert_eq!(c.job(&job.id).await.unwrap().state, JobState::Canceled);
    });
}

#[test]
fn a_paused_job_yields_its_workers_and_ends_with_the_undisturbed_bits() {
    let rt = rt();
    let farm = Farm::start("pause", 2);
    let req = JobRequest { width: 128, height: 96, ..request(Some(256)) };
    rt.block_on(async {
        let c = farm.client();
        let held = c.submit(&req).await.unwrap();
        job_when(&c, &held.id, "the job started", |j| j.progress.samples_done > 0.0).await;
        assert_eq!(c.set_paused(&held.id, true).await.unwrap().state, JobState::Paused);
        // Units leased before the pause merge; then no worker holds any of its units.
        let before =
            job_when(&c, &held.id, "the units leased before the pause ended", |j| j.workers == 0)
                .await;
        let other = c.submit(&request(Some(32))).await.unwrap();
        assert_eq!(
            c.wait(&other.id, |_| {}).await.unwrap().state,
            JobState::Done,
            "the workers went to the other job"
        );
        let after = c.job(&held.id).await.unwrap();
        assert_eq!(
            (after.state, after.progress.samples_done),
            (JobState::Paused, before.progress.samples_done),
            "nothing rendered while paused"
        );
        assert!(after.progress.samples_done < 256.0, "paused before the end");
        // Queued, or already running if an idle worker polled in between.
        assert_ne!(c.set_paused(&held.id, false).await.unwrap().state, JobState::Paused);
        let done = c.wait(&held.id, |_| {}).await.unwrap();
        assert_eq!(done.state, JobState::Done);
        let paused = c.bytes(&format!("/v1/jobs/{}/image.exr", held.id)).await.unwrap();
        let undisturbed = run_job(&farm, &req).await.1;
        assert!(
            pixels(&paused) == pixels(&undisturbed),
            "paused and resumed vs the same job undisturbed"
        );
    });
}

#[test]
fn tessera_job_reads_pauses_resumes_and_cancels_a_job() {
    let rt = rt();
    let farm = Farm::start("job-cli", 0);
    let id = rt.block_on(farm.client().submit(&request(Some(8)))).unwrap().id;
    let job = |action: &str, id: &str| {
        let out = Command::new(tessera_bin())
            .args(["job", action, id, "--server", &farm.url])
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    for (action, shown) in [
        ("status", "queued: "),
        ("pause", "paused: paused, "),
        ("resume", "queued: "),
        ("pause", "paused: "),
        ("cancel", "canceled: "),
    ] {
        let (ok, out, err) = job(action, &id);
        assert!(ok && out.starts_with(&format!("{id} {shown}")), "{action}: {out} {err}");
    }
    let (ok, _, err) = job("resume", &id);
    assert!(!ok && err.contains("has ended (canceled) and cannot be resumed"), "{err}");
    let (ok, _, err) = job("status", "no-such-job");
    assert!(!ok && err.contains("no job"), "{err}");
}

#[test]
fn with_tokens_workers_and_clients_get_in_with_theirs_only() {
    let rt = rt();
    let farm = Farm::start_with("tokens", 1, Some(("c-token", "w-token")), &[]);
    rt.block_on(async {
        let anonymous =
            Coordinator::new(&farm.url, None).submit(&request(Some(8))).await.unwrap_err();
        assert!(anonymous.to_string().contains("Unauthorized"), "{anonymous}");
        let c = Coordinator::new(&farm.url, Some("c-token".into()));
        let job = c.submit(&request(Some(8))).await.unwrap();
        let done = c.wait(&job.id, |_| {}).await.unwrap();
        assert_eq!(done.state, JobState::Done, "the worker got in with its token");
    });
}
