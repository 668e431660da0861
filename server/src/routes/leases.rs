//! The worker protocol: register, lease, heartbeat, result, release (see tessera_proto::lease).
use crate::error::{AppError, Json};
use crate::scheduler::{Accepted, IdleReason, PrepareKind, ProcessMemory, ResultError};
use crate::state::AppState;
use axum::body::Bytes;
use axum::extract::{Path, Query, State};
use axum::http::{HeaderMap, StatusCode, header};
use axum::response::{IntoResponse, Response};
use std::sync::atomic::Ordering;
use tessera_proto::{
    Heartbeat, Lease, LeaseRequest, PartialSums, Problem, Registration, SUPPORTED_PROTOCOLS,
    WorkerHello, WorkerInfo, sums,
};

/// Register a worker; returns its id.
#[utoipa::path(post, path = "/v1/workers", tag = "workers", request_body = WorkerHello, responses((status = 201, body = Registration), (status = 400, body = Problem)))]
pub async fn register(
    State(st): State<AppState>,
    Json(hello): Json<WorkerHello>,
) -> Result<impl IntoResponse, AppError> {
    if !SUPPORTED_PROTOCOLS.contains(&hello.protocol) {
        return Err(AppError::field(
            "protocol",
            format!(
                "the worker speaks worker protocol {}; this coordinator speaks {}..={}: run workers and coordinator of one release",
                hello.protocol,
                SUPPORTED_PROTOCOLS.start(),
                SUPPORTED_PROTOCOLS.end()
            ),
        ));
    }
    if hello.name.len() > 256 {
        return Err(AppError::field("name", "name must be at most 256 bytes"));
    }
    if hello.threads == 0 || hello.threads > 4096 {
        return Err(AppError::field(
            "threads",
            format!("expected threads in 1..=4096 (got {})", hello.threads),
        ));
    }
    if hello.renderer.len() > 256 {
        return Err(AppError::field("renderer", "renderer must be at most 256 bytes"));
    }
    // It goes into logs, metrics labels and EXR headers verbatim.
    if hello.renderer.chars().any(char::is_control) {
        return Err(AppError::field("renderer", "renderer must not contain control characters"));
    }
    let id = st.scheduler.lock().expect("lock").register(
        &hello.name,
        hello.threads,
        &hello.renderer,
        st.now(),
    );
    tracing::info!(worker = %id, name = %hello.name, threads = hello.threads, renderer = %hello.renderer, "worker registered");
    let heartbeat_ms = (st.config.lease_timeout_ms / 3).max(100);
    Ok((
        StatusCode::CREATED,
        axum::Json(Registration { protocol: hello.protocol, worker_id: id, heartbeat_ms }),
    ))
}

/// A worker leaving (on shutdown): its leases go back to the queue at once, its long polls end,
/// and it leaves the list. 404 for a worker the coordinator does not know.
#[utoipa::path(delete, path = "/v1/workers/{id}", tag = "workers", params(("id" = String, Path)),
    responses((status = 204), (status = 404, body = Problem)))]
pub async fn deregister(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, AppError> {
    if !st.scheduler.lock().expect("lock").deregister_worker(&id) {
        return Err(AppError::not_found(format!("worker {id} is not registered")));
    }
    tracing::info!(worker = %id, "worker left");
    // Its units are back in the queue, and its own long poll must see that it is gone.
    st.work_available.notify_waiters();
    Ok(StatusCode::NO_CONTENT)
}

/// Connected workers.
#[utoipa::path(get, path = "/v1/workers", tag = "workers", responses((status = 200, body = Vec<WorkerInfo>)))]
pub async fn list(State(st): State<AppState>) -> axum::Json<Vec<WorkerInfo>> {
    let now = st.now();
    let s = st.scheduler.lock().expect("lock");
    axum::Json(
        s.workers()
            .map(|(id, w)| WorkerInfo {
                id: id.clone(),
                name: w.name.clone(),
                threads: w.threads,
                current: w.current.clone(),
                units_done: w.units_done,
                failures: w.failures,
                last_seen_ms_ago: now.saturating_sub(w.last_seen),
                renderer: w.renderer.clone(),
                idle_reason: w
                    .current
                    .is_none()
                    .then(|| s.idle_reason(id, now))
                    .flatten()
                    .map(|why| why.to_string()),
                rss_bytes: w.memory.map(|m| m.rss_bytes),
                peak_rss_bytes: w.memory.map(|m| m.peak_rss_bytes),
            })
            .collect(),
    )
}

#[derive(serde::Deserialize, utoipa::IntoParams)]
pub struct ResultQuery {
    /// Also lease the worker its next unit (no long poll): a merged result is then answered 200
    /// with the lease, or 204 when there is no work now.
    next: Option<bool>,
}

#[derive(serde::Deserialize, utoipa::IntoParams)]
pub struct LeaseQuery {
    /// Long poll: wait up to this many milliseconds (at most 5000) for work before answering 204.
    wait_ms: Option<u64>,
}

/// Take the next unit of work: 200 with a lease, 204 when there is none, 404 for unknown workers.
#[utoipa::path(post, path = "/v1/leases", tag = "workers", request_body = LeaseRequest, params(LeaseQuery),
    responses((status = 200, body = Lease), (status = 204, description = "no work now; `x-tessera-idle-reason` says why when jobs with units left refuse this worker"), (status = 404, body = Problem)))]
