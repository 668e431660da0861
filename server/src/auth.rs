//! Bearer-token authentication: one token for clients, another for workers.
//!
//! | role   | routes                                                                 |
//! |--------|------------------------------------------------------------------------|
//! | open   | `GET /healthz`, the dashboard's static files (`/`, `/ui/…`: no data)   |
//! | worker | `POST /v1/workers`, `/v1/leases…`, `GET /v1/scenes/{id}/data`          |
//! | client | everything else (jobs, scenes, images, events, workers list, metrics, OpenAPI) |
//!
//! A role whose token is not configured is open. Tokens are compared in constant time.
use crate::error::AppError;
use crate::state::AppState;
use axum::extract::{Request, State};
use axum::http::{Method, StatusCode, header};
use axum::middleware::Next;
use axum::response::{IntoResponse, Response};
use subtle::ConstantTimeEq;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Open,
    Client,
    Worker,
}

pub fn role(method: &Method, path: &str) -> Role {
    let worker_route = path.starts_with("/v1/leases")
        || (path == "/v1/workers" && method == Method::POST)
        || (path.starts_with("/v1/scenes/") && path.ends_with("/data"));
    match path {
        "/healthz" => Role::Open,
        _ if crate::dashboard::is_static(path) => Role::Open,
        _ if worker_route => Role::Worker,
        _ => Role::Client,
    }
}

pub async fn require_token(State(st): State<AppState>, req: Request, next: Next) -> Response {
    let expected = match role(req.method(), req.uri().path()) {
        Role::Open => None,
        Role::Client => st.config.client_token.as_deref(),
        Role::Worker => st.config.worker_token.as_deref(),
    };
    if let Some(expected) = expected {
        let given = req
            .headers()
            .get(header::AUTHORIZATION)
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.strip_prefix("Bearer "));
        let ok = given.is_some_and(|g| bool::from(g.as_bytes().ct_eq(expected.as_bytes())));
        if !ok {
            let detail = if given.is_none() {
                "this route needs an Authorization: Bearer token"
            } else {
                "wrong token for this route"
            };
            let mut resp = AppError::new(StatusCode::UNAUTHORIZED, detail).into_response();
            resp.headers_mut()
                .insert(header::WWW_AUTHENTICATE, header::HeaderValue::from_static("Bearer"));
            return resp;
        }
    }
    next.run(req).await
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn routes_fall_into_the_right_roles() {
        assert_eq!(role(&Method::GET, "/healthz"), Role::Open);
        assert_eq!(role(&Method::POST, "/v1/leases"), Role::Worker);
        assert_eq!(role(&Method::PUT, "/v1/leases/l1-1/result"), Role::Worker);
        assert_eq!(role(&Method::POST, "/v1/workers"), Role::Worker);
        assert_eq!(role(&Method::GET, "/v1/workers"), Role::Client);
        assert_eq!(role(&Method::GET, "/v1/scenes/abc/data"), Role::Worker);
        assert_eq!(role(&Method::GET, "/v1/scenes/abc"), Role::Client);
        assert_eq!(role(&Method::POST, "/v1/jobs"), Role::Client);
        assert_eq!(role(&Method::GET, "/metrics"), Role::Client);
        assert_eq!(role(&Method::GET, "/"), Role::Open);
        assert_eq!(role(&Method::GET, "/ui/app.js"), Role::Open);
        assert_eq!(
            role(&Method::GET, "/ui/secret"),
            Role::Client,
            "only the dashboard's own files"
        );
    }
}
