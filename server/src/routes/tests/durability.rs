//! Restarts, corrupt checkpoints and a full disk, through the API.
use super::super::tests::*;
use axum::http::StatusCode;
use serde_json::json;
use tessera_proto::Lease;

/// Leases every unit of the first batch round and returns them.
async fn lease_all(api: &Api, worker: &str, n: usize) -> Vec<Lease> {
    let mut out = Vec::new();
    for _ in 0..n {
        out.push(lease(api, worker).await);
    }
    out
}

async fn complete(api: &Api, l: &Lease) -> StatusCode {
    put_result(api, &l.lease_id, sums_for(l, 0.5).encode()).await.status
}

/// Renders the job to the end with fake results; returns the final image's bytes.
async fn finish(api: &Api, job: &str) -> Vec<u8> {
    let w = register(api).await;
    while let Some(l) = next_lease(api, &w).await {
        assert_eq!(complete(api, &l).await, StatusCode::NO_CONTENT);
    }
    assert_eq!(api.job(job).await["state"], "done");
    let img = api.get(&format!("/v1/jobs/{job}/image.exr")).await;
    img.expect(StatusCode::OK);
    img.body.to_vec()
}

/// The tiled job rendered to the end without interruption: the image every disturbed run of
/// it must reproduce.
async fn undisturbed(name: &str) -> Vec<u8> {
    let api = Api::new(name);
    let id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    finish(&api, &id).await
}

fn pixel_layers(exr: &[u8]) -> (Vec<[f32; 3]>, Vec<f32>) {
    let (img, _) = crate::output::decode_exr(exr).unwrap();
    (img.rgb, img.samples)
}

#[tokio::test]
async fn a_restarted_coordinator_resumes_from_its_last_checkpoint() {
    let reference = undisturbed("durable-reference").await;
    let api = Api::new("durable-restart");
    let id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let w = register(&api).await;
    let first = lease_all(&api, &w, 6).await;
    for l in &first[..4] {
        assert_eq!(complete(&api, l).await, StatusCode::NO_CONTENT);
    }
    assert_eq!(api.state.checkpoint().unwrap(), 1);
    let checkpointed = samples_done(&api, &id).await;
    assert_eq!(
        complete(&api, &first[4]).await,
        StatusCode::NO_CONTENT,
        "merged, but lost in the crash"
    );
    let api = api.crash_and_reopen(|_| {});
    assert_eq!(samples_done(&api, &id).await, checkpointed);
    assert_eq!(api.job(&id).await["state"], "running");
    assert_eq!(
        complete(&api, &first[5]).await,
        StatusCode::CONFLICT,
        "a lease from before the restart"
    );
    let got = finish(&api, &id).await;
    assert!(pixel_layers(&got) == pixel_layers(&reference), "resumed image differs");
}

#[tokio::test]
async fn a_pause_is_durable_at_once_and_the_resumed_job_ends_with_the_same_image() {
    let reference = undisturbed("pause-reference").await;
    let api = Api::new("pause-restart");
    let id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let w = register(&api).await;
    let first = lease_all(&api, &w, 3).await;
    api.post_json(&format!("/v1/jobs/{id}/pause"), &json!(null)).await.expect(StatusCode::OK);
    assert_eq!(
        complete(&api, &first[0]).await,
        StatusCode::NO_CONTENT,
        "leased before the pause: merged"
    );
    // No checkpoint call here: the pause itself must have reached the store.
    let api = api.crash_and_reopen(|_| {});
    assert_eq!(api.job(&id).await["state"], "paused");
    let w = register(&api).await;
    api.post_json("/v1/leases", &json!({"worker_id": w})).await.expect(StatusCode::NO_CONTENT);
    api.post_json(&format!("/v1/jobs/{id}/resume"), &json!(null)).await.expect(StatusCode::OK);
    let got = finish(&api, &id).await;
    assert!(pixel_layers(&got) == pixel_layers(&reference), "the paused and resumed image differs");
}

#[tokio::test]
async fn a_corrupt_checkpoint_file_is_not_read_back() {
    let api = Api::new("durable-corrupt");
    let id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let w = register(&api).await;
    for l in lease_all(&api, &w, 6).await {
        assert_eq!(complete(&api, &l).await, StatusCode::NO_CONTENT);
    }
    api.state.checkpoint().unwrap();
    let tile_file = api.dir().join("jobs").join(&id).join("t0-b1.sums");
    let mut bytes = std::fs::read(&tile_file).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 1;
    std::fs::write(&tile_file, bytes).unwrap();
    let api = api.crash_and_reopen(|_| {});
    let done = samples_done(&api, &id).await;
    assert!(
        (done - 3.0 * (1.0 - 64.0 / 240.0)).abs() < 1e-9,
        "tile 0 (64 of 240 px) starts over: {done}"
    );
    finish(&api, &id).await;
}

/// A data directory on a 1 MiB tmpfs: filling it makes every write fail with ENOSPC.
struct TinyDisk(std::path::PathBuf);

impl TinyDisk {
    fn mount(name: &str) -> Option<TinyDisk> {
        let dir = std::env::temp_dir().join(format!("tessera-tiny-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).ok()?;
        let ok = std::process::Command::new("mount")
            .args(["-t", "tmpfs", "-o", "size=1m", "tmpfs"])
            .arg(&dir)
            .status()
            .is_ok_and(|s| s.success());
        ok.then_some(TinyDisk(dir))
    }

    /// Fills the disk; returns the filler's path.
    fn fill(&self) -> std::path::PathBuf {
        use std::io::Write;
        let filler = self.0.join("filler");
        let mut f = std::fs::File::create(&filler).unwrap();
        while f.write_all(&[0u8; 4096]).is_ok() {}
        filler
    }
}

impl Drop for TinyDisk {
    fn drop(&mut self) {
        let _ = std::process::Command::new("umount").arg(&self.0).status();
    }
}

#[tokio::test]
async fn a_full_disk_refuses_new_jobs_clearly_and_loses_none() {
    let Some(disk) = TinyDisk::mount("full") else {
        eprintln!(
            "SKIPPED: mounting a tmpfs needs root (CI runs as root); the full-disk test did not run"
        );
        return;
    };
    let data = disk.0.join("data");
    let api = Api::open(data.clone(), |_| {});
    let kept = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let filler = disk.fill();
    let refused =
        api.post_json("/v1/jobs", &tiled_job()).await.problem(StatusCode::SERVICE_UNAVAILABLE);
    assert!(refused.detail.contains("not accepted"), "{}", refused.detail);
    assert_eq!(
        api.get("/v1/jobs").await.json()["jobs"].as_array().unwrap().len(),
        1,
        "the refused job is not listed"
    );
    // Work goes on in memory while checkpoints fail, and says so.
    let w = register(&api).await;
    let l = lease(&api, &w).await;
    assert_eq!(complete(&api, &l).await, StatusCode::NO_CONTENT);
    assert!(api.state.checkpoint().is_err());
    assert!(api.get("/healthz").await.text().contains("checkpoints failing"));
    std::fs::remove_file(filler).unwrap();
    assert_eq!(api.state.checkpoint().unwrap(), 1, "the next checkpoint catches up");
    assert_eq!(api.get("/healthz").await.text(), "ok");
    let mut api = api.crash_and_reopen(|_| {});
    assert!(
        samples_done(&api, &kept).await > 0.0,
        "the merge written after the disk freed up survives"
    );
    api.dir = std::path::PathBuf::new(); // the tmpfs is unmounted instead
    drop(api);
}
