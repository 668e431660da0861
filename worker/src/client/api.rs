//! The coordinator's worker endpoints, one call each, answers sorted into what the loop acts on.
//!
//! Every failure is either [`CallError::Transient`] (no connection, timeout, 5xx, 408, 429, a
//! body that does not parse: worth retrying) or [`CallError::Fatal`] (any other status the
//! protocol does not define for that endpoint).
use super::prepare::Prepared;
use anyhow::{Context, bail};
use percent_encoding::{AsciiSet, NON_ALPHANUMERIC, utf8_percent_encode};
use reqwest::{Client, Method, RequestBuilder, Response, StatusCode};
use std::time::Duration;
use tessera_proto::{Heartbeat, Lease, LeaseRequest, Problem, Registration, WorkerHello};

#[derive(Debug)]
pub(crate) enum CallError {
    Transient(String),
    Fatal(String),
}

impl std::fmt::Display for CallError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CallError::Transient(m) | CallError::Fatal(m) => f.write_str(m),
        }
    }
}

pub(crate) enum LeaseAnswer {
    Lease(Box<Lease>),
    /// 204: nothing to do right now.
    NoWork,
    /// 404: the coordinator does not know this worker (it restarted); register again.
    UnknownWorker,
}

pub(crate) enum HeartbeatAnswer {
    /// The lease now expires this long from now.
    Extended(Duration),
    /// 409 (expired, job canceled) or 404 (unknown, e.g. after a coordinator restart).
    Gone,
}

pub(crate) enum UploadAnswer {
    /// Merged; with the worker's next unit when it asked for one and there was work (200).
    Merged(Option<Box<Lease>>),
    /// 409 (late or duplicate) or 404 (the lease is unknown): ignored by the coordinator.
    Stale,
    /// 422, with the coordinator's explanation.
    Malformed(String),
}

/// Result upload headers: how the unit's scene was prepared, and in how many milliseconds.
pub(crate) const PREPARE: &str = "x-tessera-prepare";
pub(crate) const PREPARE_MS: &str = "x-tessera-prepare-ms";
/// Result upload headers: the worker process's resident memory now and at its peak, in bytes.
pub(crate) const RSS: &str = "x-tessera-rss";
pub(crate) const PEAK_RSS: &str = "x-tessera-peak-rss";
/// On a 204 to a lease request: why jobs with units left refuse this worker.
pub(crate) const IDLE_REASON: &str = "x-tessera-idle-reason";

/// Request timeouts. Scene downloads may be large, hence their long one.
const JSON_TIMEOUT: Duration = Duration::from_secs(30);
const HEARTBEAT_TIMEOUT: Duration = Duration::from_secs(10);
const UPLOAD_TIMEOUT: Duration = Duration::from_secs(120);
const SCENE_TIMEOUT: Duration = Duration::from_secs(600);
const RELEASE_TIMEOUT: Duration = Duration::from_secs(5);
/// Short: it is the last thing a stopping worker does, and the leases expire without it.
const DEREGISTER_TIMEOUT: Duration = Duration::from_secs(2);
/// A lease request long-polls for 1 s at most, so an answer later than this means a dead
/// connection (e.g. a worker whose host was cut off and came back with a new address): give up
/// early and the retry opens a fresh one, rather than idling for the JSON timeout.
const LEASE_TIMEOUT: Duration = Duration::from_secs(6);

/// Characters left as they are in an id placed in a URL path (ids are coordinator-made and
/// normally URL-safe already; anything else is escaped rather than trusted).
const SEGMENT: &AsciiSet = &NON_ALPHANUMERIC.remove(b'-').remove(b'_').remove(b'.').remove(b'~');

#[derive(Debug)]
pub(crate) struct Api {
    http: Client,
    base: String,
    token: Option<String>,
    /// The last idle reason logged (see [`Api::note_idle`]).
    idle_reason: std::sync::Mutex<Option<String>>,
}

impl Api {
    pub(crate) fn new(coordinator: &str, token: Option<String>) -> anyhow::Result<Api> {
        let base = coordinator.trim().trim_end_matches('/').to_owned();
        let url = reqwest::Url::parse(&base)
            .with_context(|| format!("coordinator address {coordinator:?} is not a URL"))?;
        match url.scheme() {
            "http" => {}
            "https" => bail!(
                "coordinator {base}: https is not built in; use http:// (put TLS in a proxy in front)"
            ),
            other => bail!("coordinator {base}: unsupported scheme {other:?} (expected http)"),
        }
        let http = Client::builder()
            .connect_timeout(Duration::from_secs(5))
            .tcp_nodelay(true)
            .pool_idle_timeout(Duration::from_secs(30))
            .user_agent(concat!("tessera-worker/", env!("CARGO_PKG_VERSION")))
            .build()
            .context("cannot build the HTTP client")?;
        Ok(Api {
            http,
            base,
            token: token.filter(|t| !t.is_empty()),
            idle_reason: Default::default(),
        })
    }

