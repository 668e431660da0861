//! With tokens set, every route but /healthz refuses a missing or wrong token (401).
use super::super::tests::Api;
use axum::body::Body;
use axum::http::{Method, Request, StatusCode, header};

fn with_tokens(name: &str) -> Api {
    Api::with_config(name, |c| {
        c.client_token = Some("client-secret".into());
        c.worker_token = Some("worker-secret".into());
    })
}

async fn call(api: &Api, method: &Method, path: &str, token: Option<&str>) -> StatusCode {
    let mut req = Request::builder().method(method.clone()).uri(path);
    if let Some(t) = token {
        req = req.header(header::AUTHORIZATION, format!("Bearer {t}"));
    }
    api.send(req.body(Body::empty()).unwrap()).await.status
}

/// Every (method, path) the OpenAPI document lists, with path parameters filled in.
async fn documented_routes(api: &Api) -> Vec<(Method, String)> {
    let resp = call_json(api, "/openapi.json").await;
    let mut routes = Vec::new();
    for (path, ops) in resp["paths"].as_object().expect("paths") {
        for method in ops.as_object().unwrap().keys() {
            let m = Method::from_bytes(method.to_uppercase().as_bytes()).unwrap();
            routes.push((m, path.replace("{id}", "x")));
        }
    }
    routes
}

async fn call_json(api: &Api, path: &str) -> serde_json::Value {
    let req = Request::get(path)
        .header(header::AUTHORIZATION, "Bearer client-secret")
        .body(Body::empty())
        .unwrap();
    let r = api.send(req).await;
    assert_eq!(r.status, StatusCode::OK);
    serde_json::from_slice(&r.body).unwrap()
}

#[tokio::test]
async fn every_documented_route_but_healthz_needs_its_token() {
    let api = with_tokens("auth-all");
    let routes = documented_routes(&api).await;
    assert!(routes.len() >= 15, "{routes:?}");
    for (method, path) in routes {
        let no_token = call(&api, &method, &path, None).await;
        let wrong = call(&api, &method, &path, Some("guess")).await;
        if path == "/healthz" {
            assert_eq!(no_token, StatusCode::OK);
            continue;
        }
        assert_eq!(no_token, StatusCode::UNAUTHORIZED, "{method} {path} without a token");
        assert_eq!(wrong, StatusCode::UNAUTHORIZED, "{method} {path} with a wrong token");
        let role = crate::auth::role(&method, &path);
        let (right, other) = match role {
            crate::auth::Role::Worker => ("worker-secret", "client-secret"),
            _ => ("client-secret", "worker-secret"),
        };
        assert_eq!(
            call(&api, &method, &path, Some(other)).await,
            StatusCode::UNAUTHORIZED,
            "{method} {path}: the other role's token"
        );
        assert_ne!(
            call(&api, &method, &path, Some(right)).await,
            StatusCode::UNAUTHORIZED,
            "{method} {path} with its token"
        );
    }
}

#[tokio::test]
async fn a_401_is_a_problem_with_a_bearer_challenge() {
    let api = with_tokens("auth-401");
    let r = api.get("/v1/jobs").await;
    assert_eq!(r.status, StatusCode::UNAUTHORIZED);
    assert_eq!(r.headers.get(header::WWW_AUTHENTICATE).unwrap(), "Bearer");
    assert!(
        r.headers
            .get(header::CONTENT_TYPE)
            .unwrap()
            .to_str()
            .unwrap()
            .starts_with("application/problem+json")
    );
}
