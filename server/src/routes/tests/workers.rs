//! The worker protocol over HTTP: register, lease, heartbeat, result, release.
use super::super::tests::{
    Api, lease, next_lease, put_result, register, samples_done, sums_for, tiled_job,
};
use axum::http::{Method, StatusCode};
use serde_json::{Value, json};

#[tokio::test]
async fn registering_returns_an_id_and_the_heartbeat_period() {
    let api = Api::new("w-register");
    let r = api.post_json("/v1/workers", &json!({"name": "box-1", "threads": 8})).await;
    r.expect(StatusCode::CREATED);
    let reg = r.json();
    let id = reg["worker_id"].as_str().expect("worker_id");
    assert!(!id.is_empty());
    assert_eq!(reg["heartbeat_ms"], 10_000 / 3, "a third of the default 10 s lease timeout");
    let list = api.get("/v1/workers").await;
    list.expect(StatusCode::OK);
    let list = list.json();
    assert_eq!(list.as_array().unwrap().len(), 1);
    assert_eq!(list[0]["id"], id);
    assert_eq!(list[0]["name"], "box-1");
    assert_eq!(list[0]["threads"], 8);
    assert_eq!(list[0]["current"], Value::Null);
}

#[tokio::test]
async fn registration_names_the_protocol_version_and_refuses_one_this_coordinator_does_not_speak() {
    let api = Api::new("w-register-protocol");
    let version = tessera_proto::PROTOCOL_VERSION;
    let r = api
        .post_json("/v1/workers", &json!({"protocol": version, "name": "a", "threads": 1}))
        .await;
    r.expect(StatusCode::CREATED);
    assert_eq!(r.json()["protocol"], version);
    // Workers built before versions were sent speak version 1.
    let r = api.post_json("/v1/workers", &json!({"name": "b", "threads": 1})).await;
    r.expect(StatusCode::CREATED);
    assert_eq!(r.json()["protocol"], 1);
    for other in [0, version + 1] {
        let p = api
            .post_json("/v1/workers", &json!({"protocol": other, "name": "c", "threads": 1}))
            .await
            .problem(StatusCode::BAD_REQUEST);
        assert_eq!(p.field.as_deref(), Some("protocol"), "{p:?}");
        assert!(
            p.detail.contains(&format!(
                "worker protocol {other}; this coordinator speaks 1..={version}"
            )),
            "{p:?}"
        );
    }
    assert_eq!(
        api.get("/v1/workers").await.json().as_array().unwrap().len(),
        2,
        "refused workers are not listed"
    );
}

#[tokio::test]
async fn registering_with_zero_threads_is_a_400_naming_threads() {
    let api = Api::new("w-register-0");
    let p = api
        .post_json("/v1/workers", &json!({"name": "x", "threads": 0}))
        .await
        .problem(StatusCode::BAD_REQUEST);
    assert_eq!(p.field.as_deref(), Some("threads"));
    assert!(p.detail.contains("threads in 1..=4096"), "{p:?}");
    let p =
        api.post_json("/v1/workers", &json!({"name": "x"})).await.problem(StatusCode::BAD_REQUEST);
    assert_eq!(p.field.as_deref(), Some("threads"), "missing field: {p:?}");
}

#[tokio::test]
async fn registering_with_a_too_long_name_is_a_400_naming_name() {
    let api = Api::new("w-register-name");
    let p = api
        .post_json("/v1/workers", &json!({"name": "n".repeat(300), "threads": 2}))
        .await
        .problem(StatusCode::BAD_REQUEST);
    assert_eq!(p.field.as_deref(), Some("name"), "{p:?}");
    assert!(!p.detail.contains("threads"), "the threads are fine: {p:?}");
}

#[tokio::test]
async fn leasing_for_an_unknown_worker_is_404() {
    let api = Api::new("w-lease-404");
    let p = api
        .post_json("/v1/leases", &json!({"worker_id": "w404"}))
        .await
        .problem(StatusCode::NOT_FOUND);
    assert!(p.detail.contains("unknown worker \"w404\""), "{p:?}");
}

