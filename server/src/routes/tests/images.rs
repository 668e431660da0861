//! Images of jobs (EXR and PNG preview, running and finished) and jobs that end on their own.
use super::super::tests::{Api, job_body, lease, put_result, register, sums_for, tiled_job};
use axum::http::{Method, StatusCode, header};
use serde_json::json;

#[tokio::test]
async fn a_running_jobs_exr_and_preview_show_what_is_merged() {
    let api = Api::new("w-images");
    let w = register(&api).await;
    let job_id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let l = lease(&api, &w).await;
    assert_eq!((l.tile.x0, l.tile.y0), (0, 0));
    put_result(&api, &l.lease_id, sums_for(&l, 1.0).encode()).await.expect(StatusCode::NO_CONTENT);
    assert_eq!(api.job(&job_id).await["state"], "running");

    let r = api.get(&format!("/v1/jobs/{job_id}/image.exr")).await;
    r.expect(StatusCode::OK);
    assert_eq!(r.content_type(), "image/x-exr");
    let (img, meta) = crate::output::decode_exr(&r.body).expect("a decodable EXR");
    assert_eq!((img.width, img.height), (20, 12));
    let at = |x: usize, y: usize| y * 20 + x;
    assert_eq!(img.rgb[at(3, 5)], [1.0; 3]);
    assert_eq!(img.samples[at(7, 7)], 3.0);
    assert_eq!(img.samples[at(8, 0)], 0.0, "outside the merged tile");
    assert_eq!(img.rgb[at(19, 11)], [0.0; 3]);
    let spp = meta.iter().find(|(k, _)| k == "tessera.spp").map(|(_, v)| v.clone());
    assert_eq!(spp, Some(crate::output::MetaValue::Double(3.0 * 64.0 / 240.0)));

    let r = api.get(&format!("/v1/jobs/{job_id}/preview.png")).await;
    r.expect(StatusCode::OK);
    assert_eq!(r.content_type(), "image/png");
    assert_eq!(r.header(header::CACHE_CONTROL), "no-store");
    let png = image::load_from_memory_with_format(&r.body, image::ImageFormat::Png)
        .expect("a decodable PNG")
        .to_rgb8();
    assert_eq!(png.dimensions(), (20, 12));
    assert_eq!(png.get_pixel(3, 5).0, [255; 3], "radiance 1 is white");
    assert_eq!(png.get_pixel(19, 11).0, [0; 3], "unrendered is black");
}

#[tokio::test]
async fn a_queued_jobs_images_are_black_with_no_samples() {
    let api = Api::new("w-images-queued");
    let job_id = api.submit(&job_body(json!({"width": 9, "height": 5}))).await["id"]
        .as_str()
        .unwrap()
        .to_string();
    let r = api.get(&format!("/v1/jobs/{job_id}/image.exr")).await;
    r.expect(StatusCode::OK);
    let (img, _) = crate::output::decode_exr(&r.body).expect("a decodable EXR");
    assert_eq!((img.width, img.height), (9, 5));
    assert!(img.samples.iter().all(|s| *s == 0.0) && img.rgb.iter().all(|p| *p == [0.0; 3]));
    let r = api.get(&format!("/v1/jobs/{job_id}/preview.png")).await;
    r.expect(StatusCode::OK);
    let png = image::load_from_memory_with_format(&r.body, image::ImageFormat::Png)
        .expect("a decodable PNG")
        .to_rgb8();
    assert_eq!(png.dimensions(), (9, 5));
    assert!(png.pixels().all(|p| p.0 == [0; 3]));
}

