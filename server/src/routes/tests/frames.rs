//! Jobs over a frame range through the HTTP API: per-frame status, images, files and zip.
use super::super::tests::*;
use axum::http::{Method, StatusCode};
use serde_json::json;

/// Three frames (4, 6, 8) of 8×8 pixels, one tile, 2 spp in one batch: one unit per frame.
fn three_frames() -> serde_json::Value {
    let frames = json!({"start": 4, "end": 8, "step": 2, "fps": 2.0});
    job_body(
        json!({"scene": "cornell-animated", "width": 8, "height": 8, "spp": 2, "tile_size": 8, "batch_spp": 2, "frames": frames}),
    )
}

#[tokio::test]
async fn a_frame_range_renders_every_frame_and_serves_each_one() {
    let api = Api::new("frames");
    let w = register(&api).await;
    let id = api.submit(&three_frames()).await["id"].as_str().unwrap().to_string();
    for _ in 0..3 {
        let l = lease(&api, &w).await;
        let body = sums_for(&l, f64::from(l.frame) / 8.0).encode();
        let req = axum::http::Request::builder()
            .method(Method::PUT)
            .uri(format!("/v1/leases/{}/result", l.lease_id))
            .header("content-type", tessera_proto::sums::CONTENT_TYPE)
            .header("x-tessera-prepare", if l.frame == 4 { "build" } else { "refit" })
            .header("x-tessera-prepare-ms", "12.5")
            .body(axum::body::Body::from(body))
            .unwrap();
        api.send(req).await.expect(StatusCode::NO_CONTENT);
    }
    let job = api.job(&id).await;
    assert_eq!(job["state"], "done");
    let frames = job["frames"].as_array().unwrap();
    assert_eq!(frames.iter().map(|f| f["frame"].as_u64().unwrap()).collect::<Vec<_>>(), [4, 6, 8]);
    assert_eq!(frames[1]["time_s"], 3.0, "frame 6 at 2 fps");
    assert!(frames.iter().all(|f| f["done"] == true && f["samples_done"] == 2.0));
    assert_eq!(
        (
            frames[0]["builds"].as_u64(),
            frames[1]["refits"].as_u64(),
            frames[2]["prepare_ms"].as_f64()
        ),
        (Some(1), Some(1), Some(12.5))
    );

    for n in [4u32, 6, 8] {
        let r = api.get(&format!("/v1/jobs/{id}/frames/{n}/image.exr")).await;
        r.expect(StatusCode::OK);
        let on_disk = std::fs::read(api.dir().join("jobs").join(format!("{id}.f{n:06}.exr")))
            .expect("frame file");
        assert_eq!(r.body.as_ref(), on_disk.as_slice());
        let (img, meta) = crate::output::decode_exr(&r.body).unwrap();
        assert!(img.rgb.iter().all(|p| *p == [n as f32 / 8.0; 3]), "frame {n} holds its own units");
        assert!(
            meta.contains(&("tessera.frame".into(), crate::output::MetaValue::Text(n.to_string())))
        );
        let png = api.get(&format!("/v1/jobs/{id}/frames/{n}/preview.png")).await;
        assert!(image::load_from_memory(&png.body).is_ok());
    }
    // The job's image is its first frame.
    assert_eq!(
        api.get(&format!("/v1/jobs/{id}/image.exr")).await.body,
        api.get(&format!("/v1/jobs/{id}/frames/4/image.exr")).await.body
    );
    let p =
        api.get(&format!("/v1/jobs/{id}/frames/5/image.exr")).await.problem(StatusCode::NOT_FOUND);
    assert!(p.detail.contains("has no frame 5"), "{}", p.detail);

    let zip = api.get(&format!("/v1/jobs/{id}/frames.zip")).await;
    zip.expect(StatusCode::OK);
    assert_eq!(zip.content_type(), "application/zip");
    let mut archive = zip::ZipArchive::new(std::io::Cursor::new(zip.body.to_vec())).unwrap();
    assert_eq!(archive.len(), 3);
    for n in [4u32, 6, 8] {
        let mut entry = archive.by_name(&format!("frame_{n:04}.exr")).unwrap();
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(&mut entry, &mut bytes).unwrap();
        assert_eq!(
            bytes,
            api.get(&format!("/v1/jobs/{id}/frames/{n}/image.exr")).await.body.to_vec()
        );
    }
}

