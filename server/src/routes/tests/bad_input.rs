//! The bad-input suite: every malformed scene, job and result we know of, in one
//! table, each with its status and a piece of its problem+json `detail`. The cases run against
//! one coordinator holding a job in progress; after each, that job must be untouched, and at
//! the end it must still finish with every sample counted once.
use super::super::tests::bad_input_cases::*;
use super::super::tests::{Api, lease, put_result, register, samples_done, sums_for, tiled_job};
use axum::http::{Method, StatusCode};
use serde_json::{Value, json};
use tessera_proto::Lease;
use tessera_proto::sums::CONTENT_TYPE as SUMS;

const GLB: &str = "model/gltf-binary";
const JSON: &str = "application/json";
const SCENE_LIMIT: usize = 1 << 20;

enum To {
    Post(&'static str),
    /// PUT the result of a fresh lease on the job in progress.
    Result,
    ResultOf(&'static str),
}

enum Body {
    Raw(Vec<u8>),
    Json(Value),
    /// A result body made for the lease.
    Sums(fn(&Lease) -> Vec<u8>),
}

struct Case {
    name: &'static str,
    to: To,
    ct: &'static str,
    body: Body,
    status: StatusCode,
    detail: &'static str,
}

fn case(
    name: &'static str,
    to: To,
    ct: &'static str,
    body: Body,
    status: StatusCode,
    detail: &'static str,
) -> Case {
    Case { name, to, ct, body, status, detail }
}

fn job(overrides: Value) -> Body {
    Body::Json(super::super::tests::job_body(overrides))
}

fn scene_cases() -> Vec<Case> {
    use StatusCode as S;
    let up = || To::Post("/v1/scenes");
    let raw = Body::Raw;
    let t = triangle();
    let half = t[..t.len() / 2].to_vec();
    vec![
        case(
            "empty scene body",
            up(),
            GLB,
            raw(vec![]),
            S::UNPROCESSABLE_ENTITY,
            "the scene is empty",
        ),
        case(
            "garbage scene",
            up(),
            GLB,
            raw(b"\x00\x01 certainly not glTF".to_vec()),
            S::UNPROCESSABLE_ENTITY,
            "invalid glTF",
        ),
        case(
            "truncated .glb",
            up(),
            GLB,
            raw(half),
            S::UNPROCESSABLE_ENTITY,
            "GLB: the header declares",
        ),
        case(
            "wrong magic",
            up(),
            GLB,
            raw(patched(t.clone(), 0, b"glTX")),
            S::UNPROCESSABLE_ENTITY,
            "invalid glTF",
        ),
        case(
            "wrong .glb version",
            up(),
            GLB,
            raw(patched(t.clone(), 4, &[1])),
            S::UNPROCESSABLE_ENTITY,
            "version",
        ),
        case(
            "declared length below the header",
            up(),
            GLB,
            raw(patched(t.clone(), 8, &8u32.to_le_bytes())),
            S::UNPROCESSABLE_ENTITY,
            "declares 8 bytes",
        ),
        case(
            "chunk length past the end",
            up(),
            GLB,
            raw(patched(t.clone(), 12, &4000u32.to_le_bytes())),
            S::UNPROCESSABLE_ENTITY,
            "past the end of the file",
        ),
        case(
            "buffer longer than the binary chunk",
            up(),
            GLB,
            raw(scene(TRIANGLE, &[(r#""byteLength":36}]"#, r#""byteLength":3600}]"#)], None)),
            S::UNPROCESSABLE_ENTITY,
            "byteLength",
        ),
        case(
            "buffer view out of range",
            up(),
            GLB,
            raw(scene(
                TRIANGLE,
                &[(
                    r#"{"buffer":0,"byteLength":36}"#,
                    r#"{"buffer":0,"byteOffset":1000,"byteLength":36}"#,
                )],
                None,
            )),
            S::UNPROCESSABLE_ENTITY,
            "buffer view 0 lies outside buffer 0",
        ),
        case(
            "accessor count × stride past its view",
            up(),
            GLB,
            raw(scene(TRIANGLE, &[(r#""count":3"#, r#""count":4"#)], None)),
            S::UNPROCESSABLE_ENTITY,
            "reads past the end of buffer view 0",
        ),
        case(
            "accessor offset overflowing",
            up(),
            GLB,
            raw(scene(
                TRIANGLE,
                &[(
                    r#""bufferView":0,"componentType""#,
                    r#""bufferView":0,"byteOffset":4294967295,"componentType""#,
                )],
                None,
            )),
            S::UNPROCESSABLE_ENTITY,
            "reads past the end of buffer view 0",
        ),
        case(
            "accessor of the wrong type",
            up(),
            GLB,
            raw(scene(TRIANGLE, &[(r#""componentType":5126"#, r#""componentType":5122"#)], None)),
            S::UNPROCESSABLE_ENTITY,
            "POSITION accessor has type",
        ),
        case(
            "POSITION naming a missing accessor",
            up(),
            GLB,
            raw(scene(TRIANGLE, &[(r#""POSITION":0"#, r#""POSITION":7"#)], None)),
            S::UNPROCESSABLE_ENTITY,
            "is accessor 7, but there are only 1",
        ),
        case(
            "NaN vertex",
            up(),
            GLB,
            raw(scene([[f32::NAN, 0.0, 0.0], TRIANGLE[1], TRIANGLE[2]], &[], None)),
            S::UNPROCESSABLE_ENTITY,
            "POSITION 0 is not finite",
        ),
        case(
            "infinite vertex",
            up(),
            GLB,
            raw(scene([TRIANGLE[0], TRIANGLE[1], [0.0, f32::INFINITY, 0.0]], &[], None)),
            S::UNPROCESSABLE_ENTITY,
            "POSITION 2 is not finite",
        ),
        case(
            "texture index out of range",
            up(),
            GLB,
            raw(textured(&png_declaring(1, 1), 5)),
            S::UNPROCESSABLE_ENTITY,
            "baseColorTexture.index: Index out of bounds",
        ),
        case(
            "image not an image",
            up(),
            GLB,
            raw(textured(b"not a png at all", 0)),
            S::UNPROCESSABLE_ENTITY,
            "image 0: not a PNG or JPEG image",
        ),
        case(
            "huge declared image",
            up(),
            GLB,
            raw(textured(&png_declaring(100_000, 100_000), 0)),
            S::UNPROCESSABLE_ENTITY,
            "image is 100000×100000",
        ),
        case(
            "external buffer file",
            up(),
            JSON,
            raw(with_buffer_uri("triangle.bin")),
            S::UNPROCESSABLE_ENTITY,
            "external file \"triangle.bin\"",
        ),
        case(
            "path traversal URI",
            up(),
            JSON,
            raw(with_buffer_uri("../../etc/passwd")),
            S::UNPROCESSABLE_ENTITY,
            "leaves the scene's directory",
        ),
        case(
            "absolute file URI",
            up(),
            JSON,
            raw(with_buffer_uri("file:///etc/passwd")),
            S::UNPROCESSABLE_ENTITY,
            "is not a relative path",
        ),
        case(
            "remote URI",
            up(),
            JSON,
            raw(with_buffer_uri("http://example.com/a.bin")),
            S::UNPROCESSABLE_ENTITY,
            "is not a relative path",
        ),
        case(
            "triangle bomb",
            up(),
            GLB,
            raw(bomb()),
            S::UNPROCESSABLE_ENTITY,
            "more than 5000000 triangles",
        ),
        case(
            "node cycle",
            up(),
            GLB,
            raw(scene(TRIANGLE, &[(r#"{"mesh":0}"#, r#"{"mesh":0,"children":[0]}"#)], None)),
            S::UNPROCESSABLE_ENTITY,
            "node 0 appears more than once",
        ),
        case(
            "scene as text/plain",
            up(),
            "text/plain",
            raw(t.clone()),
            S::UNSUPPORTED_MEDIA_TYPE,
            "\"text/plain\"",
        ),
        case(
            "scene over the size limit",
            up(),
            GLB,
            raw(vec![b' '; SCENE_LIMIT + 1]),
            S::PAYLOAD_TOO_LARGE,
            "length limit",
        ),
    ]
}

/// 10⁷ triangles declared by a 1 KB file: an accessor without a buffer view is zeros.
fn bomb() -> Vec<u8> {
    let viewless = r#"{"componentType":5126,"count":30000000,"type":"VEC3","min":[0,0,0],"max":[0,0,0],
        "sparse":{"count":1,"indices":{"bufferView":0,"componentType":5125},"values":{"bufferView":0}}}"#;
    scene(
        TRIANGLE,
        &[
            (r#""max":[1,1,0]}]"#, &format!(r#""max":[1,1,0]}},{viewless}]"#)),
            (r#""POSITION":0"#, r#""POSITION":1"#),
        ],
        None,
    )
}

fn job_cases() -> Vec<Case> {
    use StatusCode as S;
    let post = || To::Post("/v1/jobs");
    vec![
        case(
            "width 0",
            post(),
            JSON,
            job(json!({"width": 0})),
            S::BAD_REQUEST,
            "width must be in 1..=16384 (got 0)",
        ),
        case(
            "negative height",
            post(),
            JSON,
            job(json!({"height": -5})),
            S::BAD_REQUEST,
            "height: invalid value: integer `-5`",
        ),
        case(
            "huge width",
            post(),
            JSON,
            job(json!({"width": 1_000_000})),
            S::BAD_REQUEST,
            "width must be in 1..=16384",
        ),
        case(
            "too many pixels",
            post(),
            JSON,
            job(json!({"width": 16384, "height": 16384})),
            S::BAD_REQUEST,
            "at most 16777216 pixels",
        ),
        case(
            "spp 0",
            post(),
            JSON,
            job(json!({"spp": 0})),
            S::BAD_REQUEST,
            "spp must be in 1..=1048576 (got 0)",
        ),
        case(
            "huge spp",
            post(),
            JSON,
            job(json!({"spp": 4_000_000_000u64})),
            S::BAD_REQUEST,
            "spp must be in 1..=1048576",
        ),
        case(
            "spp beyond u32",
            post(),
            JSON,
            job(json!({"spp": 1u64 << 40})),
            S::BAD_REQUEST,
            "spp: invalid value",
        ),
        case(
            "width as a string",
            post(),
            JSON,
            job(json!({"width": "big"})),
            S::BAD_REQUEST,
            "width: invalid type: string",
        ),
        case(
            "unknown field",
            post(),
            JSON,
            job(json!({"colour": 1})),
            S::BAD_REQUEST,
            "unknown field `colour`",
        ),
        case(
            "unknown estimator",
            post(),
            JSON,
            job(json!({"estimator": "magic"})),
            S::BAD_REQUEST,
            "\"magic\"",
        ),
        case(
            "unknown sampler",
            post(),
            JSON,
            job(json!({"sampler": "halton"})),
            S::BAD_REQUEST,
            "halton",
        ),
        case(
            "noise_target 0",
            post(),
            JSON,
            job(json!({"noise_target": 0.0})),
            S::BAD_REQUEST,
            "noise_target must be a finite number > 0",
        ),
        case(
            "negative noise_target",
            post(),
            JSON,
            job(json!({"spp": null, "noise_target": -0.5})),
            S::BAD_REQUEST,
            "noise_target must be a finite number > 0",
        ),
        case(
            "noise_target \"NaN\"",
            post(),
            JSON,
            job(json!({"noise_target": "NaN"})),
            S::BAD_REQUEST,
            "noise_target: invalid type: string \"NaN\"",
        ),
        case(
            "time limit out of range",
            post(),
            JSON,
            job(json!({"time_limit_s": 1e300})),
            S::BAD_REQUEST,
            "time_limit_s must be in (0, 1e7]",
        ),
        case(
            "no stop condition",
            post(),
            JSON,
            job(json!({"spp": null})),
            S::BAD_REQUEST,
            "stop condition",
        ),
        case(
            "frames backwards",
            post(),
            JSON,
            job(json!({"frames": {"start": 5, "end": 2}})),
            S::BAD_REQUEST,
            "frames.start (5) must be ≤ frames.end (2)",
        ),
        case(
            "frames step 0",
            post(),
            JSON,
            job(json!({"frames": {"start": 0, "end": 2, "step": 0}})),
            S::BAD_REQUEST,
            "frames.step must be ≥ 1",
        ),
        case(
            "frames fps 0",
            post(),
            JSON,
            job(json!({"frames": {"start": 0, "end": 2, "fps": 0.0}})),
            S::BAD_REQUEST,
            "frames.fps must be in (0, 1000]",
        ),
        case(
            "too many frames",
            post(),
            JSON,
            job(json!({"frames": {"start": 0, "end": 4_000_000}})),
            S::BAD_REQUEST,
            "split the range into several jobs",
        ),
        case(
            "frames of a still scene",
            post(),
            JSON,
            job(json!({"frames": {"start": 0, "end": 2}})),
            S::BAD_REQUEST,
            "the scene has no animation",
        ),
        case(
            "unknown animation",
            post(),
            JSON,
            job(json!({"animation": "walk"})),
            S::BAD_REQUEST,
            "no animation \"walk\" (the scene has no animations)",
        ),
        case(
            "frames unknown field",
            post(),
            JSON,
            job(json!({"frames": {"start": 0, "end": 2, "stop": 3}})),
            S::BAD_REQUEST,
            "unknown field `stop`",
        ),
        case(
            "unknown scene",
            post(),
            JSON,
            job(json!({"scene": "no-such-scene"})),
            S::BAD_REQUEST,
            "\"no-such-scene\"",
        ),
        case(
            "job as text/plain",
            post(),
            "text/plain",
            job(json!({})),
            S::UNSUPPORTED_MEDIA_TYPE,
            "application/json",
        ),
        case("empty job body", post(), JSON, Body::Raw(vec![]), S::BAD_REQUEST, "EOF"),
        case(
            "job body over 64 KiB",
            post(),
            JSON,
            job(json!({"scene": "x".repeat(65 << 10)})),
            S::PAYLOAD_TOO_LARGE,
            "length limit",
        ),
    ]
}

fn worker_cases() -> Vec<Case> {
    use StatusCode as S;
    let big = json!({"name": "n".repeat(65 << 10), "threads": 2});
    vec![
        case(
            "zero threads",
            To::Post("/v1/workers"),
            JSON,
            Body::Json(json!({"name": "x", "threads": 0})),
            S::BAD_REQUEST,
            "threads in 1..=4096",
        ),
        case(
            "renderer id over 256 bytes",
            To::Post("/v1/workers"),
            JSON,
            Body::Json(json!({"name": "x", "threads": 1, "renderer": "r".repeat(300)})),
            S::BAD_REQUEST,
            "renderer must be at most 256 bytes",
        ),
        case(
            "renderer id with a line feed",
            To::Post("/v1/workers"),
            JSON,
            Body::Json(json!({"name": "x", "threads": 1, "renderer": "a\nb"})),
            S::BAD_REQUEST,
            "renderer must not contain control characters",
        ),
        case(
            "registration over 64 KiB",
            To::Post("/v1/workers"),
            JSON,
            Body::Json(big.clone()),
            S::PAYLOAD_TOO_LARGE,
            "length limit",
        ),
        case(
            "lease for an unknown worker",
            To::Post("/v1/leases"),
            JSON,
            Body::Json(json!({"worker_id": "w404"})),
            S::NOT_FOUND,
            "unknown worker \"w404\"",
        ),
        case(
            "lease request over 64 KiB",
            To::Post("/v1/leases"),
            JSON,
            Body::Json(json!({"worker_id": "w".repeat(65 << 10)})),
            S::PAYLOAD_TOO_LARGE,
            "length limit",
        ),
        case(
            "empty result",
            To::Result,
            SUMS,
            Body::Raw(vec![]),
            S::UNPROCESSABLE_ENTITY,
            "shorter than the 48-byte header",
        ),
        case(
            "result one pixel short",
            To::Result,
            SUMS,
            Body::Sums(|l| {
                let b = sums_for(l, 0.5).encode();
                b[..b.len() - 64].to_vec()
            }),
            S::UNPROCESSABLE_ENTITY,
            "needs",
        ),
        case(
            "NaN in a result",
            To::Result,
            SUMS,
            Body::Sums(|l| result_with(l, |s| s.pixels[3].sum[1] = f64::NAN)),
            S::UNPROCESSABLE_ENTITY,
            "pixel 3: sums must be finite",
        ),
        case(
            "Inf in a result",
            To::Result,
            SUMS,
            Body::Sums(|l| result_with(l, |s| s.pixels[0].sum_sq[0] = f64::INFINITY)),
            S::UNPROCESSABLE_ENTITY,
            "pixel 0: sums must be finite",
        ),
        case(
            "infinite largest weight",
            To::Result,
            SUMS,
            Body::Sums(|l| result_with(l, |s| s.max_weight = f64::INFINITY)),
            S::UNPROCESSABLE_ENTITY,
            "largest path weight",
        ),
        case(
            "samples neither counted nor dropped",
            To::Result,
            SUMS,
            Body::Sums(|l| result_with(l, |s| s.pixels[0].count -= 1)),
            S::UNPROCESSABLE_ENTITY,
            "dropped ≠",
        ),
        case(
            "result for the wrong tile",
            To::Result,
            SUMS,
            Body::Sums(|l| result_with(l, |s| s.tile.x0 += 8)),
            S::UNPROCESSABLE_ENTITY,
            "result is for tile",
        ),
        case(
            "result for the wrong samples",
            To::Result,
            SUMS,
            Body::Sums(|l| result_with(l, |s| s.samples = [1, 4])),
            S::UNPROCESSABLE_ENTITY,
            "result covers samples [1, 4]",
        ),
        case(
            "result for an unknown lease",
            To::ResultOf("l999-9"),
            SUMS,
            Body::Sums(|l| sums_for(l, 0.5).encode()),
            S::CONFLICT,
            "lease l999-9 is not active",
        ),
        case(
            "result as text/plain",
            To::Result,
            "text/plain",
            Body::Sums(|l| sums_for(l, 0.5).encode()),
            S::UNSUPPORTED_MEDIA_TYPE,
            CONTENT_TYPE_HINT,
        ),
        case(
            "result as JSON",
            To::Result,
            JSON,
            Body::Raw(b"{\"sums\": []}".to_vec()),
            S::UNSUPPORTED_MEDIA_TYPE,
            CONTENT_TYPE_HINT,
        ),
        case(
            "result over the size limit",
            To::Result,
            SUMS,
            Body::Raw(vec![0; (1024 * 1024 * 64) + 4096 + 1]),
            S::PAYLOAD_TOO_LARGE,
            "length limit",
        ),
    ]
}

const CONTENT_TYPE_HINT: &str = "application/x-tessera-sums";

/// Sends one case; returns the lease it used, if any.
async fn send(api: &Api, worker: &str, c: &Case) -> (super::super::tests::Resp, Option<Lease>) {
    let l = matches!(c.to, To::Result | To::ResultOf(_)).then_some(());
    let l = match l {
        Some(()) => Some(lease(api, worker).await),
        None => None,
    };
    let uri = match (&c.to, &l) {
        (To::Post(uri), _) => uri.to_string(),
        (To::Result, Some(l)) => format!("/v1/leases/{}/result", l.lease_id),
        (To::ResultOf(id), _) => format!("/v1/leases/{id}/result"),
        _ => unreachable!(),
    };
    let body = match &c.body {
        Body::Raw(b) => b.clone(),
        Body::Json(v) => serde_json::to_vec(v).unwrap(),
        Body::Sums(f) => f(l.as_ref().expect("a lease")),
    };
    let method = if matches!(c.to, To::Post(_)) { Method::POST } else { Method::PUT };
    (api.request(method, &uri, Some(c.ct), body).await, l)
}

#[tokio::test]
async fn every_bad_input_is_a_clear_4xx_and_loses_nothing() {
    let api = Api::with_config("bad-input", |c| {
        c.max_scene_bytes = SCENE_LIMIT;
        c.max_failures = 1000; // the bad results below must not get the worker blocklisted
    });
    let worker = register(&api).await;
    let job_id = api.submit(&tiled_job()).await["id"].as_str().unwrap().to_string();
    let cases: Vec<Case> =
        [scene_cases(), job_cases(), worker_cases()].into_iter().flatten().collect();
    assert!(cases.len() >= 40, "{} cases", cases.len());
    let mut failures = Vec::new();
    for c in &cases {
        let (r, l) = send(&api, &worker, c).await;
        let detail = serde_json::from_slice::<tessera_proto::Problem>(&r.body)
            .map(|p| p.detail)
            .unwrap_or_default();
        let problem = r.content_type() == "application/problem+json";
        if r.status != c.status || !problem || !detail.contains(c.detail) {
            failures.push(format!(
                "{}: got {} {:?}, want {} containing {:?}",
                c.name,
                r.status,
                String::from_utf8_lossy(&r.body),
                c.status,
                c.detail
            ));
        }
        if let Some(l) = l {
            api.delete(&format!("/v1/leases/{}", l.lease_id)).await; // 204, or 404 if already given back
        }
        // Nothing merged, nothing lost: the job in progress is as it was.
        let j = api.job(&job_id).await;
        assert!(matches!(j["state"].as_str(), Some("queued" | "running")), "{}: {j}", c.name);
        assert_eq!(samples_done(&api, &job_id).await, 0.0, "{}", c.name);
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
    eprintln!("{} bad inputs refused", cases.len());
    finish_the_job(&api, &worker, &job_id).await;
    let jobs = api.get("/v1/jobs").await.json();
    assert_eq!(jobs["jobs"].as_array().unwrap().len(), 1, "no bad job was queued");
}

/// Renders every unit of the job in progress: it ends done with each sample counted once.
async fn finish_the_job(api: &Api, worker: &str, job_id: &str) {
    for _ in 0..12 {
        let l = lease(api, worker).await;
        put_result(api, &l.lease_id, sums_for(&l, 0.5).encode())
            .await
            .expect(StatusCode::NO_CONTENT);
    }
    let j = api.job(job_id).await;
    assert_eq!(j["state"], "done", "{j}");
    assert_eq!(j["progress"]["samples_done"], 5.0);
    assert_eq!(api.metric("tessera_units_merged_total").await, "12");
}

#[tokio::test]
async fn a_zero_area_triangle_is_accepted_and_harmless() {
    // Degenerate triangles are legal glTF; the tracer gives them zero sampling probability and
    // no hits (worker numerics case 9), so the coordinator accepts them like any scene.
    let api = Api::new("bad-zero-area");
    let flat = scene([[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]], &[], None);
    let r = api.request(Method::POST, "/v1/scenes", Some(GLB), flat).await;
    r.expect(StatusCode::CREATED);
    assert_eq!(r.json()["triangles"], 1);
    let id = r.json()["id"].as_str().unwrap().to_string();
    api.submit(&super::super::tests::job_body(json!({"scene": id}))).await;
}
