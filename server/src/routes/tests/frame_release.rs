//! An animation's frames leave the coordinator's memory as they complete: each complete frame's
//! EXR is written while the job goes on and its sums are dropped; restarts keep that straight.
use super::super::tests::*;
use axum::http::StatusCode;
use serde_json::{Value, json};
use tessera_proto::Lease;

/// Three frames (4, 6, 8) of 16×8 pixels in two 8×8 tiles, 2 spp in one batch: two units a frame.
fn three_frames() -> Value {
    let frames = json!({"start": 4, "end": 8, "step": 2, "fps": 2.0});
    job_body(
        json!({"scene": "cornell-animated", "width": 16, "height": 8, "spp": 2, "tile_size": 8, "batch_spp": 2, "frames": frames}),
    )
}

fn frame_released(api: &Api, id: &str, index: usize) -> bool {
    api.state.scheduler.lock().unwrap().job(id).unwrap().frame_released(index)
}

/// The frame's image is written in the background after the result's answer.
async fn wait_released(api: &Api, id: &str, index: usize) {
    for _ in 0..500 {
        if frame_released(api, id, index) {
            return;
        }
        tokio::time::sleep(std::time::Duration::from_millis(10)).await;
    }
    panic!("frame index {index} of {id} was not written within 5 s");
}

async fn leased_frame(api: &Api, w: &str, frame: u32) -> Lease {
    let l = lease(api, w).await;
    assert_eq!(l.frame, frame, "frame-major order with affinity");
    l
}

async fn merge(api: &Api, l: &Lease) {
    put_result(
        api,
        &l.lease_id,
        sums_for(l, f64::from(l.frame) / 8.0 + f64::from(l.tile.x0) / 64.0).encode(),
    )
    .await
    .expect(StatusCode::NO_CONTENT);
}

fn file(api: &Api, id: &str, n: u32) -> std::path::PathBuf {
    api.dir().join("jobs").join(format!("{id}.f{n:06}.exr"))
}

fn layers(exr: &[u8]) -> (Vec<[f32; 3]>, Vec<f32>) {
    let (img, _) = crate::output::decode_exr(exr).unwrap();
    (img.rgb, img.samples)
}

#[tokio::test]
async fn a_complete_frame_is_written_and_dropped_while_the_job_goes_on_and_after_a_restart() {
    let api = Api::new("frame-release");
    let w = register(&api).await;
    let id = api.submit(&three_frames()).await["id"].as_str().unwrap().to_string();
    let (a, b) = (leased_frame(&api, &w, 4).await, leased_frame(&api, &w, 4).await);
    merge(&api, &a).await;
    assert!(
        !frame_released(&api, &id, 0) && !file(&api, &id, 4).exists(),
        "half a frame stays in memory"
    );
    merge(&api, &b).await;
    wait_released(&api, &id, 0).await;
    assert_eq!(api.job(&id).await["state"], "running");
    let held: Vec<usize> = api
        .state
        .scheduler
        .lock()
        .unwrap()
        .job(&id)
        .unwrap()
        .tiles()
        .iter()
        .map(|t| t.merged.len())
        .collect();
    assert_eq!(held, [0, 0, 0, 0, 0, 0], "frame 4's sums are dropped, the others hold none yet");
    let served = api.get(&format!("/v1/jobs/{id}/frames/4/image.exr")).await;
    served.expect(StatusCode::OK);
    assert_eq!(
        served.body.as_ref(),
        std::fs::read(file(&api, &id, 4)).unwrap().as_slice(),
        "served from its file"
    );
    let (rgb, samples) = layers(&served.body);
    assert!(rgb[0] == [0.5; 3] && rgb[15] == [0.5 + 0.125; 3] && samples.iter().all(|s| *s == 2.0));
    api.get(&format!("/v1/jobs/{id}/frames/4/preview.png")).await.expect(StatusCode::OK);
    let status = api.job(&id).await;
    assert_eq!(
        (status["frames"][0]["done"].as_bool(), status["frames"][0]["samples_done"].as_f64()),
        (Some(true), Some(2.0))
    );

    let c = leased_frame(&api, &w, 6).await;
    merge(&api, &c).await;
    let partial = api.get(&format!("/v1/jobs/{id}/frames/6/image.exr")).await;
    assert_eq!(layers(&partial.body).1[0], 2.0, "a frame in flight is served from its merge");
    api.state.checkpoint().unwrap();

    let api = api.crash_and_reopen(|_| {});
    assert!(frame_released(&api, &id, 0), "the record says frame 4's image replaces its sums");
    assert_eq!(api.get(&format!("/v1/jobs/{id}/frames/4/image.exr")).await.body, served.body);
    let w = register(&api).await;
    let mut left = Vec::new();
    while let Some(l) = next_lease(&api, &w).await {
        left.push((l.frame, l.tile.x0));
        merge(&api, &l).await;
    }
    assert_eq!(left, [(6, 8), (8, 0), (8, 8)], "only the units not merged before");
    assert_eq!(api.job(&id).await["state"], "done");
    for (n, v) in [(4u32, 0.5f32), (6, 0.75), (8, 1.0)] {
        let r = api.get(&format!("/v1/jobs/{id}/frames/{n}/image.exr")).await;
        let (rgb, samples) = layers(&r.body);
        assert!(
            rgb[0] == [v; 3] && rgb[15] == [v + 0.125; 3] && samples.iter().all(|s| *s == 2.0),
            "frame {n}"
        );
    }
    assert!(api.state.scheduler.lock().unwrap().job(&id).unwrap().sums_released());
}

