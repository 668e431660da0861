//! A small HTTP client for the coordinator's client API (used by `submit`, `job` and `render`).
use anyhow::{Context, bail};
use std::path::Path;
use std::time::Duration;
use tessera_proto::{Job, JobRequest, Problem, SceneInfo};

pub struct Coordinator {
    base: String,
    http: reqwest::Client,
    token: Option<String>,
    poll: Duration,
}

impl Coordinator {
    pub fn new(base: &str, token: Option<String>) -> Coordinator {
        Coordinator {
            base: base.trim_end_matches('/').to_string(),
            http: reqwest::Client::new(),
            token,
            poll: Duration::from_millis(100),
        }
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
    pub async fn upload_scene(&self, bytes: Vec<u8>, binary: bool) -> anyhow::Result<SceneInfo> {
        let ct = if binary { "model/gltf-binary" } else { "model/gltf+json" };
        let resp = self
            .req(reqwest::Method::POST, "/v1/scenes")
            .header("content-type", ct)
            .body(bytes)
            .send()
            .await
            .context("uploading the scene")?;
        json_or_problem(resp).await
    }

    pub async fn submit(&self, req: &JobRequest) -> anyhow::Result<Job> {
        let resp = self
            .req(reqwest::Method::POST, "/v1/jobs")
            .json(req)
            .send()
            .await
            .context("submitting the job")?;
        json_or_problem(resp).await
    }

    pub async fn job(&self, id: &str) -> anyhow::Result<Job> {
        let resp = self
            .req(reqwest::Method::GET, &format!("/v1/jobs/{id}"))
            .send()
            .await
            .context("reading the job")?;
        json_or_problem(resp).await
    }

    /// Pauses (`pause`) or resumes a job; the job after it.
    pub async fn set_paused(&self, id: &str, pause: bool) -> anyhow::Result<Job> {
        let action = if pause { "pause" } else { "resume" };
        let resp = self
            .req(reqwest::Method::POST, &format!("/v1/jobs/{id}/{action}"))
            .send()
            .await
            .with_context(|| format!("asking to {action} the job"))?;
        json_or_problem(resp).await
    }

    /// Cancels a job; the job after it.
    pub async fn cancel(&self, id: &str) -> anyhow::Result<Job> {
        let resp = self
            .req(reqwest::Method::DELETE, &format!("/v1/jobs/{id}"))
            .send()
            .await
            .context("canceling the job")?;
        json_or_problem(resp).await
    }

    /// Deletes a job for good (canceled first if it runs): its record, checkpoints and images.
    pub async fn delete(&self, id: &str) -> anyhow::Result<()> {
        let resp = self
            .req(reqwest::Method::DELETE, &format!("/v1/jobs/{id}?purge=true"))
            .send()
            .await
            .context("deleting the job")?;
        if !resp.status().is_success() {
            bail!("{}", problem_text(resp).await);
        }
        Ok(())
    }

    pub async fn bytes(&self, path: &str) -> anyhow::Result<Vec<u8>> {
        let resp = self
            .req(reqwest::Method::GET, path)
            .send()
            .await
            .with_context(|| format!("GET {path}"))?;
        if !resp.status().is_success() {
            bail!("{}", problem_text(resp).await);
        }
        Ok(resp.bytes().await?.to_vec())
    }

    /// Follows the job until it ends, calling `progress` with each status: over its event
    /// stream (SSE), which tells of the end at once, or by polling every `poll` when the stream
    /// cannot be opened or breaks off.
    pub async fn wait(&self, id: &str, mut progress: impl FnMut(&Job)) -> anyhow::Result<Job> {
        if let Some(job) = self.follow_events(id, &mut progress).await {
            return Ok(job);
        }
        loop {
            let job = self.job(id).await?;
            progress(&job);
            if job.state.is_final() {
                return Ok(job);
            }
            tokio::time::sleep(self.poll).await;
        }
    }

    /// The job's `progress` events up to its final state; None when the stream ends first.
    async fn follow_events(&self, id: &str, progress: &mut impl FnMut(&Job)) -> Option<Job> {
        let mut resp =
            self.req(reqwest::Method::GET, &format!("/v1/jobs/{id}/events")).send().await.ok()?;
        if !resp.status().is_success() {
            return None;
        }
        let mut buf = Vec::new();
        while let Some(chunk) = resp.chunk().await.ok()? {
            buf.extend_from_slice(&chunk);
            while let Some(end) = buf.windows(2).position(|w| w == b"\n\n") {
                let event: Vec<u8> = buf.drain(..end + 2).collect();
                if let Some(job) = progress_event(&String::from_utf8_lossy(&event)) {
                    progress(&job);
                    if job.state.is_final() {
                        return Some(job);
                    }
                }
            }
        }
        None
    }
}

/// The job carried by one server-sent event, if it is a `progress` event (not `end`, not a
/// keep-alive comment).
fn progress_event(event: &str) -> Option<Job> {
    let mut kind = "message";
    let mut data = String::new();
    for line in event.lines() {
        if let Some(v) = line.strip_prefix("event:") {
            kind = v.trim();
        } else if let Some(v) = line.strip_prefix("data:") {
            if !data.is_empty() {
                data.push('\n');
            }
            data.push_str(v.strip_prefix(' ').unwrap_or(v));
        }
    }
    (kind == "progress").then(|| serde_json::from_str(&data).ok()).flatten()
}

async fn json_or_problem<T: serde::de::DeserializeOwned>(
    resp: reqwest::Response,
) -> anyhow::Result<T> {
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
    let paused = if job.state == tessera_proto::JobState::Paused { "paused, " } else { "" };
    format!(
        "{paused}{:.1}/{} spp, noise {noise}, {:.0} samples/s, eta {eta}, {} workers",
        job.progress.samples_done, job.progress.samples_target, job.samples_per_s, job.workers
    )
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

#[cfg(test)]
mod tests {
    use super::progress_event;

    #[test]
    fn reads_progress_events_and_skips_the_rest() {
        let job = serde_json::json!({
            "id": "j1", "state": "done", "scene": "s", "request": tessera_proto::JobRequest::default(),
            "progress": {"samples_done": 4.0, "samples_target": 4.0, "fraction": 1.0},
            "noise": null, "elapsed_s": 1.0, "eta_s": null, "samples_per_s": 1.0, "workers": 0, "effects": [],
            "history": [], "dropped_samples": 0, "max_sample_weight": 1.0, "message": null, "created_unix_ms": 0
        });
        let event = format!("event: progress\ndata: {job}\n\n");
        match progress_event(&event) {
            Some(j) => assert_eq!((j.id.as_str(), j.state.is_final()), ("j1", true)),
            None => panic!("a progress event with a job: {event}"),
        }
        assert!(progress_event(":\n\n").is_none(), "keep-alive comment");
        assert!(progress_event("event: end\ndata: j1\n\n").is_none());
        assert!(progress_event("event: progress\ndata: {not json\n\n").is_none());
    }
}