#[tokio::test]
async fn leasing_with_no_jobs_is_204_with_no_body() {
    let api = Api::new("w-lease-204");
    let w = register(&api).await;
    let r = api.post_json("/v1/leases", &json!({"worker_id": w})).await;
    r.expect(StatusCode::NO_CONTENT);
    assert!(r.body.is_empty());
}

#[tokio::test]
async fn leases_cover_the_jobs_tiles_and_batches_breadth_first() {
    let api = Api::new("w-lease-units");
    let w = register(&api).await;
    let job = api.submit(&tiled_job()).await;
    let job_id = job["id"].as_str().unwrap();

    let first = lease(&api, &w).await;
    assert_eq!(first.job_id, job_id);
    assert_eq!(first.scene_id, job["scene"].as_str().unwrap());
    assert_eq!(
        (first.tile.x0, first.tile.y0, first.tile.w, first.tile.h),
        (0, 0, 8, 8),
        "tile_size 8"
    );
    assert_eq!(first.samples, [0, 3], "batch_spp 3");
    assert_eq!(first.deadline_ms, 10_000);
    assert_eq!((first.params.width, first.params.height), (20, 12));
    assert_eq!((first.params.estimator.as_str(), first.params.sampler.as_str()), ("mis", "sobol"));
    let status = api.job(job_id).await;
    assert_eq!(status["state"], "running");
    assert_eq!(status["workers"], 1);

    let mut all = vec![first];
    while let Some(l) = next_lease(&api, &w).await {
        all.push(l);
    }
    assert_eq!(all.len(), 12, "6 tiles × 2 batches");
    assert!(
        all[..6].iter().all(|l| l.samples == [0, 3])
            && all[6..].iter().all(|l| l.samples == [3, 5]),
        "breadth first, last batch clipped to spp"
    );
    let mut rects: Vec<_> =
        all[..6].iter().map(|l| (l.tile.x0, l.tile.y0, l.tile.w, l.tile.h)).collect();
    rects.sort();
    assert_eq!(
        rects,
        [(0, 0, 8, 8), (0, 8, 8, 4), (8, 0, 8, 8), (8, 8, 8, 4), (16, 0, 4, 8), (16, 8, 4, 4)]
    );
    assert_eq!(api.metric("tessera_leases_granted_total").await, "12");
}

#[tokio::test]
async fn heartbeats_extend_live_leases_and_answer_409_for_unknown_ones() {
    let api = Api::new("w-heartbeat");
    let w = register(&api).await;
    api.submit(&tiled_job()).await;
    let l = lease(&api, &w).await;
    let r =
        api.request(Method::POST, &format!("/v1/leases/{}/heartbeat", l.lease_id), None, "").await;
    r.expect(StatusCode::OK);
    assert_eq!(r.json(), json!({"deadline_ms": 10_000}));
    let p = api
        .request(Method::POST, "/v1/leases/l999-1/heartbeat", None, "")
        .await
        .problem(StatusCode::CONFLICT);
    assert!(p.detail.contains("l999-1") && p.detail.contains("no longer active"), "{p:?}");
}

#[tokio::test]
async fn a_garbage_result_is_422_and_its_unit_is_issued_again() {
    let api = Api::new("w-result-garbage");
    let w = register(&api).await;
    api.submit(&tiled_job()).await;
    let l = lease(&api, &w).await;
    let p = put_result(&api, &l.lease_id, b"this is not a result".to_vec())
        .await
        .problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        p.detail.starts_with("malformed result:")
            && p.detail.contains("shorter than the 48-byte header"),
        "{p:?}"
    );
    let mut bad_magic = sums_for(&l, 1.0).encode();
    bad_magic[..4].copy_from_slice(b"XSUM");
    let p =
        put_result(&api, &l.lease_id, bad_magic).await.problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p.detail.contains("bad magic"), "{p:?}");
    assert_eq!(api.metric("tessera_results_malformed_total").await, "2");
    // The unit went back to the queue: the next lease is the same tile and samples.
    let again = lease(&api, &w).await;
    assert_ne!(again.lease_id, l.lease_id);
    assert_eq!((again.tile, again.samples), (l.tile, l.samples));
}

