//! Ended jobs (done, canceled, or stopped by their time limit): their images are written once,
//! their merged sums are dropped, and a restart neither reads the sums back nor changes what the
//! job reports or serves.
use super::super::tests::{
    Api, job_body, lease, next_lease, put_result, register, sums_for, tiled_job,
};
use axum::http::StatusCode;
use serde_json::{Value, json};

/// Renders the job to the end with fake results of varying radiance (so its noise is not 0).
async fn finish(api: &Api, job: &str) {
    let w = register(api).await;
    let mut n = 0;
    while let Some(l) = next_lease(api, &w).await {
        n += 1;
        put_result(api, &l.lease_id, sums_for(&l, 0.25 * n as f64).encode())
            .await
            .expect(StatusCode::NO_CONTENT);
    }
    assert_eq!(api.job(job).await["state"], "done");
}

/// Everything a client reads of an ended job: its status (without the clock's fields) and its
/// images.
async fn observed(api: &Api, job: &str) -> (Value, Vec<u8>, Vec<u8>) {
    let mut status = api.job(job).await;
    for clock in ["elapsed_s", "eta_s", "samples_per_s"] {
        status.as_object_mut().unwrap().remove(clock);
    }
    let exr = api.get(&format!("/v1/jobs/{job}/image.exr")).await;
    exr.expect(StatusCode::OK);
    let png = api.get(&format!("/v1/jobs/{job}/preview.png")).await;
    png.expect(StatusCode::OK);
    (status, exr.body.to_vec(), png.body.to_vec())
}

fn holds_sums(api: &Api, job: &str) -> usize {
    let s = api.state.scheduler.lock().unwrap();
    s.job(job).unwrap().tiles().iter().map(|t| t.merged.len()).sum()
}

#[tokio::test]
async fn a_done_job_drops_its_sums_and_serves_the_same_after_a_restart() {
    let api = Api::new("ended-done");
    let id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    assert_eq!(holds_sums(&api, &id), 0, "a queued job holds no sums before its first merge");
    finish(&api, &id).await;
    let before = observed(&api, &id).await;
    assert!(before.0["noise"].as_f64().unwrap() > 0.0, "{}", before.0);
    assert_eq!(holds_sums(&api, &id), 0, "the job's image is written: its sums are dropped");
    assert!(api.state.scheduler.lock().unwrap().job(&id).unwrap().sums_released());

    api.state.checkpoint().unwrap();
    assert!(
        !api.dir().join("jobs").join(&id).exists(),
        "the record now says the image replaces the tile files"
    );
    let api = api.crash_and_reopen(|_| {});
    assert!(api.state.scheduler.lock().unwrap().job(&id).unwrap().sums_released(), "not read back");
    assert_eq!(holds_sums(&api, &id), 0);
    let after = observed(&api, &id).await;
    assert_eq!(after.0, before.0, "the status after the restart");
    assert!(after.1 == before.1 && after.2 == before.2, "the same EXR and preview bytes");
}

#[tokio::test]
async fn an_ended_jobs_preview_from_its_file_is_the_one_its_sums_gave() {
    let api = Api::new("ended-preview");
    let w = register(&api).await;
    let id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let l = lease(&api, &w).await;
    put_result(&api, &l.lease_id, sums_for(&l, 0.7).encode()).await.expect(StatusCode::NO_CONTENT);
    let running = api.get(&format!("/v1/jobs/{id}/preview.png")).await.body.to_vec();
    assert!(holds_sums(&api, &id) > 0);
    api.delete(&format!("/v1/jobs/{id}")).await.expect(StatusCode::OK);
    let canceled = observed(&api, &id).await;
    assert_eq!(canceled.0["state"], "canceled");
    assert_eq!(canceled.2, running, "the preview decoded from the written EXR");
    assert_eq!(
        holds_sums(&api, &id),
        0,
        "a canceled job's image is written too, and its sums dropped"
    );
    let on_disk = std::fs::read(api.dir().join("jobs").join(format!("{id}.exr")))
        .expect("the canceled job's EXR");
    assert_eq!(canceled.1, on_disk);
    let (img, _) = crate::output::decode_exr(&on_disk).unwrap();
    assert_eq!(img.rgb[0], [0.7; 3], "the merged unit is in it");
}

