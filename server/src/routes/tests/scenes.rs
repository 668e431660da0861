//! `/v1/scenes`: content-addressed upload, description, and download.
use super::super::tests::{Api, Resp, cornell_bytes, job_body, sha256_hex};
use axum::http::{Method, StatusCode, header};
use serde_json::json;

async fn upload(api: &Api, content_type: &str, bytes: Vec<u8>) -> Resp {
    api.request(Method::POST, "/v1/scenes", Some(content_type), bytes).await
}

/// The Cornell box with its buffer's data URI replaced by `uri`.
fn cornell_with_buffer_uri(uri: &str) -> Vec<u8> {
    let text = String::from_utf8(cornell_bytes()).unwrap();
    let start = text.find("\"data:application/octet-stream;base64,").expect("a data URI") + 1;
    let end = start + text[start..].find('"').unwrap();
    format!("{}{uri}{}", &text[..start], &text[end..]).into_bytes()
}

#[tokio::test]
async fn uploading_the_cornell_box_answers_its_hash_and_description() {
    let api = Api::new("s-upload");
    let bytes = cornell_bytes();
    let r = upload(&api, "model/gltf+json", bytes.clone()).await;
    r.expect(StatusCode::CREATED);
    let scene = r.json();
    let id = sha256_hex(&bytes);
    assert_eq!(scene["id"], id.as_str());
    assert_eq!(r.header(header::LOCATION), format!("/v1/scenes/{id}"));
    assert_eq!(scene["triangles"], 32);
    let effects = scene["effects"].as_array().unwrap();
    assert!(
        effects.contains(&json!("area_lights")) && effects.contains(&json!("lambert")),
        "{effects:?}"
    );
    assert_eq!(scene["cameras"], json!(["Camera"]));
    assert_eq!(scene["name"], "cornell-box", "the bundled scene's bytes answer with its name");
    assert_eq!(api.get(&format!("/v1/scenes/{id}")).await.json(), scene, "described alike by id");

    let again = upload(&api, "model/gltf+json", bytes).await;
    again.expect(StatusCode::CREATED);
    assert_eq!(again.json(), scene, "same bytes, same id and description");
}

#[tokio::test]
async fn a_new_scene_is_stored_by_hash_downloadable_and_usable_by_jobs() {
    let api = Api::new("s-new");
    // Different bytes from the bundled scene: a new id.
    let mut bytes = cornell_bytes();
    bytes.extend_from_slice(b"\n\n");
    let id = sha256_hex(&bytes);
    assert_ne!(id, sha256_hex(&cornell_bytes()));
    let r = upload(&api, "application/octet-stream", bytes.clone()).await;
    r.expect(StatusCode::CREATED);
    assert_eq!(r.json()["id"], id.as_str());
    let r2 = upload(&api, "model/gltf+json; charset=utf-8", bytes.clone()).await;
    r2.expect(StatusCode::CREATED);
    assert_eq!(r2.json()["id"], id.as_str());

    let data = api.get(&format!("/v1/scenes/{id}/data")).await;
    data.expect(StatusCode::OK);
    assert_eq!(data.content_type(), "application/octet-stream");
    assert_eq!(data.body.as_ref(), bytes.as_slice(), "the exact bytes back");
    assert_eq!(
        std::fs::read(api.dir().join("scenes").join(&id)).unwrap(),
        bytes,
        "stored under its hash"
    );

    let described = api.get(&format!("/v1/scenes/{id}")).await;
    described.expect(StatusCode::OK);
    assert_eq!(described.json()["triangles"], 32);

    let job = api.submit(&job_body(json!({"scene": id}))).await;
    assert_eq!(job["scene"], id.as_str());
}

#[tokio::test]
async fn a_scene_larger_than_the_64_kib_json_limit_is_accepted() {
    let api = Api::new("s-large");
    let mut bytes = cornell_bytes();
    bytes.extend(std::iter::repeat_n(b' ', 100 << 10));
    let r = upload(&api, "model/gltf+json", bytes.clone()).await;
    r.expect(StatusCode::CREATED);
    assert_eq!(r.json()["id"], sha256_hex(&bytes).as_str());
}

#[tokio::test]
async fn a_bundled_scene_is_described_by_name() {
    let api = Api::new("s-bundled");
    let r = api.get("/v1/scenes/cornell-box").await;
    r.expect(StatusCode::OK);
    let scene = r.json();
    assert_eq!(scene["id"], sha256_hex(&cornell_bytes()).as_str());
    assert_eq!(scene["triangles"], 32);
    assert_eq!(scene["cameras"], json!(["Camera"]));
    assert!(scene["effects"].as_array().unwrap().contains(&json!("area_lights")));
    // Its bytes are served by hash.
    let data = api.get(&format!("/v1/scenes/{}/data", sha256_hex(&cornell_bytes()))).await;
    data.expect(StatusCode::OK);
    assert_eq!(data.body.as_ref(), cornell_bytes().as_slice());
}

#[tokio::test]
async fn garbage_is_a_422_problem_and_not_stored() {
    let api = Api::new("s-garbage");
    let garbage = b"\x00\x01 certainly not glTF".to_vec();
    let p = upload(&api, "model/gltf-binary", garbage.clone())
        .await
        .problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p.detail.starts_with("invalid glTF"), "{p:?}");
    api.get(&format!("/v1/scenes/{}", sha256_hex(&garbage))).await.problem(StatusCode::NOT_FOUND);
}

