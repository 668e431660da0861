//! The dashboard end to end in headless Chromium, against a real coordinator that requires tokens:
//! enter the token, get an inline error, submit the Cornell box, watch progress reach 100 % and the
//! preview change, download the EXR and decode it; then the job list and the workers page, where
//! a worker of another renderer says why it idles.
use crate::browser::{Browser, require};
use crate::cluster::Farm;
use crate::harness::temp_dir;
use fantoccini::Locator;
use serde_json::{Value, json};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tessera_proto::JobRequest;
use tessera_server::client::Coordinator;
use tessera_server::output::decode_exr;

const CLIENT: &str = "dash-client-token";
const WORKER: &str = "dash-worker-token";

/// `snapshot()`: the job view's state in one round trip; `preview` is null while the image loads.
const SNAPSHOT: &str = r#"
function snapshot() {
const $ = (id) => document.getElementById(id);
const img = $("j-preview");
let preview = null;
if (img.getAttribute("src") && img.complete && img.naturalWidth > 0) {
  const c = document.createElement("canvas");
  c.width = img.naturalWidth; c.height = img.naturalHeight;
  const g = c.getContext("2d");
  g.drawImage(img, 0, 0);
  const d = g.getImageData(0, 0, c.width, c.height).data;
  let hash = 2166136261, sum = 0;
  for (let i = 0; i < d.length; i++) {
    hash = Math.imul(hash ^ d[i], 16777619) >>> 0;
    if (i % 4 !== 3) sum += d[i];
  }
  preview = { hash, mean: sum / (c.width * c.height * 3), width: c.width, samples: img.dataset.samples };
}
return { state: $("j-state").textContent, progress: $("j-progress").value, live: $("j-live").textContent, preview };
}
"#;

#[test]
#[ignore = "needs Chromium and chromedriver: cargo test -- --include-ignored runs it (.ci/run does)"]
fn the_dashboard_submits_watches_and_downloads_a_render() {
    let t0 = Instant::now();
    with_browser("dashboard", 0, steps);
    eprintln!("dashboard browser test: {:.1} s", t0.elapsed().as_secs_f64());
}

/// Starts a farm with tokens and `workers` workers, and a browser; runs `steps` in a task so that
/// a failed assertion still closes the browser.
fn with_browser<Fut>(name: &str, workers: usize, steps: fn(Arc<Browser>, Farm) -> Fut)
where
    Fut: std::future::Future<Output = ()> + Send + 'static,
{
    let (driver, chromium) = require();
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap();
    rt.block_on(async {
        let farm = Farm::start_with(name, workers, Some((CLIENT, WORKER)), &[]);
        let b = Arc::new(
            Browser::start(&driver, &chromium, temp_dir(&format!("{name}-downloads"))).await,
        );
        let outcome = tokio::spawn(steps(b.clone(), farm)).await;
        let _ = b.client.clone().close().await;
        if let Err(e) = outcome {
            std::panic::resume_unwind(e.into_panic());
        }
    });
}

