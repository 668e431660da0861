//! Service routes: `/healthz`, `/metrics`, `/openapi.json`, and what unrouted requests get.
use super::super::tests::{Api, job_body};
use axum::body::Body;
use axum::http::{Method, StatusCode};
use serde_json::json;

#[tokio::test]
async fn healthz_says_ok() {
    let api = Api::new("healthz");
    let r = api.get("/healthz").await;
    r.expect(StatusCode::OK);
    assert_eq!(r.text(), "ok");
}

#[tokio::test]
async fn metrics_are_prometheus_text() {
    let api = Api::new("metrics");
    api.submit(&job_body(json!({}))).await;
    let r = api.get("/metrics").await;
    r.expect(StatusCode::OK);
    assert!(r.content_type().starts_with("text/plain"), "{}", r.content_type());
    assert!(
        r.text()
            .contains("# TYPE tessera_units_merged_total counter\ntessera_units_merged_total 0\n"),
        "{}",
        r.text()
    );
    assert_eq!(api.metric("tessera_jobs{state=\"queued\"}").await, "1");
    assert_eq!(api.metric("tessera_workers").await, "0");
}

#[tokio::test]
async fn metrics_count_workers_by_renderer_with_the_label_escaped() {
    let api = Api::new("metrics-renderers");
    for renderer in ["tessera 0.1.0 src:a libm:0", "tessera 0.1.0 src:a libm:0", "odd \"one\"\\"] {
        api.post_json("/v1/workers", &json!({"name": "w", "threads": 1, "renderer": renderer}))
            .await
            .expect(StatusCode::CREATED);
    }
    let r = api.get("/metrics").await;
    let text = r.text();
    assert!(
        text.contains("\ntessera_workers_by_renderer{renderer=\"tessera 0.1.0 src:a libm:0\"} 2\n"),
        "{text}"
    );
    assert!(
        text.contains("\ntessera_workers_by_renderer{renderer=\"odd \\\"one\\\"\\\\\"} 1\n"),
        "{text}"
    );
    assert_eq!(api.metric("tessera_workers").await, "3");
}

#[tokio::test]
async fn openapi_documents_every_route_the_router_serves() {
    let api = Api::new("openapi");
    let r = api.get("/openapi.json").await;
    r.expect(StatusCode::OK);
    let doc = r.json();
    let paths = doc["paths"].as_object().expect("paths");
    let served: [(&str, &[&str]); 21] = [
        ("/v1/jobs", &["get", "post"]),
        ("/v1/jobs/{id}", &["get", "delete"]),
        ("/v1/jobs/{id}/pause", &["post"]),
        ("/v1/jobs/{id}/resume", &["post"]),
        ("/v1/jobs/{id}/image.exr", &["get"]),
        ("/v1/jobs/{id}/preview.png", &["get"]),
        ("/v1/jobs/{id}/events", &["get"]),
        ("/v1/jobs/{id}/frames/{n}/image.exr", &["get"]),
        ("/v1/jobs/{id}/frames/{n}/preview.png", &["get"]),
        ("/v1/jobs/{id}/frames.zip", &["get"]),
        ("/v1/scenes", &["get", "post"]),
        ("/v1/scenes/{id}", &["get"]),
        ("/v1/scenes/{id}/data", &["get"]),
        ("/v1/workers", &["get", "post"]),
        ("/v1/workers/{id}", &["delete"]),
        ("/v1/leases", &["post"]),
        ("/v1/leases/{id}", &["delete"]),
        ("/v1/leases/{id}/heartbeat", &["post"]),
        ("/v1/leases/{id}/result", &["put"]),
        ("/healthz", &["get"]),
        ("/metrics", &["get"]),
    ];
    for (path, methods) in served {
        let item = paths.get(path).unwrap_or_else(|| {
            panic!("{path} is not documented; documented: {:?}", paths.keys().collect::<Vec<_>>())
        });
        for m in methods {
            assert!(item.get(*m).is_some(), "{path} lacks {m}");
        }
    }
    assert_eq!(
        paths.len(),
        served.len(),
        "documented paths: {:?}",
        paths.keys().collect::<Vec<_>>()
    );
    // Spot-check that schemas come along.
    assert!(doc["components"]["schemas"]["JobRequest"].is_object());
    assert!(doc["components"]["schemas"]["Problem"].is_object());
}

#[tokio::test]
async fn a_non_utf8_path_id_is_a_400_problem() {
    let api = Api::new("job-bad-path");
    api.get("/v1/jobs/%FF").await.problem(StatusCode::BAD_REQUEST);
}

#[tokio::test]
async fn merge_time_is_reported_in_seconds() {
    let api = Api::new("metrics-seconds");
    // Pretend one merge took 1.5 ms.
    api.state.counters.merge_nanos.store(1_500_000, std::sync::atomic::Ordering::Relaxed);
    let v: f64 = api.metric("tessera_merge_seconds_total").await.parse().expect("a number");
    assert_eq!(v, 0.0015);
}

#[tokio::test]
async fn unknown_routes_and_methods_are_problems() {
    let api = Api::new("no-route");
    let p = api.get("/v1/nope").await.problem(StatusCode::NOT_FOUND);
    assert!(p.detail.contains("/v1/nope"), "{p:?}");
    api.request(Method::PATCH, "/v1/jobs", None, Body::empty())
        .await
        .problem(StatusCode::METHOD_NOT_ALLOWED);
}
