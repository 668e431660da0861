//! `/v1/jobs`: submit (every validation rule), read, list with pagination, cancel, events.
use super::super::tests::{
    Api, cornell_bytes, job_body, lease, put_result, register, sha256_hex, sums_for, tiled_job,
};
use axum::http::{Method, StatusCode, header};
use serde_json::{Value, json};

// ---------------------------------------------------------------------------------------------
// POST /v1/jobs

#[tokio::test]
async fn a_valid_job_is_accepted_queued_and_readable_at_its_location() {
    let api = Api::new("job-ok");
    let r = api.post_json("/v1/jobs", &job_body(json!({"seed": 7, "priority": 3}))).await;
    r.expect(StatusCode::ACCEPTED);
    assert_eq!(r.content_type(), "application/json");
    let job = r.json();
    let id = job["id"].as_str().expect("id").to_string();
    assert_eq!(r.header(header::LOCATION), format!("/v1/jobs/{id}"));
    assert_eq!(job["state"], "queued");
    assert_eq!(job["scene"], sha256_hex(&cornell_bytes()), "the scene is resolved to its hash");
    assert_eq!(job["request"]["seed"], 7);
    assert_eq!(job["request"]["priority"], 3);
    assert_eq!(job["progress"]["samples_done"], 0.0);
    assert_eq!(job["progress"]["samples_target"], 4.0);
    assert_eq!(job["workers"], 0);
    assert_eq!(job["noise"], Value::Null);
    let effects: Vec<&str> =
        job["effects"].as_array().unwrap().iter().map(|e| e.as_str().unwrap()).collect();
    assert!(effects.contains(&"area_lights") && !effects.contains(&"background"), "{effects:?}");

    let again = api.job(&id).await;
    assert_eq!(again["id"], id);
    assert_eq!(again["state"], "queued");
    assert_eq!(again["request"], job["request"]);
}

#[tokio::test]
async fn a_named_camera_and_every_estimator_and_sampler_are_accepted() {
    let api = Api::new("job-named");
    for estimator in ["naive", "bsdf", "light", "mis"] {
        for sampler in ["sobol", "independent"] {
            let job = api
                .submit(&job_body(
                    json!({"camera": "Camera", "estimator": estimator, "sampler": sampler}),
                ))
                .await;
            assert_eq!(
                (job["request"]["estimator"].as_str(), job["request"]["sampler"].as_str()),
                (Some(estimator), Some(sampler))
            );
        }
    }
    let only_noise = api.submit(&job_body(json!({"spp": null, "noise_target": 0.01}))).await;
    assert_eq!(only_noise["progress"]["samples_target"], 65536.0, "open-ended jobs aim at the cap");
    let only_time = api.submit(&job_body(json!({"spp": null, "time_limit_s": 2.5}))).await;
    assert_eq!(only_time["state"], "queued");
}

#[tokio::test]
async fn a_bright_background_is_listed_among_the_effects() {
    let api = Api::new("job-bg");
    let job = api.submit(&job_body(json!({"background": [0.5, 0.5, 0.5]}))).await;
    assert!(job["effects"].as_array().unwrap().contains(&json!("background")), "{job}");
}

/// `light_tree` is listed where the job's light samples go through a tree: by default where it
/// suits the scene (`many-lights`, not the Cornell box's quad), or as the job says. `auto` is
/// settled when the job is accepted, so the units (every frame of an animation alike) carry the
/// sampler the list describes.
#[tokio::test]
async fn the_light_sampler_decides_whether_the_light_tree_is_listed() {
    for (case, (scene, sampler, listed, settled)) in [
        ("cornell-box", None, false, "power"),
        ("cornell-box", Some("tree"), true, "tree"),
        ("cornell-box", Some("power"), false, "power"),
        ("many-lights", None, true, "tree"),
        ("many-lights", Some("auto"), true, "tree"),
        ("many-lights", Some("power"), false, "power"),
        ("cornell-animated", Some("auto"), false, "power"),
    ]
    .into_iter()
    .enumerate()
    {
        let api = Api::new(&format!("job-light-sampler-{case}"));
        let job = api.submit(&job_body(json!({"scene": scene, "light_sampler": sampler}))).await;
        let effects = job["effects"].as_array().unwrap();
        assert_eq!(
            effects.contains(&json!("light_tree")),
            listed,
            "{scene} {sampler:?}: {effects:?}"
        );
        assert!(effects.contains(&json!("area_lights")), "{scene}: {effects:?}");
        let worker = register(&api).await;
        let unit = lease(&api, &worker).await;
        assert_eq!(unit.params.light_sampler.as_deref(), Some(settled), "{scene} {sampler:?}");
    }
}