    /// Logs why the coordinator gives this worker no work (`x-tessera-idle-reason` on a 204:
    /// jobs with units left are pinned to another renderer or keep it off), once per change
    /// rather than on every poll; work or a plain 204 clears it. True when it logged.
    pub(crate) fn note_idle(&self, headers: Option<&reqwest::header::HeaderMap>) -> bool {
        let reason = headers
            .and_then(|h| h.get(IDLE_REASON))
            .and_then(|v| v.to_str().ok())
            .map(str::to_owned);
        let mut last = self.idle_reason.lock().expect("lock");
        if reason == *last {
            return false;
        }
        match &reason {
            Some(why) => tracing::info!("jobs with units left refuse this worker: {why}"),
            None => tracing::info!("no longer kept off the farm's jobs"),
        }
        *last = reason;
        true
    }

    pub(crate) fn base(&self) -> &str {
        &self.base
    }

    fn request(&self, method: Method, path: &str, timeout: Duration) -> RequestBuilder {
        let rb = self.http.request(method, format!("{}{path}", self.base)).timeout(timeout);
        match &self.token {
            Some(t) => rb.bearer_auth(t),
            None => rb,
        }
    }

    pub(crate) async fn register(&self, hello: &WorkerHello) -> Result<Registration, CallError> {
        let resp = send(
            self.request(Method::POST, "/v1/workers", JSON_TIMEOUT).json(hello),
            "registration",
        )
        .await?;
        match resp.status() {
            StatusCode::OK | StatusCode::CREATED => {
                json(resp, "registration", |b| serde_json::from_slice::<Registration>(b)).await
            }
            _ => Err(unexpected(resp, "registration").await),
        }
    }

    pub(crate) async fn lease(&self, worker_id: &str) -> Result<LeaseAnswer, CallError> {
        let body = LeaseRequest { worker_id: worker_id.to_owned() };
        let resp = send(
            self.request(Method::POST, "/v1/leases?wait_ms=1000", LEASE_TIMEOUT).json(&body),
            "lease request",
        )
        .await?;
        match resp.status() {
            StatusCode::OK => {
                self.note_idle(None);
                Ok(LeaseAnswer::Lease(Box::new(
                    json(resp, "lease request", |b| serde_json::from_slice::<Lease>(b)).await?,
                )))
            }
            StatusCode::NO_CONTENT => {
                self.note_idle(Some(resp.headers()));
                Ok(LeaseAnswer::NoWork)
            }
            StatusCode::NOT_FOUND => Ok(LeaseAnswer::UnknownWorker),
            _ => Err(unexpected(resp, "lease request").await),
        }
    }

    pub(crate) async fn heartbeat(&self, lease_id: &str) -> Result<HeartbeatAnswer, CallError> {
        let path = format!("/v1/leases/{}/heartbeat", segment(lease_id));
        let resp = send(self.request(Method::POST, &path, HEARTBEAT_TIMEOUT), "heartbeat").await?;
        match resp.status() {
            StatusCode::OK => {
                let hb =
                    json(resp, "heartbeat", |b| serde_json::from_slice::<Heartbeat>(b)).await?;
                Ok(HeartbeatAnswer::Extended(Duration::from_millis(hb.deadline_ms)))
            }
            StatusCode::CONFLICT | StatusCode::NOT_FOUND | StatusCode::GONE => {
                Ok(HeartbeatAnswer::Gone)
            }
            _ => Err(unexpected(resp, "heartbeat").await),
        }
    }

    /// Uploads a unit's sums, saying how its scene was prepared (`x-tessera-prepare`: cached,
    /// build or refit; `x-tessera-prepare-ms`: milliseconds, 0 when cached) and what the process
    /// holds in memory (`x-tessera-rss`, `x-tessera-peak-rss`: bytes; not sent off Linux). With
    /// `next`, the answer also leases the worker its next unit (`?next=true`).
    pub(crate) async fn upload(
        &self,
        lease_id: &str,
        body: bytes::Bytes,
        prepared: Prepared,
        next: bool,
    ) -> Result<UploadAnswer, CallError> {
        let query = if next { "?next=true" } else { "" };
        let path = format!("/v1/leases/{}/result{query}", segment(lease_id));
        let mut rb = self
            .request(Method::PUT, &path, UPLOAD_TIMEOUT)
            .header(reqwest::header::CONTENT_TYPE, tessera_proto::sums::CONTENT_TYPE)
            .header(PREPARE, prepared.how.name())
            .header(PREPARE_MS, prepared.ms.to_string());
        if let Some(m) = crate::memory::process_memory() {
            rb = rb.header(RSS, m.rss_bytes).header(PEAK_RSS, m.peak_rss_bytes);
        }
        let rb = rb.body(body);
        let resp = send(rb, "result upload").await?;
        match resp.status() {
            StatusCode::NO_CONTENT => {
                if next {
                    self.note_idle(Some(resp.headers()));
                }
                Ok(UploadAnswer::Merged(None))
            }
            StatusCode::OK if !next => Ok(UploadAnswer::Merged(None)),
            // Merged whatever the lease's body holds: a retry would only be told the result is stale.
            StatusCode::OK => {
                match json(resp, "result upload", |b| serde_json::from_slice::<Lease>(b)).await {
                    Ok(lease) => {
                        self.note_idle(None);
                        Ok(UploadAnswer::Merged(Some(Box::new(lease))))
                    }
                    Err(e) => {
                        tracing::warn!(
                            lease = lease_id,
                            "result merged, but the next lease in its answer is unreadable ({e}); it will expire"
                        );
                        Ok(UploadAnswer::Merged(None))
                    }
                }
            }
            StatusCode::CONFLICT | StatusCode::NOT_FOUND | StatusCode::GONE => {
                Ok(UploadAnswer::Stale)
            }
            StatusCode::UNPROCESSABLE_ENTITY => Ok(UploadAnswer::Malformed(detail(resp).await)),
            _ => Err(unexpected(resp, "result upload").await),
        }
    }

