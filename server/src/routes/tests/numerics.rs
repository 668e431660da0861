//! Issue #5 as clients see it: a dropped non-finite sample is counted in the job status and the
//! EXR (case 13), and every bundled scene renders with none dropped and a finite largest weight.
use super::super::tests::{Api, job_body, lease, put_result, register, sums_for};
use crate::output::MetaValue;
use axum::http::StatusCode;
use serde_json::json;
use tessera_proto::{JobRequest, JobState};

/// The tracer drops a NaN/Inf sample and counts it (worker `tracer/numerics/accumulation.rs`,
/// case 13); here a unit reports one such sample in its header: pixel 0 counts 3 of its 4.
#[tokio::test]
async fn a_dropped_sample_is_counted_in_the_status_and_the_exr_and_the_image_stays_finite() {
    let api = Api::new("num-dropped");
    let w = register(&api).await;
    let job_id = api
        .submit(&job_body(
            json!({"width": 8, "height": 8, "spp": 4, "tile_size": 8, "batch_spp": 4}),
        ))
        .await["id"]
        .as_str()
        .unwrap()
        .to_string();
    let l = lease(&api, &w).await;
    let mut sums = sums_for(&l, 0.25);
    let p = &mut sums.pixels[0];
    (p.sum, p.sum_sq, p.sum_lum_sq, p.count) = ([0.75; 3], [0.1875; 3], 0.1875, 3);
    sums.dropped = 1;
    put_result(&api, &l.lease_id, sums.encode()).await.expect(StatusCode::NO_CONTENT);

    let job = api.job(&job_id).await;
    assert_eq!(job["state"], "done", "{job}");
    assert_eq!(job["dropped_samples"], 1);
    assert_eq!(job["max_sample_weight"], 0.25);
    let r = api.get(&format!("/v1/jobs/{job_id}/image.exr")).await;
    r.expect(StatusCode::OK);
    let (img, meta) = crate::output::decode_exr(&r.body).expect("a decodable EXR");
    let dropped = meta.iter().find(|(k, _)| k == "tessera.dropped_samples").map(|(_, v)| v.clone());
    assert_eq!(dropped, Some(MetaValue::Text("1".into())));
    assert!(
        img.rgb.iter().chain(&img.variance).flatten().all(|v| v.is_finite()),
        "the image is finite"
    );
    // The dropped sample weighs nothing: pixel 0 is the mean of its 3 kept samples.
    assert_eq!((img.rgb[0], img.samples[0], img.samples[1]), ([0.25; 3], 3.0, 4.0));
}

/// Renders each bundled scene small with each estimator on an in-process farm (coordinator +
/// worker over HTTP).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_bundled_scene_renders_with_no_dropped_samples() {
    let dir = std::env::temp_dir().join(format!("tessera-num-bundled-{}", std::process::id()));
    let report = crate::local::with_local_farm(&dir, 2, |c| async move {
        let mut rows = Vec::new();
        for name in crate::bundled::names() {
            for estimator in ["naive", "bsdf", "light", "mis"] {
                let req = JobRequest {
                    scene: name.into(),
                    width: 24,
                    height: 16,
                    spp: Some(16),
                    estimator: Some(estimator.into()),
                    ..JobRequest::default()
                };
                let job = c.wait(&c.submit(&req).await?.id, |_| {}).await?;
                rows.push((format!("{name} ({estimator})"), job));
            }
        }
        Ok(rows)
    })
    .await
    .expect("the farm renders");
    let _ = std::fs::remove_dir_all(&dir);
    for (name, job) in &report {
        eprintln!(
            "{name}: {:?}, {} dropped, largest sample weight {}",
            job.state, job.dropped_samples, job.max_sample_weight
        );
        assert_eq!(job.state, JobState::Done, "{name}: {:?}", job.message);
        assert_eq!(job.dropped_samples, 0, "{name}");
        assert!(
            job.max_sample_weight.is_finite() && job.max_sample_weight > 0.0,
            "{name}: {}",
            job.max_sample_weight
        );
    }
    assert_eq!(report.len(), crate::bundled::names().len() * 4);
}
