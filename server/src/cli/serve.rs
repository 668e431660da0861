//! `tessera serve`: the coordinator.
use clap::Args;
use std::path::PathBuf;
use tessera_server::state::{AppState, Config};

#[derive(Args)]
pub struct ServeArgs {
    /// Address to listen on (port 0 picks a free port; the chosen address is printed).
    #[arg(long, env = "TESSERA_LISTEN", default_value = "127.0.0.1:7878")]
    pub listen: String,
    /// Directory for the job store, checkpoints, scenes and finished images.
    #[arg(long, env = "TESSERA_DATA", default_value = "tessera-data")]
    pub data: PathBuf,
    /// Seconds a lease lives without a heartbeat before its unit is given to another worker.
    #[arg(long, env = "TESSERA_LEASE_TIMEOUT", default_value_t = 10.0)]
    pub lease_timeout: f64,
    /// Seconds between checkpoints of job state to the data directory (a restarted coordinator
    /// resumes from the last one; merges after it are rendered again). 0 keeps jobs in memory only.
    #[arg(long, env = "TESSERA_CHECKPOINT_INTERVAL", default_value_t = 1.0)]
    pub checkpoint_interval: f64,
    /// Units of one job a worker may fail (lease expired, malformed result) before it gets no
    /// more units of that job.
    #[arg(long, default_value_t = 3)]
    pub max_failures: u32,
    /// Give each worker units of the animation frame it rendered last, so it reuses that frame's
    /// BVH (off: units go out frame by frame in plain order, as a baseline).
    #[arg(long, env = "TESSERA_FRAME_AFFINITY", default_value_t = true, action = clap::ArgAction::Set)]
    pub frame_affinity: bool,
    /// Let workers of any renderer id (`tessera --version`) share a job: every worker gets work,
    /// but an image may then mix two builds' or libms' bits (its `renderers` lists them). Off:
    /// a job stays on the renderer it started with while a worker of it is live.
    #[arg(long, env = "TESSERA_MIX_RENDERERS")]
    pub mix_renderers: bool,
    /// Delete ended jobs (done, canceled or failed: their record, checkpoints and images) this
    /// many hours after they ended, checked every 10 s. Unset: keep them until `tessera job
    /// delete`.
    #[arg(long, env = "TESSERA_DELETE_ENDED_AFTER", value_name = "HOURS")]
    pub delete_ended_after: Option<f64>,
    /// Largest accepted scene upload, in MiB.
    #[arg(long, default_value_t = 256)]
    pub max_scene_mib: usize,
    /// Most triangles in an accepted scene.
    #[arg(long, default_value_t = 5_000_000)]
    pub max_triangles: u64,
    /// Bearer token clients must send (submit, read, cancel, dashboard).
    #[arg(long, env = "TESSERA_CLIENT_TOKEN", hide_env_values = true)]
    pub client_token: Option<String>,
    /// Bearer token workers must send (register, lease, heartbeat, result, scene data).
    #[arg(long, env = "TESSERA_WORKER_TOKEN", hide_env_values = true)]
    pub worker_token: Option<String>,
    /// Listen on a non-loopback address even without tokens (anyone who can reach it can use it).
    #[arg(long)]
    pub insecure: bool,
}

pub fn run(a: ServeArgs) -> anyhow::Result<()> {
    anyhow::ensure!(
        a.lease_timeout > 0.0 && a.lease_timeout.is_finite(),
        "--lease-timeout must be > 0"
    );
    anyhow::ensure!(
        a.checkpoint_interval >= 0.0 && a.checkpoint_interval.is_finite(),
        "--checkpoint-interval must be >= 0"
    );
    anyhow::ensure!(a.max_failures >= 1, "--max-failures must be at least 1");
    anyhow::ensure!(
        a.delete_ended_after.is_none_or(|h| h >= 0.0 && h.is_finite()),
        "--delete-ended-after must be a number of hours >= 0"
    );
    let mut config = Config::new(a.data.clone());
    config.checkpoint_ms =
        (a.checkpoint_interval > 0.0).then_some((a.checkpoint_interval * 1000.0) as u64);
    config.max_failures = a.max_failures;
    config.frame_affinity = a.frame_affinity;
    config.mix_renderers = a.mix_renderers;
    config.delete_ended_after_ms = a.delete_ended_after.map(|h| (h * 3_600_000.0) as u64);
    config.lease_timeout_ms = (a.lease_timeout * 1000.0) as u64;
    config.max_scene_bytes = a.max_scene_mib << 20;
    config.max_triangles = a.max_triangles;
    config.client_token = a.client_token.clone().filter(|t| !t.is_empty());
    config.worker_token = a.worker_token.clone().filter(|t| !t.is_empty());
    let open = config.client_token.is_none() || config.worker_token.is_none();
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(async {
        let state = AppState::new(config)?;
        let listener = tokio::net::TcpListener::bind(&a.listen).await?;
        let addr = listener.local_addr()?;
        if open && !addr.ip().is_loopback() && !a.insecure {
            anyhow::bail!(
                "refusing to listen on {addr} without both --client-token and --worker-token; set them, listen on 127.0.0.1, or pass --insecure"
            );
        }
        if open {
            tracing::warn!(%addr, "some routes need no token (set --client-token and --worker-token to require them)");
        }
        // The first line of stdout is the address, for scripts and tests that asked for port 0.
        println!("listening on http://{addr}");
        tracing::info!(%addr, data = %a.data.display(), "coordinator listening");
        tessera_server::app::run(listener, state, super::shutdown_signal()).await?;
        tracing::info!("coordinator stopped");
        Ok(())
    })
}