#[tokio::test]
async fn a_result_is_merged_once_and_a_duplicate_is_409() {
    let api = Api::new("w-result-dup");
    let w = register(&api).await;
    let job_id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let l = lease(&api, &w).await;
    assert_eq!(samples_done(&api, &job_id).await, 0.0);
    assert_eq!(api.get("/v1/workers").await.json()[0]["current"], format!("{job_id}/0/0"));
    let body = sums_for(&l, 0.5).encode();

    let r = put_result(&api, &l.lease_id, body.clone()).await;
    r.expect(StatusCode::NO_CONTENT);
    assert!(r.body.is_empty());
    let after = samples_done(&api, &job_id).await;
    assert_eq!(after, 3.0 * 64.0 / 240.0, "3 spp on 64 of the 240 pixels");

    let p = put_result(&api, &l.lease_id, body).await.problem(StatusCode::CONFLICT);
    assert!(p.detail.contains(&l.lease_id) && p.detail.contains("not active"), "{p:?}");
    assert_eq!(samples_done(&api, &job_id).await, after, "a duplicate is never counted twice");
    assert_eq!(api.metric("tessera_units_merged_total").await, "1");
    assert_eq!(api.metric("tessera_results_stale_total").await, "1");
    let job = api.job(&job_id).await;
    assert_eq!(job["workers"], 0, "the lease is done");
    assert_eq!(job["history"].as_array().unwrap().len(), 1);
    assert_eq!(job["max_sample_weight"], 0.5);
    assert_eq!(
        job["contributions"],
        json!([{"worker_id": w, "name": "test-host", "samples": 3 * 64}]),
        "3 spp × 64 pixels, once"
    );
    let worker = &api.get("/v1/workers").await.json()[0];
    assert_eq!(
        (worker["units_done"].as_u64(), worker["current"].is_null()),
        (Some(1), true),
        "{worker}"
    );
}

#[tokio::test]
async fn a_result_for_the_wrong_tile_or_samples_is_422_and_not_merged() {
    let api = Api::new("w-result-wrong");
    let w = register(&api).await;
    let job_id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let l = lease(&api, &w).await;

    let mut wrong_tile = sums_for(&l, 1.0);
    wrong_tile.tile.x0 += 8;
    let p = put_result(&api, &l.lease_id, wrong_tile.encode())
        .await
        .problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p.detail.contains("result is for tile") && p.detail.contains(&l.lease_id), "{p:?}");

    let l2 = lease(&api, &w).await;
    assert_eq!((l2.tile, l2.samples), (l.tile, l.samples), "the refused unit is issued again");
    let mut wrong_samples = sums_for(&l2, 1.0);
    wrong_samples.samples = [1, 4];
    let p = put_result(&api, &l2.lease_id, wrong_samples.encode())
        .await
        .problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p.detail.contains("result covers samples [1, 4]"), "{p:?}");

    assert_eq!(samples_done(&api, &job_id).await, 0.0);
    assert_eq!(api.metric("tessera_units_merged_total").await, "0");
    let workers = api.get("/v1/workers").await.json();
    assert_eq!(workers[0]["failures"], 2);
}

#[tokio::test]
async fn releasing_a_lease_is_204_once_then_404() {
    let api = Api::new("w-release");
    let w = register(&api).await;
    api.submit(&tiled_job()).await;
    let l = lease(&api, &w).await;
    let r = api.delete(&format!("/v1/leases/{}", l.lease_id)).await;
    r.expect(StatusCode::NO_CONTENT);
    let p = api.delete(&format!("/v1/leases/{}", l.lease_id)).await.problem(StatusCode::NOT_FOUND);
    assert!(p.detail.contains(&l.lease_id), "{p:?}");
    api.request(Method::POST, &format!("/v1/leases/{}/heartbeat", l.lease_id), None, "")
        .await
        .problem(StatusCode::CONFLICT);
    let again = lease(&api, &w).await;
    assert_eq!((again.tile, again.samples), (l.tile, l.samples), "a released unit is issued again");
}

