//! The dashboard's static files: served without a token, self-contained, consistent with each other.
//! (The page itself is exercised in a real browser by `tests/tests/dashboard.rs`.)
use super::super::tests::Api;
use crate::dashboard;
use axum::http::{StatusCode, header};

fn with_tokens(name: &str) -> Api {
    Api::with_config(name, |c| {
        c.client_token = Some("client-secret".into());
        c.worker_token = Some("worker-secret".into());
    })
}

fn file(name: &str) -> &'static str {
    dashboard::files()
        .find(|(n, _)| *n == name)
        .unwrap_or_else(|| panic!("no dashboard file {name}"))
        .1
}

/// Every `"./x.js"` module import and `/ui/…` reference in the dashboard's files.
fn references() -> Vec<String> {
    let mut refs = Vec::new();
    for (_, text) in dashboard::files() {
        for piece in text.split(['"', '\'']) {
            if let Some(m) = piece.strip_prefix("./").filter(|m| m.ends_with(".js")) {
                refs.push(format!("/ui/{m}"));
            } else if piece.starts_with("/ui/") {
                refs.push(piece.to_string());
            }
        }
    }
    refs.sort();
    refs.dedup();
    refs
}

#[tokio::test]
async fn the_page_and_every_file_it_loads_are_served_without_a_token() {
    let api = with_tokens("dash-open");
    let page = api.get("/").await;
    page.expect(StatusCode::OK);
    assert_eq!(page.content_type(), "text/html; charset=utf-8");
    assert!(page.text().contains("<title>Tessera</title>"));
    assert!(page.header(header::CONTENT_SECURITY_POLICY).contains("script-src 'self'"));
    let refs = references();
    assert!(refs.len() >= 8, "style.css and seven modules: {refs:?}");
    for path in refs {
        let r = api.get(&path).await;
        r.expect(StatusCode::OK);
        let want = if path.ends_with(".css") { "text/css" } else { "text/javascript" };
        assert!(r.content_type().starts_with(want), "{path}: {}", r.content_type());
        assert_eq!(r.header(header::X_CONTENT_TYPE_OPTIONS), "nosniff");
    }
    // The API behind it still needs the token.
    assert_eq!(api.get("/v1/jobs").await.status, StatusCode::UNAUTHORIZED);
}

#[tokio::test]
async fn other_paths_under_ui_are_not_open() {
    let with = with_tokens("dash-closed");
    assert_eq!(with.get("/ui/nope.js").await.status, StatusCode::UNAUTHORIZED);
    let open = Api::new("dash-404");
    let p = open.get("/ui/nope.js").await.problem(StatusCode::NOT_FOUND);
    assert!(p.detail.contains("nope.js"), "{p:?}");
}

#[test]
fn nothing_is_loaded_from_another_origin() {
    for (name, text) in dashboard::files() {
        // The SVG namespace is a name, not a request.
        let text = text.replace("http://www.w3.org/2000/svg", "");
        for bad in ["http://", "https://", "src=\"//", "href=\"//", "@import", "url(http"] {
            assert!(!text.contains(bad), "{name} contains {bad:?}");
        }
    }
}

#[test]
fn every_element_the_scripts_look_up_exists_in_the_page() {
    let html = file("index.html");
    let mut ids: Vec<String> = Vec::new();
    for (name, text) in dashboard::files().filter(|(n, _)| n.ends_with(".js")) {
        for piece in text.split("$(\"").skip(1) {
            ids.push(piece.split('"').next().unwrap().to_string());
        }
        // The form's fields are looked up by name: f-NAME and f-NAME-err.
        if name == "jobs.js" {
            let list = text.split("const FIELDS = [").nth(1).unwrap().split(']').next().unwrap();
            for f in list.split(',').map(|f| f.trim().trim_matches('"')) {
                ids.push(format!("f-{f}"));
                ids.push(format!("f-{f}-err"));
            }
        }
    }
    assert!(ids.len() > 30, "{ids:?}");
    for id in ids {
        assert!(html.contains(&format!("id=\"{id}\"")), "index.html has no element with id {id:?}");
    }
}