/// One test per invalid setting: 400 problem+json naming the field and saying what is wrong,
/// and nothing queued.
macro_rules! rejects {
    ($name:ident, $overrides:tt, $field:expr, [$($needle:expr),+]) => {
        #[tokio::test]
        async fn $name() {
            let api = Api::new(stringify!($name));
            let p = api.post_json("/v1/jobs", &job_body(json!($overrides))).await.problem(StatusCode::BAD_REQUEST);
            assert_eq!(p.field.as_deref(), Some($field), "{p:?}");
            $(assert!(p.detail.contains($needle), "detail {:?} should mention {:?}", p.detail, $needle);)+
            let list = api.get("/v1/jobs").await;
            list.expect(StatusCode::OK);
            assert_eq!(list.json()["jobs"], json!([]), "a refused job must not be queued");
        }
    };
}

rejects!(width_0_is_refused, {"width": 0}, "width", ["width", "1..=16384", "got 0"]);
rejects!(height_20000_is_refused, {"height": 20000}, "height", ["height", "1..=16384", "got 20000"]);
rejects!(too_many_pixels_is_refused, {"width": 8192, "height": 4096}, "width", ["width × height", "16777216"]);
rejects!(spp_0_is_refused, {"spp": 0}, "spp", ["spp must be in 1..=", "got 0"]);
rejects!(spp_above_the_cap_is_refused, {"spp": 2_000_000}, "spp", ["spp must be in 1..=1048576", "got 2000000"]);
rejects!(no_stop_condition_is_refused, {"spp": null}, "spp", ["stop condition", "noise_target", "time_limit_s"]);
rejects!(negative_noise_target_is_refused, {"spp": null, "noise_target": -0.01}, "noise_target", ["noise_target", "> 0"]);
rejects!(zero_noise_target_is_refused, {"noise_target": 0.0}, "noise_target", ["noise_target", "> 0"]);
rejects!(negative_time_limit_is_refused, {"spp": null, "time_limit_s": -5.0}, "time_limit_s", ["time_limit_s", "(0, 1e7]"]);
rejects!(huge_time_limit_is_refused, {"time_limit_s": 1e8}, "time_limit_s", ["time_limit_s", "(0, 1e7]"]);
rejects!(unknown_estimator_is_refused, {"estimator": "magic"}, "estimator", ["\"magic\"", "naive, bsdf, light, mis"]);
rejects!(unknown_sampler_is_refused, {"sampler": "halton"}, "sampler", ["halton", "sobol"]);
rejects!(unknown_light_sampler_is_refused, {"light_sampler": "bvh"}, "light_sampler", ["\"bvh\"", "auto, power, tree"]);
rejects!(tile_size_4_is_refused, {"tile_size": 4}, "tile_size", ["tile_size must be in 8..=1024", "got 4"]);
rejects!(batch_spp_0_is_refused, {"batch_spp": 0}, "batch_spp", ["batch_spp must be in 1..=4096", "got 0"]);
rejects!(max_depth_0_is_refused, {"max_depth": 0}, "max_depth", ["max_depth must be in 1..=65536", "got 0"]);
rejects!(roulette_depth_above_the_cap_is_refused, {"roulette_depth": 70000}, "roulette_depth", ["roulette_depth must be in 0..=65536", "got 70000"]);
rejects!(infinite_background_is_refused, {"background": [1e39, 0.0, 0.0]}, "background", ["background[0]", "out of range"]);
rejects!(negative_background_is_refused, {"background": [0.5, -1.0, 0.5]}, "background", ["background", "≥ 0"]);
rejects!(unknown_camera_is_refused, {"camera": "Nope"}, "camera", ["\"Nope\"", "\"Camera\""]);
rejects!(unknown_scene_is_refused, {"scene": "no-such-scene"}, "scene", ["\"no-such-scene\"", "/v1/scenes"]);
rejects!(unknown_json_field_is_refused, {"colour": 1}, "colour", ["unknown field `colour`"]);
rejects!(missing_required_field_is_refused, {"width": null}, "width", ["missing field `width`"]);