#[tokio::test]
async fn a_job_ended_by_its_time_limit_is_still_done_after_a_restart() {
    let api = Api::new("ended-time-limit");
    let w = register(&api).await;
    let id = api.submit(&job_body(json!({"spp": null, "time_limit_s": 0.3}))).await["id"]
        .as_str()
        .unwrap()
        .to_string();
    let l = lease(&api, &w).await; // starts the clock
    put_result(&api, &l.lease_id, sums_for(&l, 0.5).encode()).await.expect(StatusCode::NO_CONTENT);
    tokio::time::sleep(std::time::Duration::from_millis(400)).await;
    // No background ticker runs here: the lease request's own tick ends the job.
    api.post_json("/v1/leases", &json!({"worker_id": w})).await.expect(StatusCode::NO_CONTENT);
    let before = observed(&api, &id).await;
    assert_eq!(
        (before.0["state"].as_str(), before.0["message"].as_str()),
        (Some("done"), Some("time limit reached"))
    );
    api.state.checkpoint().unwrap();
    let api = api.crash_and_reopen(|_| {});
    let after = observed(&api, &id).await;
    assert_eq!(after.0, before.0, "not resumed as if its checkpoints were lost");
    assert_eq!(after.1, before.1);
}

#[tokio::test]
async fn a_deleted_job_is_gone_with_its_files_even_after_a_restart() {
    let api = Api::new("ended-purge");
    let w = register(&api).await;
    let done = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    finish(&api, &done).await;
    let running = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let l = lease(&api, &w).await;
    put_result(&api, &l.lease_id, sums_for(&l, 0.5).encode()).await.expect(StatusCode::NO_CONTENT);
    let held = lease(&api, &w).await;
    api.state.checkpoint().unwrap();
    let jobs = api.dir().join("jobs");
    assert!(jobs.join(format!("{done}.exr")).exists() && jobs.join(&running).exists());

    for id in [&done, &running] {
        let r = api.delete(&format!("/v1/jobs/{id}?purge=true")).await;
        assert_eq!(r.status, StatusCode::NO_CONTENT);
        api.get(&format!("/v1/jobs/{id}")).await.problem(StatusCode::NOT_FOUND);
        api.get(&format!("/v1/jobs/{id}/image.exr")).await.problem(StatusCode::NOT_FOUND);
        api.delete(&format!("/v1/jobs/{id}?purge=true")).await.problem(StatusCode::NOT_FOUND);
    }
    assert!(
        !jobs.join(format!("{done}.exr")).exists() && !jobs.join(&running).exists(),
        "images and checkpoints removed"
    );
    put_result(&api, &held.lease_id, sums_for(&held, 0.5).encode())
        .await
        .problem(StatusCode::CONFLICT);
    assert_eq!(api.get("/v1/jobs").await.json()["jobs"].as_array().unwrap().len(), 0);
    let api = api.crash_and_reopen(|_| {});
    assert_eq!(
        api.get("/v1/jobs").await.json()["jobs"].as_array().unwrap().len(),
        0,
        "no record left to restore"
    );
    assert_eq!(
        std::fs::read_dir(api.dir().join("jobs")).unwrap().count(),
        0,
        "no file left behind"
    );
}

#[tokio::test]
async fn ended_jobs_are_deleted_once_older_than_the_retention_even_across_a_restart() {
    const HOUR_MS: u64 = 3_600_000;
    let api = Api::with_config("ended-retention", |c| c.delete_ended_after_ms = Some(HOUR_MS));
    let ended = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    finish(&api, &ended).await;
    let running = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let now = crate::state::unix_ms();
    assert_eq!(api.state.delete_expired(now), 0, "ended just now");
    api.state.checkpoint().unwrap();
    let api = api.crash_and_reopen(|c| c.delete_ended_after_ms = Some(HOUR_MS));
    assert_eq!(
        api.state.delete_expired(now + HOUR_MS - 60_000),
        0,
        "the end time survived the restart"
    );
    assert_eq!(api.state.delete_expired(now + HOUR_MS + 60_000), 1);
    api.get(&format!("/v1/jobs/{ended}")).await.problem(StatusCode::NOT_FOUND);
    assert!(!api.dir().join("jobs").join(format!("{ended}.exr")).exists());
    assert_eq!(api.job(&running).await["state"], "queued", "a job that has not ended stays");
}
