//! The coordinator's HTTP application: `app(state) -> Router` and `run(listener, state, shutdown)`.
use crate::error::AppError;
use crate::routes::{events, health, images, jobs, leases, scenes};
use crate::state::AppState;
use axum::Router;
use axum::extract::DefaultBodyLimit;
use axum::http::{StatusCode, header};
use axum::response::{IntoResponse, Response};
use std::time::Duration;
use utoipa::OpenApi;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::router::UtoipaMethodRouterExt;
use utoipa_axum::routes;

#[derive(OpenApi)]
#[openapi(info(
    title = "Tessera coordinator",
    description = "Distributed path-tracing render farm: clients submit jobs, workers lease units."
))]
struct ApiDoc;

/// Largest JSON body on any route (jobs, leases, registrations).
const JSON_LIMIT: usize = 64 << 10;
/// Largest result body: a 1024×1024 tile of 64-byte pixels plus header.
const RESULT_LIMIT: usize = (1024 * 1024 * 64) + 4096;

pub fn app(state: AppState) -> Router {
    let scene_limit = state.config.max_scene_bytes;
    let (router, api) = OpenApiRouter::with_openapi(ApiDoc::openapi())
        .routes(routes!(scenes::upload, scenes::list).layer(DefaultBodyLimit::max(scene_limit)))
        .routes(routes!(scenes::describe))
        .routes(routes!(scenes::data))
        .routes(routes!(jobs::create, jobs::list))
        .routes(routes!(jobs::get, jobs::cancel))
        .routes(routes!(jobs::pause))
        .routes(routes!(jobs::resume))
        .routes(routes!(images::image_exr))
        .routes(routes!(images::preview_png))
        .routes(routes!(images::frame_exr))
        .routes(routes!(images::frame_png))
        .routes(routes!(images::frames_zip))
        .routes(routes!(events::events))
        .routes(routes!(leases::register, leases::list))
        .routes(routes!(leases::deregister))
        .routes(routes!(leases::lease))
        .routes(routes!(leases::heartbeat))
        .routes(routes!(leases::release))
        .routes(routes!(leases::result).layer(DefaultBodyLimit::max(RESULT_LIMIT)))
        .routes(routes!(health::healthz))
        .routes(routes!(health::metrics))
        .split_for_parts();
    let api = std::sync::Arc::new(api);
    router
        .route(
            "/openapi.json",
            axum::routing::get(move || {
                let api = api.clone();
                async move { axum::Json(api.as_ref().clone()) }
            }),
        )
        .merge(crate::dashboard::router())
        .fallback(
            |uri: axum::http::Uri| async move { AppError::not_found(format!("no route {uri}")) },
        )
        .method_not_allowed_fallback(|| async {
            AppError::new(StatusCode::METHOD_NOT_ALLOWED, "this route does not take that method")
        })
        .layer(DefaultBodyLimit::max(JSON_LIMIT))
        .layer(axum::middleware::from_fn_with_state(state.clone(), crate::auth::require_token))
        .layer(axum::middleware::map_response(as_problem))
        .with_state(state)
}

/// Turns every error response that is not already problem+json (extractor rejections such as a
/// bad path or query, 413 from body limits) into one, keeping its status and message.
async fn as_problem(resp: Response) -> Response {
    let status = resp.status();
    let is_problem = resp
        .headers()
        .get(header::CONTENT_TYPE)
        .is_some_and(|v| v.as_bytes().starts_with(b"application/problem+json"));
    if !(status.is_client_error() || status.is_server_error()) || is_problem {
        return resp;
    }
    let body = axum::body::to_bytes(resp.into_body(), 64 << 10).await.unwrap_or_default();
    let text = String::from_utf8_lossy(&body).trim().to_string();
    let detail = if text.is_empty() {
        status.canonical_reason().unwrap_or("error").to_string()
    } else {
        text
    };
    AppError::new(status, detail).into_response()
}

/// How long open connections (e.g. SSE streams) may linger after shutdown is requested.
const SHUTDOWN_GRACE: Duration = Duration::from_secs(3);

/// Serves until `shutdown` resolves, then lets requests in flight finish (at most
/// `SHUTDOWN_GRACE`); a background task expires leases and time limits meanwhile.
pub async fn run(
    listener: tokio::net::TcpListener,
    state: AppState,
    shutdown: impl std::future::Future<Output = ()> + Send + 'static,
) -> std::io::Result<()> {
    let ticker = tokio::spawn(tick_forever(state.clone()));
    let checkpointer = tokio::spawn(checkpoint_forever(state.clone()));
    let (stopping_tx, mut stopping) = tokio::sync::watch::channel(false);
    let signal = async move {
        shutdown.await;
        let _ = stopping_tx.send(true);
    };
    let state_for_exit = state.clone();
    let serve = axum::serve(listener, app(state)).with_graceful_shutdown(signal);
    let result = tokio::select! {
        r = serve => r,
        _ = async {
            let _ = stopping.wait_for(|s| *s).await;
            tokio::time::sleep(SHUTDOWN_GRACE).await;
        } => Ok(()),
    };
    ticker.abort();
    checkpointer.abort();
    // What merged since the last checkpoint need not be rendered again after a restart.
    let st = state_for_exit;
    match tokio::task::spawn_blocking(move || st.checkpoint()).await {
        Ok(Err(e)) => tracing::error!("the last checkpoint failed: {e:#}"),
        Ok(Ok(n)) if n > 0 => tracing::info!(jobs = n, "state checkpointed"),
        _ => {}
    }
    result
}

async fn checkpoint_forever(state: AppState) {
    while let Some(pause) = state.durable.interval() {
        tokio::time::sleep(pause).await;
        let st = state.clone();
        if let Ok(Err(e)) = tokio::task::spawn_blocking(move || st.checkpoint()).await {
            tracing::error!("checkpoint failed (jobs stay in memory; retrying): {e:#}");
        }
    }
}

/// Ended jobs past `--delete-ended-after` are looked for every this many ticks (10 s).
const RETENTION_EVERY_TICKS: u64 = 50;

async fn tick_forever(state: AppState) {
    let mut interval = tokio::time::interval(Duration::from_millis(200));
    for n in 0u64.. {
        interval.tick().await;
        if state.config.delete_ended_after_ms.is_some() && n % RETENTION_EVERY_TICKS == 0 {
            let st = state.clone();
            let _ = tokio::task::spawn_blocking(move || st.delete_expired(crate::state::unix_ms()))
                .await;
        }
        state.scheduler.lock().expect("lock").tick(state.now());
        state.0.settle().await;
        // Expired leases put units back: let long-polling workers look again.
        state.work_available.notify_waiters();
    }
}
