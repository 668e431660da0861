//! `/v1/jobs`: submit, list, read, pause, resume, cancel, delete (the images of a job are in `images.rs`).
use super::validate::job_config;
use crate::error::{AppError, Json};
use crate::state::{AppState, job_status};
use axum::extract::{Path, Query, State};
use axum::http::{StatusCode, header};
use axum::response::IntoResponse;
use serde::Deserialize;
use tessera_proto::{Job, JobList, JobRequest, Problem};

/// Submit a job. At least one stop condition (spp, noise_target, time_limit_s).
#[utoipa::path(post, path = "/v1/jobs", tag = "jobs", request_body = JobRequest,
    responses((status = 202, body = Job, headers(("Location" = String))), (status = 400, body = Problem)))]
pub async fn create(
    State(st): State<AppState>,
    Json(req): Json<JobRequest>,
) -> Result<impl IntoResponse, AppError> {
    let scene = st.scenes.resolve(&req.scene).ok_or_else(|| {
        AppError::field(
            "scene",
            format!("no scene {:?} (upload it to /v1/scenes or use a bundled name)", req.scene),
        )
    })?;
    let id = st.new_job_id();
    let created = crate::state::unix_ms();
    let cfg = job_config(id.clone(), req, &scene, created)?;
    let job = {
        let mut s = st.scheduler.lock().expect("lock");
        s.submit(cfg);
        job_status(s.job(&id).expect("just submitted"), st.now(), 0, s.max_failures())
    };
    // Accepted means durable: a job the store could not take is not accepted at all.
    let st2 = st.clone();
    if let Err(e) =
        tokio::task::spawn_blocking(move || st2.checkpoint()).await.map_err(AppError::internal)?
    {
        st.scheduler.lock().expect("lock").forget(&id);
        return Err(AppError::new(
            StatusCode::SERVICE_UNAVAILABLE,
            format!("the job could not be stored, so it was not accepted: {e:#}"),
        ));
    }
    st.notify(&id);
    st.work_available.notify_waiters();
    tracing::info!(job = %id, scene = %scene.id, "job accepted");
    Ok((StatusCode::ACCEPTED, [(header::LOCATION, format!("/v1/jobs/{id}"))], axum::Json(job)))
}

#[derive(Deserialize, utoipa::IntoParams)]
pub struct ListQuery {
    /// Page size (default 50, at most 500).
    limit: Option<usize>,
    /// Only jobs older than this job id (from a previous page's `next`).
    before: Option<String>,
}

/// Jobs, newest first, paginated.
#[utoipa::path(get, path = "/v1/jobs", tag = "jobs", params(ListQuery), responses((status = 200, body = JobList)))]
pub async fn list(State(st): State<AppState>, Query(q): Query<ListQuery>) -> axum::Json<JobList> {
    let limit = q.limit.unwrap_or(50).clamp(1, 500);
    let s = st.scheduler.lock().expect("lock");
    let now = st.now();
    let mut iter =
        s.jobs_newest_first().skip_while(|j| q.before.as_ref().is_some_and(|b| &j.cfg().id != b));
    if q.before.is_some() {
        iter.next();
    }
    let page: Vec<Job> = iter
        .take(limit + 1)
        .map(|j| job_status(j, now, s.workers_on(&j.cfg().id), s.max_failures()))
        .collect();
    let next = (page.len() > limit).then(|| page[limit - 1].id.clone());
    axum::Json(JobList { jobs: page.into_iter().take(limit).collect(), next })
}