#[tokio::test]
async fn a_gltf_with_an_external_file_is_a_422_naming_the_reference() {
    let api = Api::new("s-external");
    let p = upload(&api, "model/gltf+json", cornell_with_buffer_uri("cornell.bin"))
        .await
        .problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(
        p.detail.contains("buffer 0") && p.detail.contains("external file \"cornell.bin\""),
        "{p:?}"
    );
    let p = upload(&api, "model/gltf+json", cornell_with_buffer_uri("file:///etc/passwd"))
        .await
        .problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p.detail.contains("external reference \"file:///etc/passwd\""), "{p:?}");
    let p = upload(&api, "model/gltf+json", cornell_with_buffer_uri("../../etc/passwd"))
        .await
        .problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p.detail.contains("leaves the scene's directory"), "{p:?}");
}

#[tokio::test]
async fn a_scene_without_triangles_is_a_422() {
    let api = Api::new("s-empty");
    let p = upload(
        &api,
        "model/gltf+json",
        br#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[]}]}"#.to_vec(),
    )
    .await
    .problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert!(p.detail.contains("no triangles"), "{p:?}");
}

#[tokio::test]
async fn a_text_plain_upload_is_a_415_problem() {
    let api = Api::new("s-415");
    let p = upload(&api, "text/plain", cornell_bytes())
        .await
        .problem(StatusCode::UNSUPPORTED_MEDIA_TYPE);
    assert!(p.detail.contains("\"text/plain\"") && p.detail.contains("model/gltf-binary"), "{p:?}");
}

#[tokio::test]
async fn a_scene_over_the_configured_size_is_413() {
    let api = Api::with_config("s-413", |c| c.max_scene_bytes = 1024);
    let r = upload(&api, "model/gltf+json", cornell_bytes()).await;
    r.expect(StatusCode::PAYLOAD_TOO_LARGE);
}

#[tokio::test]
async fn a_scene_over_the_configured_size_is_a_413_problem() {
    let api = Api::with_config("s-413-problem", |c| c.max_scene_bytes = 1024);
    let p = upload(&api, "model/gltf+json", cornell_bytes())
        .await
        .problem(StatusCode::PAYLOAD_TOO_LARGE);
    assert!(p.detail.contains("limit"), "{p:?}");
}

#[tokio::test]
async fn unknown_scenes_are_404_problems() {
    let api = Api::new("s-404");
    let unknown = "0".repeat(64);
    for uri in [
        format!("/v1/scenes/{unknown}"),
        format!("/v1/scenes/{unknown}/data"),
        "/v1/scenes/no-such-scene".to_string(),
    ] {
        let p = api.get(&uri).await.problem(StatusCode::NOT_FOUND);
        assert!(p.detail.starts_with("no scene"), "{uri}: {p:?}");
    }
}

#[tokio::test]
async fn path_traversal_ids_never_read_files() {
    let api = Api::new("s-traversal");
    // A real file the traversal could reach: DATA/jobs/secret, i.e. scenes/../jobs/secret.
    std::fs::write(api.dir().join("jobs").join("secret"), b"top secret").unwrap();
    for id in ["..%2F..%2Fetc%2Fpasswd", "..%2Fjobs%2Fsecret", "%2E%2E%2Fjobs%2Fsecret", "..", "."]
    {
        for uri in [format!("/v1/scenes/{id}/data"), format!("/v1/scenes/{id}")] {
            let r = api.get(&uri).await;
            if r.status == StatusCode::NOT_FOUND && r.body.is_empty() {
                continue; // not routed at all (e.g. "." segments): no handler ran
            }
            let p = r.problem(StatusCode::NOT_FOUND);
            assert!(p.detail.starts_with("no scene"), "{uri}: {p:?}");
            assert!(
                !p.detail.contains("root:") && !p.detail.contains("top secret"),
                "{uri}: {p:?}"
            );
        }
    }
    // The decoded traversal reaches the handler and is refused there.
    let p = api.get("/v1/scenes/..%2F..%2Fetc%2Fpasswd/data").await.problem(StatusCode::NOT_FOUND);
    assert_eq!(p.detail, "no scene \"../../etc/passwd\"");
}

#[tokio::test]
async fn the_scene_list_names_the_bundled_scenes_then_uploads() {
    let api = Api::new("s-list");
    let mut extra = cornell_bytes();
    extra.extend_from_slice(b"\n");
    upload(&api, "model/gltf+json", extra.clone()).await.expect(StatusCode::CREATED);
    let r = api.get("/v1/scenes").await;
    r.expect(StatusCode::OK);
    let list = r.json();
    let list = list.as_array().unwrap();
    let names: Vec<&str> = list.iter().filter_map(|s| s["name"].as_str()).collect();
    assert_eq!(names, crate::bundled::names(), "every bundled scene, by name, in order");
    let cornell = list.iter().find(|s| s["name"] == "cornell-box").unwrap();
    assert_eq!(
        (cornell["id"].as_str(), &cornell["triangles"]),
        (Some(sha256_hex(&cornell_bytes()).as_str()), &json!(32))
    );
    let last = list.last().unwrap();
    assert_eq!(
        (last["id"].as_str(), &last["name"]),
        (Some(sha256_hex(&extra).as_str()), &json!(null)),
        "the upload, unnamed, after them"
    );
    assert_eq!(list.len(), names.len() + 1);
}

#[tokio::test]
async fn a_valid_scene_the_store_cannot_write_is_a_507_not_a_422() {
    let api = Api::new("s-storage");
    std::fs::remove_dir_all(api.dir().join("scenes")).expect("the store's scene folder");
    let mut bytes = cornell_bytes();
    bytes.extend_from_slice(b"\n");
    let p = upload(&api, "model/gltf+json", bytes.clone())
        .await
        .problem(StatusCode::INSUFFICIENT_STORAGE);
    assert!(p.detail.starts_with("the scene is valid but storing it failed"), "{p:?}");
    let id = sha256_hex(&bytes);
    api.get(&format!("/v1/scenes/{id}")).await.problem(StatusCode::NOT_FOUND);
}
