//! The web dashboard: plain HTML, CSS and JavaScript modules compiled into the binary and served
//! at `/` and `/ui/…`, with no build step and nothing fetched from elsewhere.
//!
//! These files carry no data, so they are served without a token (see `auth::role`); the page asks
//! for the client token, keeps it in the browser's session storage and sends it as
//! `Authorization: Bearer …` on every API call it makes.
use crate::error::AppError;
use axum::Router;
use axum::extract::Path;
use axum::http::{HeaderValue, header};
use axum::response::{IntoResponse, Response};
use axum::routing::get;

/// `(file name under /ui/, content type, contents)`.
const ASSETS: &[(&str, &str, &str)] = &[
    ("style.css", "text/css; charset=utf-8", include_str!("style.css")),
    ("app.js", JS, include_str!("app.js")),
    ("api.js", JS, include_str!("api.js")),
    ("format.js", JS, include_str!("format.js")),
    ("jobs.js", JS, include_str!("jobs.js")),
    ("job.js", JS, include_str!("job.js")),
    ("chart.js", JS, include_str!("chart.js")),
    ("workers.js", JS, include_str!("workers.js")),
];
const JS: &str = "text/javascript; charset=utf-8";
const INDEX: &str = include_str!("index.html");

/// Only our own origin, for scripts, styles and API calls; images also from `blob:` URLs (previews
/// are fetched with the token, then shown from memory). Rules out any CDN by construction.
const CSP: &str = "default-src 'none'; script-src 'self'; style-src 'self'; img-src 'self' blob: data:; \
                   connect-src 'self'; base-uri 'none'; form-action 'none'; frame-ancestors 'none'";

/// The dashboard's routes, to merge into the application router.
pub fn router<S: Clone + Send + Sync + 'static>() -> Router<S> {
    Router::new().route("/", get(index)).route("/ui/{file}", get(asset))
}

/// Whether a request path is one of the dashboard's static files (served without a token).
pub fn is_static(path: &str) -> bool {
    path == "/"
        || path.strip_prefix("/ui/").is_some_and(|f| ASSETS.iter().any(|(name, _, _)| *name == f))
}

async fn index() -> Response {
    with_headers(INDEX, "text/html; charset=utf-8")
}

async fn asset(Path(file): Path<String>) -> Response {
    match ASSETS.iter().find(|(name, _, _)| *name == file) {
        Some((_, content_type, body)) => with_headers(body, content_type),
        None => AppError::not_found(format!("no dashboard file {file:?}")).into_response(),
    }
}

fn with_headers(body: &'static str, content_type: &'static str) -> Response {
    let mut resp = body.into_response();
    let h = resp.headers_mut();
    h.insert(header::CONTENT_TYPE, HeaderValue::from_static(content_type));
    // Revalidate each load, so a new binary's page never runs against stale modules.
    h.insert(header::CACHE_CONTROL, HeaderValue::from_static("no-cache"));
    h.insert(header::X_CONTENT_TYPE_OPTIONS, HeaderValue::from_static("nosniff"));
    h.insert(header::CONTENT_SECURITY_POLICY, HeaderValue::from_static(CSP));
    resp
}

/// Every asset, for tests.
pub fn files() -> impl Iterator<Item = (&'static str, &'static str)> {
    std::iter::once(("index.html", INDEX)).chain(ASSETS.iter().map(|(n, _, b)| (*n, *b)))
}
