//! The mock coordinator the worker loop is tested against: axum on 127.0.0.1:0, serving the
//! bundled scenes, answering from a script and recording everything the worker sends.
use super::*;
use axum::extract::{Path, RawQuery, Request, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::middleware::{self, Next};
use axum::response::{IntoResponse, Response};
use axum::routing::{delete, get, post, put};
use axum::{Json, Router};
use std::collections::{HashSet, VecDeque};
use tessera_proto::{Heartbeat, LeaseRequest, Problem};

pub(super) enum Step {
    Lease(Box<Lease>),
    NoWork,
    /// Answer 404 and forget every worker, as a restarted coordinator would.
    Forget,
}

#[derive(Default)]
pub(super) struct Log {
    pub(super) registrations: u32,
    pub(super) known: HashSet<String>,
    pub(super) script: VecDeque<Step>,
    /// (when, worker id) of every lease request.
    pub(super) lease_requests: Vec<(Instant, String)>,
    pub(super) heartbeats: Vec<(Instant, String)>,
    /// Leases whose heartbeat answers 409, and when that first happened.
    pub(super) kill_on_heartbeat: HashSet<String>,
    pub(super) killed_at: Option<Instant>,
    /// Leases whose result answers 409.
    pub(super) stale_results: HashSet<String>,
    /// How many result uploads to answer 503 before accepting them.
    pub(super) failing_results: u32,
    /// Leases whose result upload takes half a second to answer.
    pub(super) slow_results: HashSet<String>,
    /// (lease id, content type, body, when it arrived) of every result upload.
    pub(super) results: Vec<(String, String, Vec<u8>, Instant)>,
    pub(super) released: Vec<String>,
    /// (when, worker id) of every deregistration.
    pub(super) deregistered: Vec<(Instant, String)>,
    pub(super) scene_downloads: u32,
    pub(super) unauthorized: u32,
    /// (lease id, x-tessera-prepare, x-tessera-prepare-ms) of every result upload.
    pub(super) prepared: Vec<(String, String, f64)>,
    /// (x-tessera-rss, x-tessera-peak-rss) of every result upload, as sent (empty when absent).
    pub(super) memory: Vec<(String, String)>,
    /// Answer a merged result that asks for the next lease (`?next=true`) with the script's next
    /// step, as the coordinator does; otherwise such results are answered 204 (no work now).
    pub(super) leases_with_results: bool,
    /// Leases handed out in a result's answer.
    pub(super) carried: Vec<String>,
    /// A result's answer that may carry a lease waits until this many lease requests have
    /// arrived: the worker sends its prefetch's request and its last upload concurrently, and
    /// the script's order must not depend on which the scheduler lets through first.
    pub(super) carry_after_lease_requests: usize,
    /// The protocol versions this coordinator registers (None: any).
    pub(super) speaks_protocols: Option<std::ops::RangeInclusive<u32>>,
    /// The renderer of every accepted registration.
    pub(super) renderers: Vec<String>,
}

pub(super) struct Mock {
    pub(super) heartbeat_ms: u64,
    pub(super) scene: Vec<u8>,
    pub(super) log: Mutex<Log>,
}

impl Mock {
    pub(super) fn new(heartbeat_ms: u64, script: Vec<Step>) -> Arc<Mock> {
        let log = Log { script: script.into(), ..Log::default() };
        Arc::new(Mock {
            heartbeat_ms,
            scene: std::fs::read(furnace_path()).unwrap(),
            log: Mutex::new(log),
        })
    }

    pub(super) fn log(&self) -> std::sync::MutexGuard<'_, Log> {
        self.log.lock().unwrap()
    }
}

pub(super) fn problem(status: StatusCode, detail: &str) -> Response {
    let p = Problem {
        kind: "about:blank".into(),
        title: status.to_string(),
        status: status.as_u16(),
        detail: detail.into(),
        field: None,
    };
    (
        status,
        [(header::CONTENT_TYPE, "application/problem+json")],
        serde_json::to_string(&p).unwrap(),
    )
        .into_response()
}

async fn auth(State(mock): State<Arc<Mock>>, req: Request, next: Next) -> Response {
    let expected = format!("Bearer {TOKEN}");
    if req.headers().get(header::AUTHORIZATION).and_then(|v| v.to_str().ok())
        != Some(expected.as_str())
    {
        mock.log().unauthorized += 1;
        return problem(StatusCode::UNAUTHORIZED, "missing or wrong token");
    }
    next.run(req).await
}

async fn register(State(mock): State<Arc<Mock>>, Json(hello): Json<WorkerHello>) -> Response {
    assert!(hello.threads >= 1);
    let mut log = mock.log();
    if let Some(speaks) = &log.speaks_protocols
        && !speaks.contains(&hello.protocol)
    {
        return problem(
            StatusCode::BAD_REQUEST,
            &format!(
                "protocol: the worker speaks worker protocol {}; this coordinator speaks {}..={}",
                hello.protocol,
                speaks.start(),
                speaks.end()
            ),
        );
    }
    log.renderers.push(hello.renderer.clone());
    log.registrations += 1;
    let worker_id = format!("w{}", log.registrations);
    log.known.insert(worker_id.clone());
    (
        StatusCode::CREATED,
        Json(Registration { protocol: hello.protocol, worker_id, heartbeat_ms: mock.heartbeat_ms }),
    )
        .into_response()
}