/// A job's state, progress, noise and history.
#[utoipa::path(get, path = "/v1/jobs/{id}", tag = "jobs", params(("id" = String, Path)), responses((status = 200, body = Job), (status = 404, body = Problem)))]
pub async fn get(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<axum::Json<Job>, AppError> {
    status_of(&st, &id).map(axum::Json)
}

pub fn status_of(st: &AppState, id: &str) -> Result<Job, AppError> {
    let s = st.scheduler.lock().expect("lock");
    let job = s.job(id).ok_or_else(|| AppError::not_found(format!("no job {id:?}")))?;
    Ok(job_status(job, st.now(), s.workers_on(id), s.max_failures()))
}

/// `DELETE /v1/jobs/{id}` options.
#[derive(Debug, Deserialize, utoipa::IntoParams)]
pub struct DeleteQuery {
    /// Also delete the job for good: its record, checkpoints and images (it is canceled first
    /// if it still runs). Without it the job is only canceled, and stays listed with its images.
    pub purge: Option<bool>,
}

/// Cancel a job (its workers are told within one heartbeat); with `?purge=true`, delete it.
#[utoipa::path(delete, path = "/v1/jobs/{id}", tag = "jobs", params(("id" = String, Path), DeleteQuery),
    responses((status = 200, body = Job, description = "canceled"), (status = 204, description = "deleted (purge)"), (status = 404, body = Problem)))]
pub async fn cancel(
    State(st): State<AppState>,
    Path(id): Path<String>,
    Query(q): Query<DeleteQuery>,
) -> Result<axum::response::Response, AppError> {
    if q.purge == Some(true) {
        let (st2, id2) = (st.clone(), id.clone());
        let found = tokio::task::spawn_blocking(move || st2.purge(&id2))
            .await
            .map_err(AppError::internal)?
            .map_err(AppError::internal)?;
        if !found {
            return Err(AppError::not_found(format!("no job {id:?}")));
        }
        st.notify(&id);
        return Ok(StatusCode::NO_CONTENT.into_response());
    }
    st.scheduler
        .lock()
        .expect("lock")
        .cancel(&id, st.now())
        .ok_or_else(|| AppError::not_found(format!("no job {id:?}")))?;
    let answer = changed(st.clone(), id.clone(), "cancel").await;
    // Its images are final now: written in the background, after which its sums are dropped.
    tokio::task::spawn_blocking(move || st.finalize(&id));
    answer.map(IntoResponse::into_response)
}

/// Pause a job: it is leased no new units (other jobs get the workers); units already leased
/// finish and are merged, and its render time and time limit stop until it is resumed.
#[utoipa::path(post, path = "/v1/jobs/{id}/pause", tag = "jobs", params(("id" = String, Path)),
    responses((status = 200, body = Job), (status = 404, body = Problem), (status = 409, body = Problem)))]
pub async fn pause(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<axum::Json<Job>, AppError> {
    set_paused(st, id, true).await
}

/// Resume a paused job (`queued` until a worker takes its next unit).
#[utoipa::path(post, path = "/v1/jobs/{id}/resume", tag = "jobs", params(("id" = String, Path)),
    responses((status = 200, body = Job), (status = 404, body = Problem), (status = 409, body = Problem)))]
pub async fn resume(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<axum::Json<Job>, AppError> {
    set_paused(st, id, false).await
}

async fn set_paused(st: AppState, id: String, pause: bool) -> Result<axum::Json<Job>, AppError> {
    let outcome = st.scheduler.lock().expect("lock").set_paused(&id, pause, st.now());
    match outcome {
        None => return Err(AppError::not_found(format!("no job {id:?}"))),
        Some(Err(state)) => {
            let verb = if pause { "paused" } else { "resumed" };
            return Err(AppError::new(
                StatusCode::CONFLICT,
                format!("job {id} has ended ({}) and cannot be {verb}", state.name()),
            ));
        }
        Some(Ok(_)) => {}
    }
    let job = changed(st.clone(), id, if pause { "pause" } else { "resume" }).await;
    if !pause {
        st.work_available.notify_waiters();
    }
    job
}

/// After a change of a job's state by request: writes a checkpoint (a failure is logged and
/// retried by the next one), tells the job's watchers, and answers with the job.
async fn changed(st: AppState, id: String, what: &str) -> Result<axum::Json<Job>, AppError> {
    let st2 = st.clone();
    if let Ok(Err(e)) = tokio::task::spawn_blocking(move || st2.checkpoint()).await {
        tracing::error!(job = %id, "the {what} is not yet durable (retried at the next checkpoint): {e:#}");
    }
    st.notify(&id);
    get(State(st), Path(id)).await
}