/// A result with the worker's memory in `x-tessera-rss` / `x-tessera-peak-rss` (None: without).
async fn put_with_memory(api: &Api, l: &tessera_proto::Lease, memory: Option<(&str, &str)>) {
    let mut req = axum::http::Request::builder()
        .method(Method::PUT)
        .uri(format!("/v1/leases/{}/result", l.lease_id))
        .header("content-type", tessera_proto::sums::CONTENT_TYPE);
    if let Some((rss, peak)) = memory {
        req = req.header("x-tessera-rss", rss).header("x-tessera-peak-rss", peak);
    }
    api.send(req.body(axum::body::Body::from(sums_for(l, 0.5).encode())).unwrap())
        .await
        .expect(StatusCode::NO_CONTENT);
}

#[tokio::test]
async fn memory_reported_with_results_shows_on_the_worker_and_the_frame() {
    let api = Api::new("frames-memory");
    let w = register(&api).await;
    let id = api.submit(&three_frames()).await["id"].as_str().unwrap().to_string();
    assert!(
        api.get("/v1/workers").await.json()[0].get("rss_bytes").is_none(),
        "nothing reported yet"
    );
    let mut by_frame = std::collections::BTreeMap::new();
    for report in [Some(("100", "300")), None, Some(("5", "not a number"))] {
        let l = lease(&api, &w).await;
        by_frame.insert(l.frame, report);
        put_with_memory(&api, &l, report).await;
    }
    // The unreadable report is ignored: the worker keeps the last readable one.
    let w = api.get("/v1/workers").await.json()[0].clone();
    assert_eq!((w["rss_bytes"].as_u64(), w["peak_rss_bytes"].as_u64()), (Some(100), Some(300)));
    let job = api.job(&id).await;
    for f in job["frames"].as_array().unwrap() {
        let want = if by_frame[&(f["frame"].as_u64().unwrap() as u32)] == Some(("100", "300")) {
            json!(300)
        } else {
            json!(null)
        };
        assert_eq!(f["worker_peak_rss_bytes"], want, "{f}");
    }
}

#[tokio::test]
async fn a_still_has_one_frame_and_keeps_its_file_name() {
    let api = Api::new("frames-still");
    let w = register(&api).await;
    let id = api
        .submit(&job_body(
            json!({"width": 8, "height": 8, "spp": 2, "tile_size": 8, "batch_spp": 2}),
        ))
        .await["id"]
        .as_str()
        .unwrap()
        .to_string();
    let l = lease(&api, &w).await;
    assert_eq!(l.frame, 0);
    put_result(&api, &l.lease_id, sums_for(&l, 0.5).encode()).await.expect(StatusCode::NO_CONTENT);
    let job = api.job(&id).await;
    assert_eq!(job["frames"].as_array().unwrap().len(), 1);
    api.get(&format!("/v1/jobs/{id}/frames/0/image.exr")).await.expect(StatusCode::OK);
    assert!(api.dir().join("jobs").join(format!("{id}.exr")).exists());
}

#[tokio::test]
async fn a_frame_job_survives_a_coordinator_restart_frame_by_frame() {
    let api = Api::new("frames-restart");
    let w = register(&api).await;
    let id = api.submit(&three_frames()).await["id"].as_str().unwrap().to_string();
    let l = lease(&api, &w).await;
    put_result(&api, &l.lease_id, sums_for(&l, 0.75).encode()).await.expect(StatusCode::NO_CONTENT);
    let done_frame = l.frame;
    api.state.checkpoint().unwrap();
    let api = api.crash_and_reopen(|_| {});
    let job = api.job(&id).await;
    let frames = job["frames"].as_array().unwrap();
    let restored: Vec<u64> =
        frames.iter().filter(|f| f["done"] == true).map(|f| f["frame"].as_u64().unwrap()).collect();
    assert_eq!(restored, [u64::from(done_frame)], "the merged frame came back, the others did not");
    let w = register(&api).await;
    let mut left = Vec::new();
    while let Some(l) = next_lease(&api, &w).await {
        left.push(l.frame);
        put_result(&api, &l.lease_id, sums_for(&l, 0.75).encode())
            .await
            .expect(StatusCode::NO_CONTENT);
    }
    left.sort();
    assert_eq!(left.len(), 2);
    assert!(!left.contains(&done_frame));
    assert_eq!(api.job(&id).await["state"], "done");
}