    /// Gives a lease back unrendered. A lease the coordinator no longer has counts as returned.
    pub(crate) async fn release(&self, lease_id: &str) -> Result<(), CallError> {
        let path = format!("/v1/leases/{}", segment(lease_id));
        let resp =
            send(self.request(Method::DELETE, &path, RELEASE_TIMEOUT), "lease release").await?;
        match resp.status() {
            s if s.is_success() => Ok(()),
            StatusCode::CONFLICT | StatusCode::NOT_FOUND | StatusCode::GONE => Ok(()),
            _ => Err(unexpected(resp, "lease release").await),
        }
    }

    /// Tells the coordinator this worker is leaving; its leases go back to the queue. A
    /// coordinator that no longer knows the worker (restarted) counts as done.
    pub(crate) async fn deregister(&self, worker_id: &str) -> Result<(), CallError> {
        let path = format!("/v1/workers/{}", segment(worker_id));
        let resp =
            send(self.request(Method::DELETE, &path, DEREGISTER_TIMEOUT), "deregistration").await?;
        match resp.status() {
            s if s.is_success() => Ok(()),
            StatusCode::NOT_FOUND | StatusCode::GONE => Ok(()),
            _ => Err(unexpected(resp, "deregistration").await),
        }
    }

    pub(crate) async fn scene(&self, scene_id: &str) -> Result<Vec<u8>, CallError> {
        let path = format!("/v1/scenes/{}/data", segment(scene_id));
        let resp = send(self.request(Method::GET, &path, SCENE_TIMEOUT), "scene download").await?;
        match resp.status() {
            StatusCode::OK => match resp.bytes().await {
                // Without a copy when the body arrived as one buffer.
                Ok(b) => Ok(Vec::from(b)),
                Err(e) => Err(CallError::Transient(format!("scene download: {}", chain(&e)))),
            },
            _ => Err(unexpected(resp, "scene download").await),
        }
    }
}

fn segment(id: &str) -> String {
    utf8_percent_encode(id, SEGMENT).to_string()
}

async fn send(rb: RequestBuilder, what: &str) -> Result<Response, CallError> {
    rb.send().await.map_err(|e| CallError::Transient(format!("{what}: {}", chain(&e))))
}

/// Reads a JSON answer; `parse` is `serde_json::from_slice` at the wanted type (taking it as a
/// function keeps serde itself out of the worker's dependencies).
async fn json<T>(
    resp: Response,
    what: &str,
    parse: fn(&[u8]) -> serde_json::Result<T>,
) -> Result<T, CallError> {
    let bytes =
        resp.bytes().await.map_err(|e| CallError::Transient(format!("{what}: {}", chain(&e))))?;
    parse(&bytes)
        .map_err(|e| CallError::Transient(format!("{what}: the answer does not parse: {e}")))
}

/// An error status the endpoint does not define: 5xx, 408 and 429 are worth retrying.
async fn unexpected(resp: Response, what: &str) -> CallError {
    let status = resp.status();
    let msg = format!("{what}: {status}: {}", detail(resp).await);
    if status.is_server_error()
        || status == StatusCode::REQUEST_TIMEOUT
        || status == StatusCode::TOO_MANY_REQUESTS
    {
        CallError::Transient(msg)
    } else {
        CallError::Fatal(msg)
    }
}

/// The `detail` of a problem+json body, or the start of whatever text came instead.
async fn detail(resp: Response) -> String {
    let text = resp.text().await.unwrap_or_default();
    match serde_json::from_str::<Problem>(&text) {
        Ok(p) if !p.detail.is_empty() => p.detail,
        Ok(p) => p.title,
        Err(_) if text.trim().is_empty() => "(no body)".to_owned(),
        Err(_) => text.chars().take(300).collect(),
    }
}

/// An error with its sources ("error sending request …: connection refused").
pub(crate) fn chain(e: &dyn std::error::Error) -> String {
    let mut s = e.to_string();
    let mut source = e.source();
    while let Some(inner) = source {
        let m = inner.to_string();
        if !s.contains(&m) {
            s.push_str(": ");
            s.push_str(&m);
        }
        source = inner.source();
    }
    s
}