#[tokio::test]
async fn a_frame_written_after_the_last_checkpoint_is_rendered_again_after_a_crash() {
    let api = Api::new("frame-release-crash");
    let w = register(&api).await;
    let id = api.submit(&three_frames()).await["id"].as_str().unwrap().to_string();
    let (a, b) = (leased_frame(&api, &w, 4).await, leased_frame(&api, &w, 4).await);
    merge(&api, &a).await;
    api.state.checkpoint().unwrap();
    merge(&api, &b).await;
    wait_released(&api, &id, 0).await;
    let before = std::fs::read(file(&api, &id, 4)).unwrap();

    let api = api.crash_and_reopen(|_| {});
    assert!(
        !file(&api, &id, 4).exists(),
        "the file holds a merge the crash lost: removed at start"
    );
    let w = register(&api).await;
    let again = leased_frame(&api, &w, 4).await;
    assert_eq!(again.tile.x0, b.tile.x0, "the lost unit is issued again");
    merge(&api, &again).await;
    wait_released(&api, &id, 0).await;
    assert!(
        layers(&std::fs::read(file(&api, &id, 4)).unwrap()) == layers(&before),
        "the same pixels"
    );
}

#[tokio::test]
async fn only_a_time_limited_animation_is_bounded_by_its_pixels() {
    let api = Api::new("frame-limits");
    let long = |extra: Value| {
        let mut body = json!({"scene": "cornell-animated", "width": 1024, "height": 1024, "frames": {"start": 0, "end": 99}});
        body.as_object_mut().unwrap().extend(extra.as_object().unwrap().clone());
        job_body(body)
    };
    // 100 frames of 1 Mpx: more than the 2²⁶ pixels a job once held, 25,600 tiles.
    let r = api.post_json("/v1/jobs", &long(json!({"spp": 1}))).await;
    assert_eq!(r.status, StatusCode::ACCEPTED, "{}", String::from_utf8_lossy(&r.body));
    let p = api
        .post_json("/v1/jobs", &long(json!({"spp": null, "time_limit_s": 60.0})))
        .await
        .problem(StatusCode::BAD_REQUEST);
    assert!(
        p.field.as_deref() == Some("frames") && p.detail.contains("time-limited"),
        "{}",
        p.detail
    );
    let p = api
        .post_json("/v1/jobs", &long(json!({"spp": 1, "frames": {"start": 0, "end": 599}})))
        .await
        .problem(StatusCode::BAD_REQUEST);
    assert!(
        p.field.as_deref() == Some("frames") && p.detail.contains("131072 tiles per job"),
        "{}",
        p.detail
    );
}