pub async fn lease(
    State(st): State<AppState>,
    Query(q): Query<LeaseQuery>,
    Json(req): Json<LeaseRequest>,
) -> Result<Response, AppError> {
    let deadline = tokio::time::Instant::now()
        + std::time::Duration::from_millis(q.wait_ms.unwrap_or(0).min(5000));
    let g = loop {
        // Register for wake-ups before looking, so work submitted in between is not missed.
        let woken = st.work_available.notified();
        tokio::pin!(woken);
        woken.as_mut().enable();
        let grant = st.scheduler.lock().expect("lock").lease(&req.worker_id, st.now());
        st.0.settle().await;
        match grant.map_err(AppError::not_found)? {
            Some(g) => break g,
            None if tokio::time::Instant::now() >= deadline => {
                let why = st.scheduler.lock().expect("lock").idle_reason(&req.worker_id, st.now());
                return Ok(no_work(why));
            }
            None => {
                let _ = tokio::time::timeout_at(deadline, woken).await;
            }
        }
    };
    st.counters.leases_granted.fetch_add(1, Ordering::Relaxed);
    st.notify(&g.job_id);
    Ok(axum::Json(g).into_response())
}

/// Answer header of a 204 to a worker that jobs with units left refuse: why (see
/// `scheduler::IdleReason`).
pub const IDLE_REASON: &str = "x-tessera-idle-reason";

/// 204, with the reason in [`IDLE_REASON`] when there is one. Header values are visible ASCII:
/// anything else (a renderer id may be any text) is shown as '?'.
fn no_work(why: Option<IdleReason>) -> Response {
    let mut resp = StatusCode::NO_CONTENT.into_response();
    if let Some(why) = why {
        let text: String = why
            .to_string()
            .chars()
            .map(|c| if c == ' ' || c.is_ascii_graphic() { c } else { '?' })
            .collect();
        if let Ok(v) = header::HeaderValue::from_str(&text) {
            resp.headers_mut().insert(IDLE_REASON, v);
        }
    }
    resp
}

/// Extend a lease; 409 when it is gone (expired or its job ended): stop rendering it.
#[utoipa::path(post, path = "/v1/leases/{id}/heartbeat", tag = "workers", params(("id" = String, Path)),
    responses((status = 200, body = Heartbeat), (status = 409, body = Problem)))]
pub async fn heartbeat(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<axum::Json<Heartbeat>, AppError> {
    let deadline = st.scheduler.lock().expect("lock").heartbeat(&id, st.now());
    st.0.settle().await;
    deadline.map(|deadline_ms| axum::Json(Heartbeat { deadline_ms })).ok_or_else(|| {
        AppError::new(StatusCode::CONFLICT, format!("lease {id} is no longer active"))
    })
}

/// Give a lease back unrendered.
#[utoipa::path(delete, path = "/v1/leases/{id}", tag = "workers", params(("id" = String, Path)),
    responses((status = 204), (status = 404, body = Problem)))]
pub async fn release(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<StatusCode, AppError> {
    if st.scheduler.lock().expect("lock").release(&id) {
        st.work_available.notify_waiters();
        Ok(StatusCode::NO_CONTENT)
    } else {
        Err(AppError::not_found(format!("lease {id} is not active")))
    }
}

/// Return a unit's partial sums (binary, `application/x-tessera-sums`); with `next=true`, also
/// take the next unit, saving the worker a lease request per unit.
#[utoipa::path(put, path = "/v1/leases/{id}/result", tag = "workers", params(("id" = String, Path), ResultQuery),
    request_body(content = Vec<u8>, content_type = "application/x-tessera-sums"),
    responses((status = 200, body = Lease, description = "merged, and the worker's next unit (`next=true`)"),
        (status = 204, description = "merged (and, with `next=true`, no work now)"), (status = 409, body = Problem), (status = 415, body = Problem), (status = 422, body = Problem)))]