#[tokio::test]
async fn canceling_a_job_revokes_its_leases() {
    let api = Api::new("w-cancel");
    let w = register(&api).await;
    let job_id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let l = lease(&api, &w).await;
    api.delete(&format!("/v1/jobs/{job_id}")).await.expect(StatusCode::OK);
    api.request(Method::POST, &format!("/v1/leases/{}/heartbeat", l.lease_id), None, "")
        .await
        .problem(StatusCode::CONFLICT);
    put_result(&api, &l.lease_id, sums_for(&l, 1.0).encode()).await.problem(StatusCode::CONFLICT);
    assert_eq!(samples_done(&api, &job_id).await, 0.0);
    api.post_json("/v1/leases", &json!({"worker_id": w})).await.expect(StatusCode::NO_CONTENT);
}

#[tokio::test]
async fn a_paused_job_leases_nothing_until_resumed_and_keeps_what_was_leased() {
    let api = Api::new("w-pause");
    let w = register(&api).await;
    let job_id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let l = lease(&api, &w).await;
    let r = api.post_json(&format!("/v1/jobs/{job_id}/pause"), &json!(null)).await;
    r.expect(StatusCode::OK);
    assert_eq!(
        (r.json()["state"].clone(), r.json()["eta_s"].clone()),
        (json!("paused"), Value::Null)
    );
    api.post_json("/v1/leases", &json!({"worker_id": w})).await.expect(StatusCode::NO_CONTENT);
    put_result(&api, &l.lease_id, sums_for(&l, 1.0).encode()).await.expect(StatusCode::NO_CONTENT);
    assert!(samples_done(&api, &job_id).await > 0.0, "the unit leased before the pause is merged");
    assert_eq!(api.metric("tessera_jobs{state=\"paused\"}").await, "1");
    let r = api.post_json(&format!("/v1/jobs/{job_id}/resume"), &json!(null)).await;
    r.expect(StatusCode::OK);
    assert_eq!(r.json()["state"], "queued");
    lease(&api, &w).await;
    assert_eq!(api.job(&job_id).await["state"], "running");
    api.delete(&format!("/v1/jobs/{job_id}")).await.expect(StatusCode::OK);
    let p = api
        .post_json(&format!("/v1/jobs/{job_id}/pause"), &json!(null))
        .await
        .problem(StatusCode::CONFLICT);
    assert!(p.detail.contains("canceled"), "{p:?}");
    api.post_json("/v1/jobs/nope/resume", &json!(null)).await.problem(StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn a_result_over_the_size_limit_is_413() {
    let api = Api::new("w-result-413");
    let r = put_result(&api, "l1-1", vec![0u8; (1024 * 1024 * 64) + 4096 + 1]).await;
    r.expect(StatusCode::PAYLOAD_TOO_LARGE);
}

#[tokio::test]
async fn a_result_over_the_size_limit_is_a_413_problem() {
    let api = Api::new("w-result-413-problem");
    put_result(&api, "l1-1", vec![0u8; (1024 * 1024 * 64) + 4096 + 1])
        .await
        .problem(StatusCode::PAYLOAD_TOO_LARGE);
}

#[tokio::test]
async fn a_worker_leaving_ends_its_long_poll_and_hands_back_its_units() {
    let api = Api::new("w-deregister");
    let (a, b) = (register(&api).await, register(&api).await);
    let started = std::time::Instant::now();
    let poll_body = json!({"worker_id": a});
    let (poll, left) = tokio::join!(api.post_json("/v1/leases?wait_ms=5000", &poll_body), async {
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
        api.delete(&format!("/v1/workers/{a}")).await
    });
    left.expect(StatusCode::NO_CONTENT);
    poll.problem(StatusCode::NOT_FOUND);
    assert!(
        started.elapsed() < std::time::Duration::from_secs(2),
        "the long poll ended when its worker left: {:?}",
        started.elapsed()
    );
    api.delete(&format!("/v1/workers/{a}")).await.problem(StatusCode::NOT_FOUND);

    api.submit(&tiled_job()).await;
    let held = lease(&api, &b).await;
    api.delete(&format!("/v1/workers/{b}")).await.expect(StatusCode::NO_CONTENT);
    let c = register(&api).await;
    let again = lease(&api, &c).await;
    assert_eq!(
        (again.tile, again.samples),
        (held.tile, held.samples),
        "b's unit is issued again at once"
    );
    let ids: Vec<Value> = api
        .get("/v1/workers")
        .await
        .json()
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w["id"].clone())
        .collect();
    assert_eq!(ids, [json!(c)], "only c is listed");
}

#[tokio::test]
async fn a_job_stays_with_the_renderer_that_started_it_and_its_status_names_it() {
    let api = Api::new("w-renderers");
    let as_renderer =
        |name: &str, renderer: &str| json!({"name": name, "threads": 1, "renderer": renderer});
    let old = api
        .post_json("/v1/workers", &as_renderer("old", "tessera 0.1.0 src:aaaa libm:0000"))
        .await
        .json()["worker_id"]
        .as_str()
        .unwrap()
        .to_string();
    let new = api
        .post_json("/v1/workers", &as_renderer("new", "tessera 0.1.0 src:bbbb libm:0000"))
        .await
        .json()["worker_id"]
        .as_str()
        .unwrap()
        .to_string();
    let workers = api.get("/v1/workers").await.json();
    let renderer_of = |id: &str| {
        workers.as_array().unwrap().iter().find(|w| w["id"] == id).unwrap()["renderer"].clone()
    };
    assert_eq!(renderer_of(&old), "tessera 0.1.0 src:aaaa libm:0000");
    assert_eq!(renderer_of(&new), "tessera 0.1.0 src:bbbb libm:0000");

    let idle_reason = axum::http::HeaderName::from_static(crate::routes::leases::IDLE_REASON);
    let nothing = api.post_json("/v1/leases", &json!({"worker_id": new})).await;
    nothing.expect(StatusCode::NO_CONTENT);
    assert_eq!(nothing.header(idle_reason.clone()), "", "no jobs: nothing to explain");

    let job = api.submit(&tiled_job()).await;
    let job_id = job["id"].as_str().unwrap();
    let l = lease(&api, &old).await;
    let refused = api.post_json("/v1/leases", &json!({"worker_id": new})).await;
    refused.expect(StatusCode::NO_CONTENT);
    assert_eq!(
        refused.header(idle_reason.clone()),
        format!(
            "jobs {job_id} are kept on renderer tessera 0.1.0 src:aaaa libm:0000 while a worker of it is live"
        ),
        "the 204 says why this worker idles beside a job with units left"
    );
    let workers = api.get("/v1/workers").await.json();
    let idle_reason_of = |id: &str| {
        workers
            .as_array()
            .unwrap()
            .iter()
            .find(|w| w["id"] == id)
            .unwrap()
            .get("idle_reason")
            .cloned()
    };
    assert_eq!(
        idle_reason_of(&new),
        Some(json!(refused.header(idle_reason.clone()))),
        "the workers list says it too"
    );
    assert_eq!(idle_reason_of(&old), None, "busy");
    put_result(&api, &l.lease_id, sums_for(&l, 1.0).encode()).await.expect(StatusCode::NO_CONTENT);
    assert_eq!(api.job(job_id).await["renderers"], json!(["tessera 0.1.0 src:aaaa libm:0000"]));
    api.post_json("/v1/leases", &json!({"worker_id": new})).await.expect(StatusCode::NO_CONTENT);
    assert_eq!(lease(&api, &old).await.job_id, job_id, "the job goes on with its own renderer");
}
