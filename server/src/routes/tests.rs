//! In-process HTTP tests of the coordinator's API through `tower::ServiceExt::oneshot`: the shared
//! harness. The cases are in `tests_jobs.rs` (submit, validate, list, cancel, events),
//! `tests_scenes.rs`, `tests_workers.rs` (the worker protocol), `tests_images.rs` (images, jobs
//! that end on their own), `tests_service.rs` (health, metrics, OpenAPI, routing) and
//! `tests_durability.rs` (restarts, corrupt checkpoints, a full disk).
use crate::app::app;
use crate::state::{AppState, Config};
use axum::Router;
use axum::body::{Body, Bytes};
use axum::http::{HeaderMap, Method, Request, StatusCode, header};
use serde_json::{Value, json};
use std::path::PathBuf;
use tessera_proto::sums::CONTENT_TYPE;
use tessera_proto::{Lease, PartialSums, Problem, WirePixel};
use tower::ServiceExt;

/// A coordinator on a fresh data directory (removed on drop).
pub(super) struct Api {
    router: Router,
    pub state: AppState,
    pub(super) dir: PathBuf,
}

impl Api {
    pub fn new(name: &str) -> Api {
        Api::with_config(name, |_| {})
    }

    pub fn with_config(name: &str, tweak: impl FnOnce(&mut Config)) -> Api {
        let dir = std::env::temp_dir().join(format!("tessera-api-{}-{}", std::process::id(), name));
        let _ = std::fs::remove_dir_all(&dir);
        Api::open(dir, tweak)
    }

    /// A coordinator on an existing data directory.
    pub fn open(dir: PathBuf, tweak: impl FnOnce(&mut Config)) -> Api {
        let mut config = Config::new(dir.clone());
        tweak(&mut config);
        let state = AppState::new(config).expect("coordinator state");
        Api { router: app(state.clone()), state, dir }
    }

    /// Stops this coordinator as a crash would (no final checkpoint) and starts another on the
    /// same data directory.
    pub fn crash_and_reopen(mut self, tweak: impl FnOnce(&mut Config)) -> Api {
        let dir = std::mem::take(&mut self.dir);
        let state = std::sync::Arc::downgrade(&self.state.0);
        drop(self);
        // A background task of the old coordinator (a complete frame's image being written) may
        // still hold it, and with it the store's lock, which a crashed process would release.
        let deadline = std::time::Instant::now() + std::time::Duration::from_secs(10);
        while state.strong_count() > 0 && std::time::Instant::now() < deadline {
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        Api::open(dir, tweak)
    }

    pub fn dir(&self) -> &std::path::Path {
        &self.dir
    }

    pub async fn send(&self, req: Request<Body>) -> Resp {
        let res = self.router.clone().oneshot(req).await.expect("the router is infallible");
        let status = res.status();
        let headers = res.headers().clone();
        let body = axum::body::to_bytes(res.into_body(), usize::MAX).await.expect("response body");
        Resp { status, headers, body }
    }

    /// A GET whose body is left open, for streams (SSE).
    pub async fn stream(&self, uri: &str) -> axum::body::BodyDataStream {
        let req = Request::builder().uri(uri).body(Body::empty()).expect("request");
        let res = self.router.clone().oneshot(req).await.expect("the router is infallible");
        assert_eq!(res.status(), StatusCode::OK, "GET {uri}");
        res.into_body().into_data_stream()
    }

    pub async fn request(
        &self,
        method: Method,
        uri: &str,
        content_type: Option<&str>,
        body: impl Into<Body>,
    ) -> Resp {
        let mut req = Request::builder().method(method).uri(uri);
        if let Some(ct) = content_type {
            req = req.header(header::CONTENT_TYPE, ct);
        }
        self.send(req.body(body.into()).expect("request")).await
    }

    pub async fn get(&self, uri: &str) -> Resp {
        self.request(Method::GET, uri, None, Body::empty()).await
    }

    pub async fn delete(&self, uri: &str) -> Resp {
        self.request(Method::DELETE, uri, None, Body::empty()).await
    }

    pub async fn post_json(&self, uri: &str, v: &Value) -> Resp {
        self.request(
            Method::POST,
            uri,
            Some("application/json"),
            serde_json::to_vec(v).expect("json"),
        )
        .await
    }

    /// Submits a job and returns its JSON (asserting 202).
    pub async fn submit(&self, body: &Value) -> Value {
        let r = self.post_json("/v1/jobs", body).await;
        r.expect(StatusCode::ACCEPTED);
        r.json()
    }

    pub async fn job(&self, id: &str) -> Value {
        let r = self.get(&format!("/v1/jobs/{id}")).await;
        r.expect(StatusCode::OK);
        r.json()
    }

    pub async fn metric(&self, name: &str) -> String {
        let r = self.get("/metrics").await;
        r.expect(StatusCode::OK);
        let line = r.text().lines().find(|l| l.split(' ').next() == Some(name)).map(str::to_string);
        let line = line.unwrap_or_else(|| panic!("no metric {name} in:\n{}", r.text()));
        line.rsplit(' ').next().expect("value").to_string()
    }
}

impl Drop for Api {
    fn drop(&mut self) {
        if !self.dir.as_os_str().is_empty() {
            let _ = std::fs::remove_dir_all(&self.dir);
        }
    }
}

pub(super) struct Resp {
    pub status: StatusCode,
    pub headers: HeaderMap,
    pub body: Bytes,
}

impl Resp {
    pub fn text(&self) -> &str {
        std::str::from_utf8(&self.body).expect("UTF-8 body")
    }