async fn lease(State(mock): State<Arc<Mock>>, Json(req): Json<LeaseRequest>) -> Response {
    let mut log = mock.log();
    log.lease_requests.push((Instant::now(), req.worker_id.clone()));
    if !log.known.contains(&req.worker_id) {
        return problem(StatusCode::NOT_FOUND, "unknown worker");
    }
    match log.script.pop_front() {
        Some(Step::Lease(l)) => Json(*l).into_response(),
        Some(Step::NoWork) | None => StatusCode::NO_CONTENT.into_response(),
        Some(Step::Forget) => {
            log.known.clear();
            problem(StatusCode::NOT_FOUND, "unknown worker")
        }
    }
}

async fn heartbeat(State(mock): State<Arc<Mock>>, Path(id): Path<String>) -> Response {
    let mut log = mock.log();
    let now = Instant::now();
    log.heartbeats.push((now, id.clone()));
    if log.kill_on_heartbeat.contains(&id) {
        log.killed_at.get_or_insert(now);
        return problem(StatusCode::CONFLICT, "lease expired or job canceled");
    }
    Json(Heartbeat { deadline_ms: 30_000 }).into_response()
}

async fn result(
    State(mock): State<Arc<Mock>>,
    Path(id): Path<String>,
    RawQuery(query): RawQuery,
    headers: HeaderMap,
    body: axum::body::Bytes,
) -> Response {
    let content_type =
        headers.get(header::CONTENT_TYPE).and_then(|v| v.to_str().ok()).unwrap_or("").to_owned();
    let slow = {
        let mut log = mock.log();
        log.results.push((id.clone(), content_type, body.to_vec(), Instant::now()));
        let header =
            |name: &str| headers.get(name).and_then(|v| v.to_str().ok()).unwrap_or("").to_owned();
        let ms = header("x-tessera-prepare-ms").parse().unwrap_or(f64::NAN);
        log.prepared.push((id.clone(), header("x-tessera-prepare"), ms));
        log.memory.push((header("x-tessera-rss"), header("x-tessera-peak-rss")));
        log.slow_results.contains(&id)
    };
    if slow {
        tokio::time::sleep(SLOW_RESULT).await;
    }
    {
        let mut log = mock.log();
        if log.failing_results > 0 {
            log.failing_results -= 1;
            return problem(StatusCode::SERVICE_UNAVAILABLE, "try again");
        }
    }
    let asks_for_next = query.as_deref() == Some("next=true");
    if asks_for_next {
        let wanted = mock.log().carry_after_lease_requests;
        wait_until("the lease requests sent before this result", Duration::from_secs(30), || {
            mock.log().lease_requests.len() >= wanted
        })
        .await;
    }
    let mut log = mock.log();
    if log.stale_results.contains(&id) {
        return problem(StatusCode::CONFLICT, "stale");
    }
    if !asks_for_next || !log.leases_with_results {
        return StatusCode::NO_CONTENT.into_response();
    }
    match log.script.pop_front() {
        Some(Step::Lease(l)) => {
            log.carried.push(l.lease_id.clone());
            Json(*l).into_response()
        }
        _ => StatusCode::NO_CONTENT.into_response(),
    }
}

async fn release(State(mock): State<Arc<Mock>>, Path(id): Path<String>) -> Response {
    mock.log().released.push(id);
    StatusCode::NO_CONTENT.into_response()
}

async fn deregister(State(mock): State<Arc<Mock>>, Path(id): Path<String>) -> Response {
    let mut log = mock.log();
    log.deregistered.push((Instant::now(), id.clone()));
    if log.known.remove(&id) {
        StatusCode::NO_CONTENT.into_response()
    } else {
        problem(StatusCode::NOT_FOUND, "unknown worker")
    }
}

async fn scene(State(mock): State<Arc<Mock>>, Path(id): Path<String>) -> Response {
    let bytes = match id.as_str() {
        SCENE_ID => mock.scene.clone(),
        ANIMATED_ID => std::fs::read(animated_path()).unwrap(),
        _ => return problem(StatusCode::NOT_FOUND, "no such scene"),
    };
    mock.log().scene_downloads += 1;
    bytes.into_response()
}

pub(super) async fn serve_on(mock: Arc<Mock>, listener: tokio::net::TcpListener) {
    let app = Router::new()
        .route("/v1/workers", post(register))
        .route("/v1/leases", post(lease))
        .route("/v1/leases/{id}/heartbeat", post(heartbeat))
        .route("/v1/leases/{id}/result", put(result))
        .route("/v1/leases/{id}", delete(release))
        .route("/v1/workers/{id}", delete(deregister))
        .route("/v1/scenes/{id}/data", get(scene))
        .layer(middleware::from_fn_with_state(mock.clone(), auth))
        .with_state(mock);
    tokio::spawn(async move { axum::serve(listener, app).await.unwrap() });
}

/// Starts a mock; returns its base URL.
pub(super) async fn start(mock: &Arc<Mock>) -> String {
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let base = format!("http://{}", listener.local_addr().unwrap());
    serve_on(mock.clone(), listener).await;
    base
}