pub async fn result(
    State(st): State<AppState>,
    Path(id): Path<String>,
    Query(q): Query<ResultQuery>,
    headers: HeaderMap,
    body: Bytes,
) -> Result<Response, AppError> {
    // A body sent as something else (JSON, text) is a client bug, not a bad unit: say so and
    // leave the lease alone.
    let ct = headers
        .get(header::CONTENT_TYPE)
        .map(|v| v.to_str().unwrap_or("?").split(';').next().unwrap_or("").trim());
    if ct.is_some_and(|ct| ct != sums::CONTENT_TYPE && ct != "application/octet-stream") {
        return Err(AppError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            format!("results are {} (got {:?})", sums::CONTENT_TYPE, ct.unwrap_or("")),
        ));
    }
    let sums = match PartialSums::decode(&body) {
        Ok(s) => s,
        Err(e) => {
            st.counters.results_malformed.fetch_add(1, Ordering::Relaxed);
            // A malformed body cannot be merged: the unit goes back to the queue.
            st.scheduler.lock().expect("lock").release(&id);
            return Err(AppError::new(
                StatusCode::UNPROCESSABLE_ENTITY,
                format!("malformed result: {e}"),
            ));
        }
    };
    let (outcome, next) = {
        let mut sched = st.scheduler.lock().expect("lock");
        if let Some((kind, ms)) = prepare_report(&headers) {
            sched.note_prepare(&id, kind, ms);
        }
        if let Some(memory) = memory_report(&headers) {
            sched.note_memory(&id, memory);
        }
        let t0 = std::time::Instant::now();
        let outcome = sched.complete(&id, sums, st.now());
        st.counters.merge_nanos.fetch_add(t0.elapsed().as_nanos() as u64, Ordering::Relaxed);
        // The worker's next unit in the same answer: one request per unit instead of two.
        let next = match &outcome {
            Ok(a) if q.next == Some(true) => {
                match sched.lease(&a.worker, st.now()).ok().flatten() {
                    Some(lease) => Ok(lease),
                    None => Err(sched.idle_reason(&a.worker, st.now())),
                }
            }
            _ => Err(None),
        };
        (outcome, next)
    };
    st.0.settle().await;
    match outcome {
        Ok(Accepted { job_id, merged, job_finished, frame_completed, .. }) => {
            if merged {
                st.counters.units_merged.fetch_add(1, Ordering::Relaxed);
                st.notify(&job_id);
            }
            if let Some(index) = frame_completed {
                // In the background: the worker's answer does not wait for the encoding.
                let (st2, id2) = (st.clone(), job_id.clone());
                tokio::task::spawn_blocking(move || st2.write_frame(&id2, index));
            }
            if job_finished {
                let st2 = st.clone();
                tokio::task::spawn_blocking(move || st2.finalize(&job_id))
                    .await
                    .map_err(AppError::internal)?;
            }
            Ok(match next {
                Ok(g) => {
                    st.counters.leases_granted.fetch_add(1, Ordering::Relaxed);
                    st.notify(&g.job_id);
                    axum::Json(g).into_response()
                }
                Err(why) => no_work(why),
            })
        }
        Err(ResultError::Stale(m)) => {
            st.counters.results_stale.fetch_add(1, Ordering::Relaxed);
            Err(AppError::new(StatusCode::CONFLICT, m))
        }
        Err(ResultError::Malformed(m)) => {
            st.counters.results_malformed.fetch_add(1, Ordering::Relaxed);
            Err(AppError::new(StatusCode::UNPROCESSABLE_ENTITY, m))
        }
    }
}

/// How the worker prepared the unit's scene, from the optional `x-tessera-prepare` (cached |
/// build | refit) and `x-tessera-prepare-ms` headers of a result. Absent or unreadable headers
/// are ignored: they are a report, not part of the result.
fn prepare_report(headers: &HeaderMap) -> Option<(PrepareKind, f64)> {
    let kind = match headers.get("x-tessera-prepare")?.to_str().ok()? {
        "cached" => PrepareKind::Cached,
        "build" => PrepareKind::Build,
        "refit" => PrepareKind::Refit,
        _ => return None,
    };
    let ms = headers
        .get("x-tessera-prepare-ms")
        .and_then(|v| v.to_str().ok()?.parse::<f64>().ok())
        .filter(|m| m.is_finite() && *m >= 0.0);
    Some((kind, ms.unwrap_or(0.0)))
}

/// The worker process's resident memory from the optional `x-tessera-rss` and
/// `x-tessera-peak-rss` headers of a result (bytes); like the prepare report, ignored unless both
/// are there and readable.
fn memory_report(headers: &HeaderMap) -> Option<ProcessMemory> {
    let bytes = |name: &str| headers.get(name)?.to_str().ok()?.parse::<u64>().ok();
    Some(ProcessMemory {
        rss_bytes: bytes("x-tessera-rss")?,
        peak_rss_bytes: bytes("x-tessera-peak-rss")?,
    })
}
