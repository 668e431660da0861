//! A small HTTP client for the coordinator's client API (used by `submit` and `render`).
use anyhow::{Context, bail};
use std::path::Path;
use std::time::Duration;
use tessera_proto::{Job, JobRequest, Problem, SceneUploaded};

pub struct Coordinator {
    base: String,
    http: reqwest::Client,
    token: Option<String>,
    poll: Duration,
}

impl Coordinator {
    pub fn new(base: &str, token: Option<String>) -> Coordinator {
        Coordinator { base: base.trim_end_matches('/').to_string(), http: reqwest::Client::new(), token, poll: Duration::from_millis(100) }
    }

    /// How often [`Coordinator::wait`] polls (default 100 ms).
    pub fn polling_every(mut self, poll: Duration) -> Coordinator {
        self.poll = poll;
        self
    }

    fn req(&self, method: reqwest::Method, path: &str) -> reqwest::RequestBuilder {
        let r = self.http.request(method, format!("{}{path}", self.base));
        match &self.token {
            Some(t) => r.bearer_auth(t),
            None => r,
        }
    }

    /// Uploads a scene file; returns its id.
    pub async fn upload_scene(&self, bytes: Vec<u8>, binary: bool) -> anyhow::Result<SceneUploaded> {
        let ct = if binary { "model/gltf-binary" } else { "model/gltf+json" };
        let resp = self.req(reqwest::Method::POST, "/v1/scenes").header("content-type", ct).body(bytes).send().await.context("uploading the scene")?;
        json_or_problem(resp).await
    }

    pub async fn submit(&self, req: &JobRequest) -> anyhow::Result<Job> {
        let resp = self.req(reqwest::Method::POST, "/v1/jobs").json(req).send().await.context("submitting the job")?;
        json_or_problem(resp).await
    }

    pub async fn job(&self, id: &str) -> anyhow::Result<Job> {
        let resp = self.req(reqwest::Method::GET, &format!("/v1/jobs/{id}")).send().await.context("reading the job")?;
        json_or_problem(resp).await
    }

    pub async fn bytes(&self, path: &str) -> anyhow::Result<Vec<u8>> {
        let resp = self.req(reqwest::Method::GET, path).send().await.with_context(|| format!("GET {path}"))?;
        if !resp.status().is_success() {
            bail!("{}", problem_text(resp).await);
        }
        Ok(resp.bytes().await?.to_vec())
    }

    /// Polls until the job ends, calling `progress` with each status.
    pub async fn wait(&self, id: &str, mut progress: impl FnMut(&Job)) -> anyhow::Result<Job> {
        loop {
            let job = self.job(id).await?;
            progress(&job);
            if job.state.is_final() {
                return Ok(job);
            }
            tokio::time::sleep(self.poll).await;
        }
    }
}

async fn json_or_problem<T: serde::de::DeserializeOwned>(resp: reqwest::Response) -> anyhow::Result<T> {
    if resp.status().is_success() {
        return Ok(resp.json().await?);
    }
    bail!("{}", problem_text(resp).await)
}

async fn problem_text(resp: reqwest::Response) -> String {
    let status = resp.status();
    let body = resp.text().await.unwrap_or_default();
    match serde_json::from_str::<Problem>(&body) {
        Ok(p) => match p.field {
            Some(f) => format!("{} ({}): {}", p.title, f, p.detail),
            None => format!("{}: {}", p.title, p.detail),
        },
        Err(_) => format!("{status}: {body}"),
    }
}

/// A one-line summary of a job's progress.
pub fn progress_line(job: &Job) -> String {
    let noise = job.noise.map_or("-".into(), |n| format!("{n:.2e}"));
    let eta = job.eta_s.map_or("-".into(), |e| format!("{e:.1}s"));
    format!("{:.1}/{} spp, noise {noise}, {:.0} samples/s, eta {eta}, {} workers", job.progress.samples_done, job.progress.samples_target, job.samples_per_s, job.workers)
}

/// Uploads a scene file, or passes a name/id through.
pub async fn scene_ref(c: &Coordinator, scene: &str) -> anyhow::Result<String> {
    let path = Path::new(scene);
    if !path.is_file() {
        return Ok(scene.to_string());
    }
    let bytes = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let binary = bytes.starts_with(b"glTF");
    Ok(c.upload_scene(bytes, binary).await?.id)
}