    pub fn header(&self, name: header::HeaderName) -> &str {
        self.headers.get(&name).map(|v| v.to_str().expect("ASCII header")).unwrap_or("")
    }

    pub fn content_type(&self) -> &str {
        self.header(header::CONTENT_TYPE)
    }

    pub fn json(&self) -> Value {
        serde_json::from_slice(&self.body)
            .unwrap_or_else(|e| panic!("not JSON ({e}): {}", String::from_utf8_lossy(&self.body)))
    }

    #[track_caller]
    pub fn expect(&self, status: StatusCode) {
        assert_eq!(self.status, status, "body: {}", String::from_utf8_lossy(&self.body));
    }

    /// Asserts an RFC 9457 problem with this status and returns it.
    #[track_caller]
    pub fn problem(&self, status: StatusCode) -> Problem {
        self.expect(status);
        assert_eq!(
            self.content_type(),
            "application/problem+json",
            "body: {}",
            String::from_utf8_lossy(&self.body)
        );
        let p: Problem = serde_json::from_slice(&self.body).expect("problem body");
        assert_eq!(p.status, status.as_u16());
        assert_eq!(p.title, status.canonical_reason().unwrap());
        assert_eq!(p.kind, "about:blank");
        assert!(!p.detail.is_empty(), "{p:?}");
        p
    }
}

/// A small valid job on the bundled Cornell box, with `overrides` applied (null removes a key).
pub(super) fn job_body(overrides: Value) -> Value {
    let mut body = json!({"scene": "cornell-box", "width": 32, "height": 24, "spp": 4});
    for (k, v) in overrides.as_object().expect("object").clone() {
        if v.is_null() {
            body.as_object_mut().unwrap().remove(&k);
        } else {
            body[k] = v;
        }
    }
    body
}

/// A 20×12 job in 8-pixel tiles (3×2 tiles, the last column 4 wide, the last row 4 high),
/// 5 spp in batches of 3: 12 units.
pub(super) fn tiled_job() -> Value {
    job_body(json!({"width": 20, "height": 12, "spp": 5, "tile_size": 8, "batch_spp": 3}))
}

pub(super) fn cornell_bytes() -> Vec<u8> {
    std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes/cornell-box.gltf"))
        .expect("bundled scene")
}

pub(super) fn sha256_hex(bytes: &[u8]) -> String {
    use sha2::Digest;
    hex::encode(sha2::Sha256::digest(bytes))
}

// Worker side.

pub(super) async fn register(api: &Api) -> String {
    let r = api.post_json("/v1/workers", &json!({"name": "test-host", "threads": 2})).await;
    r.expect(StatusCode::CREATED);
    r.json()["worker_id"].as_str().expect("worker_id").to_string()
}

pub(super) async fn lease(api: &Api, worker: &str) -> Lease {
    next_lease(api, worker).await.expect("a lease, not 204 no work")
}

/// The worker's next lease, None when the coordinator has no work (204).
pub(super) async fn next_lease(api: &Api, worker: &str) -> Option<Lease> {
    let r = api.post_json("/v1/leases", &json!({"worker_id": worker})).await;
    if r.status == StatusCode::NO_CONTENT {
        return None;
    }
    r.expect(StatusCode::OK);
    Some(serde_json::from_slice(&r.body).expect("a lease"))
}

/// Sums for the lease where every sample has radiance `v` in every channel.
pub(super) fn sums_for(l: &Lease, v: f64) -> PartialSums {
    let n = l.samples[1] - l.samples[0];
    let p = WirePixel {
        sum: [v * n as f64; 3],
        sum_sq: [v * v * n as f64; 3],
        sum_lum_sq: v * v * n as f64,
        count: n as u64,
    };
    PartialSums {
        tile: l.tile,
        samples: l.samples,
        dropped: 0,
        max_weight: v,
        pixels: vec![p; l.tile.pixel_count()],
    }
}

pub(super) async fn put_result(api: &Api, lease_id: &str, body: Vec<u8>) -> Resp {
    api.request(Method::PUT, &format!("/v1/leases/{lease_id}/result"), Some(CONTENT_TYPE), body)
        .await
}

pub(super) async fn samples_done(api: &Api, job: &str) -> f64 {
    api.job(job).await["progress"]["samples_done"].as_f64().expect("samples_done")
}
mod auth;
mod bad_input;
mod bad_input_cases;
mod carried;
mod dashboard;
mod durability;
mod ended;
mod frame_release;
mod frames;
mod images;
mod jobs;
mod numerics;
mod scenes;
mod service;
mod workers;