#[tokio::test]
async fn a_value_of_the_wrong_type_is_a_400_whose_detail_names_the_field() {
    let api = Api::new("job-wrong-type");
    let p = api
        .post_json("/v1/jobs", &job_body(json!({"width": "big"})))
        .await
        .problem(StatusCode::BAD_REQUEST);
    assert!(p.detail.contains("width") && p.detail.contains("invalid type"), "{p:?}");
}

#[tokio::test]
async fn a_value_of_the_wrong_type_names_the_field() {
    let api = Api::new("job-wrong-type-field");
    let p = api
        .post_json("/v1/jobs", &job_body(json!({"width": "big"})))
        .await
        .problem(StatusCode::BAD_REQUEST);
    assert_eq!(p.field.as_deref(), Some("width"), "{p:?}");
}

#[tokio::test]
async fn malformed_json_is_a_400_problem() {
    let api = Api::new("job-malformed");
    let r = api
        .request(
            Method::POST,
            "/v1/jobs",
            Some("application/json"),
            r#"{"scene": "cornell-box", "width": 3"#,
        )
        .await;
    let p = r.problem(StatusCode::BAD_REQUEST);
    assert!(p.detail.contains("JSON") && p.detail.contains("EOF"), "{p:?}");
    assert_eq!(p.field, None);
}

#[tokio::test]
async fn a_job_without_a_json_content_type_is_a_415_problem() {
    let api = Api::new("job-no-ct");
    let body = serde_json::to_vec(&job_body(json!({}))).unwrap();
    let p = api
        .request(Method::POST, "/v1/jobs", Some("text/plain"), body)
        .await
        .problem(StatusCode::UNSUPPORTED_MEDIA_TYPE);
    assert!(p.detail.contains("application/json"), "{p:?}");
}

#[tokio::test]
async fn a_job_body_over_64_kib_is_a_413_problem_and_one_just_under_is_read() {
    let api = Api::new("job-too-large");
    let big = job_body(json!({"scene": "x".repeat(65 << 10)}));
    let p = api.post_json("/v1/jobs", &big).await.problem(StatusCode::PAYLOAD_TOO_LARGE);
    assert!(p.detail.contains("length limit"), "{p:?}");
    // Just under the limit the body is parsed and judged on its content.
    let under = job_body(json!({"scene": "x".repeat(60 << 10)}));
    let p = api.post_json("/v1/jobs", &under).await.problem(StatusCode::BAD_REQUEST);
    assert_eq!(p.field.as_deref(), Some("scene"));
}

// ---------------------------------------------------------------------------------------------
// GET / DELETE /v1/jobs

#[tokio::test]
async fn unknown_jobs_are_404_problems_on_every_job_route() {
    let api = Api::new("job-404");
    for uri in [
        "/v1/jobs/j-nope",
        "/v1/jobs/j-nope/image.exr",
        "/v1/jobs/j-nope/preview.png",
        "/v1/jobs/j-nope/events",
    ] {
        let p = api.get(uri).await.problem(StatusCode::NOT_FOUND);
        assert!(p.detail.contains("\"j-nope\""), "{uri}: {p:?}");
    }
    let p = api.delete("/v1/jobs/j-nope").await.problem(StatusCode::NOT_FOUND);
    assert!(p.detail.contains("\"j-nope\""), "{p:?}");
}