#[tokio::test]
async fn a_finished_job_serves_its_final_exr_and_writes_it_to_disk() {
    let api = Api::new("w-done");
    let w = register(&api).await;
    let job_id = api
        .submit(&job_body(
            json!({"width": 8, "height": 8, "spp": 2, "tile_size": 8, "batch_spp": 2}),
        ))
        .await["id"]
        .as_str()
        .unwrap()
        .to_string();
    let l = lease(&api, &w).await;
    put_result(&api, &l.lease_id, sums_for(&l, 0.25).encode()).await.expect(StatusCode::NO_CONTENT);
    let job = api.job(&job_id).await;
    assert_eq!(job["state"], "done");
    assert_eq!(job["progress"]["fraction"], 1.0);
    assert_eq!(job["progress"]["samples_done"], 2.0);
    api.post_json("/v1/leases", &json!({"worker_id": w})).await.expect(StatusCode::NO_CONTENT);

    let r = api.get(&format!("/v1/jobs/{job_id}/image.exr")).await;
    r.expect(StatusCode::OK);
    let on_disk = std::fs::read(api.dir().join("jobs").join(format!("{job_id}.exr")))
        .expect("the final EXR on disk");
    assert_eq!(r.body.as_ref(), on_disk.as_slice(), "the served image is the stored one");
    let (img, meta) = crate::output::decode_exr(&r.body).unwrap();
    assert!(img.rgb.iter().all(|p| *p == [0.25; 3]) && img.samples.iter().all(|s| *s == 2.0));
    let job_meta = meta.iter().find(|(k, _)| k == "tessera.job").map(|(_, v)| v.clone());
    assert_eq!(job_meta, Some(crate::output::MetaValue::Text(job_id.clone())));
    assert_eq!(api.metric("tessera_jobs{state=\"done\"}").await, "1");
    // Canceling a finished job does not change it.
    let r = api.delete(&format!("/v1/jobs/{job_id}")).await;
    r.expect(StatusCode::OK);
    assert_eq!(r.json()["state"], "done");
}

#[tokio::test]
async fn a_tile_that_reaches_its_noise_target_ends_the_job_and_revokes_later_batches() {
    let api = Api::new("w-noise");
    let w = register(&api).await;
    let job_id = api
        .submit(&job_body(json!({"width": 8, "height": 8, "spp": null, "noise_target": 0.01, "tile_size": 8, "batch_spp": 16})))
        .await["id"]
        .as_str()
        .unwrap()
        .to_string();
    let (b0, b1) = (lease(&api, &w).await, lease(&api, &w).await);
    assert_eq!((b0.samples, b1.samples), ([0, 16], [16, 32]));
    // A constant radiance has zero variance: relMSE 0 ≤ 0.01 after the first 16 samples.
    put_result(&api, &b0.lease_id, sums_for(&b0, 0.5).encode())
        .await
        .expect(StatusCode::NO_CONTENT);
    let job = api.job(&job_id).await;
    assert_eq!(job["state"], "done", "{job}");
    assert_eq!(job["progress"]["samples_done"], 16.0);
    assert_eq!(job["noise"], 0.0);
    api.request(Method::POST, &format!("/v1/leases/{}/heartbeat", b1.lease_id), None, "")
        .await
        .problem(StatusCode::CONFLICT);
    put_result(&api, &b1.lease_id, sums_for(&b1, 0.5).encode()).await.problem(StatusCode::CONFLICT);
    assert_eq!(
        api.job(&job_id).await["progress"]["samples_done"],
        16.0,
        "the unwanted batch is not merged"
    );
    assert!(
        api.dir().join("jobs").join(format!("{job_id}.exr")).exists(),
        "the final EXR is written"
    );
}

#[tokio::test]
async fn a_job_ended_by_its_time_limit_during_a_request_writes_its_final_exr() {
    let api = Api::new("w-time-limit");
    let w = register(&api).await;
    let job_id = api.submit(&job_body(json!({"spp": null, "time_limit_s": 0.001}))).await["id"]
        .as_str()
        .unwrap()
        .to_string();
    lease(&api, &w).await; // starts the 1 ms clock
    tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    // No background ticker runs here: the lease request's own tick ends the job.
    api.post_json("/v1/leases", &json!({"worker_id": w})).await.expect(StatusCode::NO_CONTENT);
    let job = api.job(&job_id).await;
    assert_eq!(
        (job["state"].as_str(), job["message"].as_str()),
        (Some("done"), Some("time limit reached"))
    );
    assert!(
        api.dir().join("jobs").join(format!("{job_id}.exr")).exists(),
        "a done job's final EXR must be written"
    );
}