async fn steps(b: Arc<Browser>, mut farm: Farm) {
    let url = farm.url.clone();
    b.client.goto(&format!("{url}/")).await.expect("open the dashboard");
    let banner = b
        .until(
            "the missing-token banner",
            20,
            r#"const e = document.getElementById("banner"); return !e.hidden && e.textContent;"#,
        )
        .await;
    assert!(banner.as_str().unwrap().contains("client token"), "{banner}");
    b.fill("#token", CLIENT).await;
    b.click("#token-form button").await;
    b.until("the bundled scenes", 20, r#"return document.getElementById("banner").hidden && document.querySelector('#f-scene option[value="cornell-box"]:checked') !== null;"#)
        .await;

    // A bad width comes back as problem+json naming the field, shown next to it.
    b.fill("#f-width", "0").await;
    b.click("#f-submit").await;
    let err = b
        .until(
            "the inline width error",
            20,
            r#"return document.getElementById("f-width-err").textContent;"#,
        )
        .await;
    assert!(err.as_str().unwrap().contains("width must be in 1..=16384"), "{err}");
    let focus = b.js(r#"return [document.activeElement.id, document.getElementById("f-width").getAttribute("aria-invalid")];"#).await;
    assert_eq!(focus, json!(["f-width", "true"]));
    // A file that is not glTF: the upload's 422 shows at the file field.
    let bad = temp_dir("dashboard-upload").join("not-a-scene.glb");
    std::fs::write(&bad, b"certainly not glTF").unwrap();
    b.client
        .find(Locator::Css("#f-file"))
        .await
        .unwrap()
        .send_keys(bad.to_str().unwrap())
        .await
        .unwrap();
    b.click("#f-submit").await;
    let err = b
        .until(
            "the inline upload error",
            20,
            r#"return document.getElementById("f-file-err").textContent;"#,
        )
        .await;
    assert!(err.as_str().unwrap().contains("invalid glTF"), "{err}");
    b.js(r#"document.getElementById("f-file").value = ""; return true;"#).await;

    for (field, v) in [("#f-width", "64"), ("#f-height", "64"), ("#f-spp", "32")] {
        b.fill(field, v).await;
    }
    b.click("#f-submit").await;
    let hash = b
        .until(
            "the job page",
            20,
            r##"return location.hash.startsWith("#/job/") && location.hash;"##,
        )
        .await;
    let job_id = hash.as_str().unwrap().trim_start_matches("#/job/").to_string();
    // No worker yet: the job waits, and its preview has no samples.
    let first = b
        .until(
            "the queued job's preview",
            20,
            &format!(
                "{SNAPSHOT} const s = snapshot(); return s.preview && s.state === 'queued' && s;"
            ),
        )
        .await;
    // Paused and resumed from its page while it waits.
    b.click("#j-pause").await;
    b.until("the paused job", 20, r#"return document.getElementById("j-state").textContent === "paused" && document.getElementById("j-pause").textContent === "Resume";"#).await;
    b.click("#j-pause").await;
    b.until("the resumed job", 20, r#"return document.getElementById("j-state").textContent === "queued" && document.getElementById("j-pause").textContent === "Pause";"#).await;
    farm.add_worker();

    let (progress, previews) = watch_to_the_end(&b).await;
    assert!(progress.windows(2).all(|w| w[0] <= w[1]), "progress never goes back: {progress:?}");
    let last = previews.last().unwrap();
    assert_eq!(
        (first["preview"]["mean"].as_f64(), first["preview"]["width"].as_u64()),
        (Some(0.0), Some(64)),
        "nothing merged: black"
    );
    assert!(last["mean"].as_f64().unwrap() > 20.0, "the rendered box is not black: {last}");
    assert_ne!(first["preview"]["hash"], last["hash"], "the preview changed");
    let drawn = b.js(r##"return [document.querySelectorAll("#j-chart polyline").length, document.getElementById("j-cancel").disabled, document.getElementById("j-pause").disabled];"##).await;
    assert_eq!(
        drawn,
        json!([1, true, true]),
        "the noise history is drawn; a finished job cannot be canceled or paused"
    );
    let contrib = b.js(r##"return document.querySelector("#j-contrib tbody").textContent;"##).await;
    assert!(contrib.as_str().unwrap().contains("100%"), "one worker did everything: {contrib}");

    b.click("#j-exr").await;
    let exr = b.downloaded(&format!("{job_id}.exr"), 30).await;
    let api = Coordinator::new(&url, Some(CLIENT.into()));
    assert_eq!(
        exr,
        api.bytes(&format!("/v1/jobs/{job_id}/image.exr")).await.unwrap(),
        "the download is the job's EXR"
    );
    let (img, _) = decode_exr(&exr).expect("the EXR decodes");
    assert_eq!((img.width, img.height), (64, 64));
    assert!(img.samples.iter().all(|&s| s == 32.0), "32 samples in every pixel");
    assert!(img.rgb.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    assert!(img.rgb.iter().map(|p| p[0] as f64).sum::<f64>() > 0.0);

    b.click("a[href='#/jobs']").await;
    let row = b.until("the job's row, done", 20, &format!(r#"const r = document.querySelector('tr[data-job="{job_id}"]'); return r && r.dataset.state === "done" && r.textContent;"#)).await;
    assert!(
        row.as_str().unwrap().contains("100%") && row.as_str().unwrap().contains("64×64"),
        "{row}"
    );
    b.click("#nav-workers").await;
    let units = b.until("the worker's row", 20, r##"const r = document.querySelector("#workers tbody tr"); return r && r.cells[4].textContent;"##).await;
    assert_eq!(units, "2", "one 64×64 tile × two 16-spp batches");
    let renderer =
        b.js(r##"return document.querySelector("#workers tbody tr").cells[8].textContent;"##).await;
    assert_eq!(renderer, tessera_render::renderer_id(), "the worker's renderer id");
    // Linux workers report their resident memory with each result.
    let memory =
        b.js(r##"return document.querySelector("#workers tbody tr").cells[7].textContent;"##).await;
    let memory = memory.as_str().unwrap();
    assert!(
        memory.contains("MiB (peak ") && memory.ends_with("MiB)"),
        "the worker's memory: {memory}"
    );

    // A worker of another renderer beside a job this worker renders: its row says why it idles.
    let other = "tessera 0.0.0 src:000000000000 libm:00000000";
    let hello = json!({"name": "other", "threads": 1, "renderer": other});
    let reg: Value = reqwest::Client::new()
        .post(format!("{url}/v1/workers"))
        .bearer_auth(WORKER)
        .json(&hello)
        .send()
        .await
        .unwrap()
        .json()
        .await
        .unwrap();
    let long = JobRequest {
        scene: "furnace".into(),
        width: 64,
        height: 64,
        spp: Some(1 << 20),
        ..JobRequest::default()
    };
    let long = api.submit(&long).await.unwrap();
    let script = format!(
        r#"const r = document.querySelector('tr[data-worker="{}"]'); const t = r && r.cells[3].textContent; return t && t.startsWith("idle: ") && t;"#,
        reg["worker_id"].as_str().unwrap()
    );
    let idle = b.until("the other renderer's idle reason", 20, &script).await;
    let expected = format!(
        "idle: jobs {} are kept on renderer {} while a worker of it is live",
        long.id,
        tessera_render::renderer_id()
    );
    assert_eq!(idle, expected);
    // The running job deleted from its page (the confirmation answered yes): gone from the list
    // and from the coordinator.
    b.js(&format!(
        r##"location.hash = "#/job/{}"; window.confirm = () => true; return true;"##,
        long.id
    ))
    .await;
    b.until(
        "the job to delete",
        20,
        &format!(r#"return document.getElementById("j-id").textContent === "{}";"#, long.id),
    )
    .await;
    b.click("#j-delete").await;
    b.until("the list without it", 20, &format!(r##"return location.hash === "#/jobs" && document.querySelector('tr[data-job="{job_id}"]') && !document.querySelector('tr[data-job="{}"]');"##, long.id)).await;
    assert!(api.job(&long.id).await.is_err(), "deleted on the coordinator");
}

/// Snapshots the job page every 50 ms until it shows the job done at 100 % with its final
/// preview; returns the progress values and the distinct previews seen, in order.
async fn watch_to_the_end(b: &Browser) -> (Vec<i64>, Vec<Value>) {
    let end = Instant::now() + Duration::from_secs(120);
    let (mut progress, mut previews): (Vec<i64>, Vec<Value>) = (Vec::new(), Vec::new());
    loop {
        let s = b.js(&format!("{SNAPSHOT} return snapshot();")).await;
        progress.push(s["progress"].as_i64().unwrap());
        let p = &s["preview"];
        if !p.is_null() && previews.last().is_none_or(|l: &Value| l["hash"] != p["hash"]) {
            previews.push(p.clone());
        }
        let final_preview = p["samples"] == "32";
        if s["state"] == "done" && final_preview {
            assert_eq!(progress.last(), Some(&100));
            assert_eq!(s["live"], "Job done, 100% done.", "announced to screen readers");
            return (progress, previews);
        }
        assert!(Instant::now() < end, "the job did not finish in the browser within 120 s: {s}");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

/// Regenerates the README's screenshots, `docs/dashboard-jobs.png` and `docs/dashboard-job.png`:
/// `cargo test -p tessera-tests --test e2e dashboard_screenshots -- --ignored`.
#[test]
#[ignore = "writes docs/; run by hand"]
fn dashboard_screenshots() {
    with_browser("dashboard-docs", 2, screenshots);
}

async fn screenshots(b: Arc<Browser>, farm: Farm) {
    use tessera_proto::JobRequest;
    let api = Coordinator::new(&farm.url, Some(CLIENT.into()));
    let job = |scene: &str, size: u32, spp: Option<u32>, noise_target: Option<f64>| JobRequest {
        scene: scene.into(),
        width: size,
        height: size,
        spp,
        noise_target,
        ..JobRequest::default()
    };
    let small = api.submit(&job("phong", 96, Some(64), None)).await.unwrap();
    api.wait(&small.id, |_| {}).await.unwrap();
    let canceled = api.submit(&job("glossy", 192, Some(1024), None)).await.unwrap();
    tokio::time::sleep(Duration::from_millis(1500)).await;
    let cancel = reqwest::Client::new()
        .delete(format!("{}/v1/jobs/{}", farm.url, canceled.id))
        .bearer_auth(CLIENT)
        .send()
        .await
        .unwrap();
    assert!(cancel.status().is_success());
    let main = api.submit(&job("cornell-box", 256, Some(4096), Some(1e-3))).await.unwrap();
    api.submit(&job("punctual", 160, Some(256), None)).await.unwrap();

    b.client.goto(&format!("{}/", farm.url)).await.unwrap();
    b.fill("#token", CLIENT).await;
    b.click("#token-form button").await;
    b.client.set_window_size(1280, 760).await.unwrap();
    b.until(
        "a running job in the list",
        60,
        r#"return document.querySelector('tr[data-state="running"]') !== null;"#,
    )
    .await;
    tokio::time::sleep(Duration::from_secs(4)).await;
    let docs = crate::harness::repo_root().join("docs");
    b.screenshot(&docs.join("dashboard-jobs.png")).await;

    b.client.set_window_size(1280, 1400).await.unwrap();
    b.client.goto(&format!("{}/#/job/{}", farm.url, main.id)).await.unwrap();
    b.until(
        "the job half way",
        600,
        r#"return document.getElementById("j-progress").value >= 50;"#,
    )
    .await;
    b.screenshot(&docs.join("dashboard-job.png")).await;
}
