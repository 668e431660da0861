//! `tessera work`: a worker process.
use clap::Args;

#[derive(Args)]
pub struct WorkArgs {
    /// The coordinator's URL.
    #[arg(long, env = "TESSERA_COORDINATOR", default_value = "http://127.0.0.1:7878")]
    pub coordinator: String,
    /// Render threads (default: all cores).
    #[arg(long, env = "TESSERA_THREADS", default_value_t = 0)]
    pub threads: usize,
    /// Name shown by the coordinator (default: the host name).
    #[arg(long, env = "TESSERA_WORKER_NAME")]
    pub name: Option<String>,
    /// Worker bearer token.
    #[arg(long, env = "TESSERA_WORKER_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Also answer GET /healthz on this address (for liveness probes; a worker has no other port).
    #[arg(long, env = "TESSERA_HEALTH_LISTEN")]
    pub health_listen: Option<String>,
}

pub fn run(a: WorkArgs) -> anyhow::Result<()> {
    tessera_server::purge::for_scene_builders();
    let name = a.name.clone().unwrap_or_else(|| {
        std::fs::read_to_string("/etc/hostname")
            .map(|s| s.trim().to_string())
            .unwrap_or_else(|_| "worker".into())
    });
    let config = tessera_worker::client::WorkerConfig {
        coordinator: a.coordinator,
        token: a.token,
        threads: a.threads,
        name,
    };
    let rt = tokio::runtime::Runtime::new()?;
    if let Some(addr) = &a.health_listen {
        rt.block_on(serve_health(addr))?;
    }
    let report = rt.block_on(tessera_worker::client::run(config, super::shutdown_signal()))?;
    tracing::info!(units_done = report.units_done, "worker exiting");
    Ok(())
}

/// Serves `/healthz` in the background. It answers while the worker's runtime does (a wedged
/// runtime or a dead process fails the probe); the worker never waits for it.
async fn serve_health(addr: &str) -> anyhow::Result<()> {
    let listener = tokio::net::TcpListener::bind(addr)
        .await
        .map_err(|e| anyhow::anyhow!("--health-listen {addr}: {e}"))?;
    let app = axum::Router::new().route("/healthz", axum::routing::get(|| async { "ok" }));
    tracing::info!(addr = %listener.local_addr()?, "answering /healthz");
    tokio::spawn(async move { axum::serve(listener, app).await });
    Ok(())
}