#[tokio::test]
async fn jobs_are_listed_newest_first_with_next_page_links() {
    let api = Api::new("job-list");
    let mut ids = Vec::new();
    for seed in 0..3 {
        ids.push(
            api.submit(&job_body(json!({"seed": seed}))).await["id"].as_str().unwrap().to_string(),
        );
    }
    let ids_of = |v: &Value| -> Vec<String> {
        v["jobs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|j| j["id"].as_str().unwrap().to_string())
            .collect()
    };

    let all = api.get("/v1/jobs").await;
    all.expect(StatusCode::OK);
    assert_eq!(ids_of(&all.json()), [ids[2].clone(), ids[1].clone(), ids[0].clone()]);
    assert_eq!(all.json()["next"], Value::Null);

    let first = api.get("/v1/jobs?limit=2").await;
    first.expect(StatusCode::OK);
    let first = first.json();
    assert_eq!(ids_of(&first), [ids[2].clone(), ids[1].clone()]);
    assert_eq!(first["next"], ids[1].as_str());

    let second = api.get(&format!("/v1/jobs?limit=2&before={}", ids[1])).await;
    second.expect(StatusCode::OK);
    let second = second.json();
    assert_eq!(ids_of(&second), [ids[0].clone()]);
    assert_eq!(second["next"], Value::Null, "the last page has no next");
}

#[tokio::test]
async fn a_bad_list_query_is_a_400_problem() {
    let api = Api::new("job-list-bad-query");
    let p = api.get("/v1/jobs?limit=lots").await.problem(StatusCode::BAD_REQUEST);
    assert!(p.detail.contains("limit"), "{p:?}");
}

#[tokio::test]
async fn deleting_a_job_cancels_it() {
    let api = Api::new("job-cancel");
    let id = api.submit(&job_body(json!({}))).await["id"].as_str().unwrap().to_string();
    let r = api.delete(&format!("/v1/jobs/{id}")).await;
    r.expect(StatusCode::OK);
    let job = r.json();
    assert_eq!(job["id"], id.as_str());
    assert_eq!(job["state"], "canceled");
    assert_eq!(job["message"], "canceled by request");
    assert_eq!(api.job(&id).await["state"], "canceled");
    assert_eq!(api.metric("tessera_jobs{state=\"canceled\"}").await, "1");
}

#[tokio::test]
async fn the_events_of_an_ended_job_are_one_progress_event_then_end() {
    let api = Api::new("job-events");
    let id = api.submit(&job_body(json!({}))).await["id"].as_str().unwrap().to_string();
    api.delete(&format!("/v1/jobs/{id}")).await.expect(StatusCode::OK);
    let r = tokio::time::timeout(
        std::time::Duration::from_secs(5),
        api.get(&format!("/v1/jobs/{id}/events")),
    )
    .await
    .expect("the stream ends");
    r.expect(StatusCode::OK);
    assert!(r.content_type().starts_with("text/event-stream"), "{}", r.content_type());
    let text = r.text();
    let progress = text.find("event: progress").expect(text);
    let end = text.find("event: end").expect(text);
    assert!(progress < end, "{text}");
    assert!(
        text.contains("\"state\":\"canceled\"") && text.contains(&format!("data: {id}")),
        "{text}"
    );
}

/// Progress events are coalesced (at most one per `COALESCE`), but a job's end is streamed at
/// once. On tokio's paused clock: the `done` event carries no wait after the last merge.
#[tokio::test(start_paused = true)]
async fn the_end_of_a_job_is_streamed_without_waiting() {
    use futures_util::StreamExt;
    let api = Api::new("job-events-end");
    let w = register(&api).await;
    let id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let mut events = api.stream(&format!("/v1/jobs/{id}/events")).await;
    let first =
        String::from_utf8(events.next().await.expect("an event").expect("bytes").to_vec()).unwrap();
    assert!(first.contains("event: progress") && first.contains("\"state\":\"queued\""), "{first}");
    let reader = tokio::spawn(async move {
        let mut text = String::new();
        while let Some(chunk) = events.next().await {
            text.push_str(&String::from_utf8_lossy(&chunk.expect("bytes")));
            if text.contains("\"state\":\"done\"") {
                return (tokio::time::Instant::now(), text);
            }
        }
        panic!("the stream ended without the job's end: {text}");
    });
    let units: Vec<_> = futures_util::future::join_all((0..12).map(|_| lease(&api, &w))).await;
    let mut last_merge = tokio::time::Instant::now();
    for l in &units {
        last_merge = tokio::time::Instant::now();
        put_result(&api, &l.lease_id, sums_for(l, 0.5).encode())
            .await
            .expect(StatusCode::NO_CONTENT);
    }
    let (seen, text) = reader.await.unwrap();
    assert!(
        seen - last_merge < crate::routes::events::COALESCE / 10,
        "the end came {:?} after the last merge: {text}",
        seen - last_merge
    );
}
