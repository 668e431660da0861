//! The coordinator's HTTP application: `app(state) -> Router` and `run(listener, state, shutdown)`.
use crate::routes::{events, health, jobs, leases, scenes};
use crate::state::AppState;
use axum::Router;
use axum::extract::DefaultBodyLimit;
use std::time::Duration;
use utoipa::OpenApi;
use utoipa_axum::router::OpenApiRouter;
use utoipa_axum::router::UtoipaMethodRouterExt;
use utoipa_axum::routes;

#[derive(OpenApi)]
#[openapi(info(title = "Tessera coordinator", description = "Distributed path-tracing render farm: clients submit jobs, workers lease units."))]
struct ApiDoc;

/// Largest JSON body on any route (jobs, leases, registrations).
const JSON_LIMIT: usize = 64 << 10;
/// Largest result body: a 1024×1024 tile of 64-byte pixels plus header.
const RESULT_LIMIT: usize = (1024 * 1024 * 64) + 4096;

pub fn app(state: AppState) -> Router {
    let scene_limit = state.config.max_scene_bytes;
    let (router, api) = OpenApiRouter::with_openapi(ApiDoc::openapi())
        .routes(routes!(scenes::upload).layer(DefaultBodyLimit::max(scene_limit)))
        .routes(routes!(scenes::describe))
        .routes(routes!(scenes::data))
        .routes(routes!(jobs::create, jobs::list))
        .routes(routes!(jobs::get, jobs::cancel))
        .routes(routes!(jobs::image_exr))
        .routes(routes!(jobs::preview_png))
        .routes(routes!(events::events))
        .routes(routes!(leases::register, leases::list))
        .routes(routes!(leases::lease))
        .routes(routes!(leases::heartbeat))
        .routes(routes!(leases::release))
        .routes(routes!(leases::result).layer(DefaultBodyLimit::max(RESULT_LIMIT)))
        .routes(routes!(health::healthz))
        .routes(routes!(health::metrics))
        .split_for_parts();
    let api = std::sync::Arc::new(api);
    router
        .route("/openapi.json", axum::routing::get(move || {
            let api = api.clone();
            async move { axum::Json(api.as_ref().clone()) }
        }))
        .layer(DefaultBodyLimit::max(JSON_LIMIT))
        .with_state(state)
}

/// Serves until `shutdown` resolves; a background task expires leases and time limits.
pub async fn run(listener: tokio::net::TcpListener, state: AppState, shutdown: impl std::future::Future<Output = ()> + Send + 'static) -> std::io::Result<()> {
    let ticker = tokio::spawn(tick_forever(state.clone()));
    let result = axum::serve(listener, app(state)).with_graceful_shutdown(shutdown).await;
    ticker.abort();
    result
}

async fn tick_forever(state: AppState) {
    let mut interval = tokio::time::interval(Duration::from_millis(200));
    loop {
        interval.tick().await;
        let finished = state.scheduler.lock().expect("lock").tick(state.now());
        for id in finished {
            let st = state.clone();
            let id2 = id.clone();
            let _ = tokio::task::spawn_blocking(move || st.finalize(&id2)).await;
            state.notify(&id);
        }
    }
}
