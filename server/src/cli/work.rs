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
}

pub fn run(a: WorkArgs) -> anyhow::Result<()> {
    let name = a.name.clone().unwrap_or_else(|| std::fs::read_to_string("/etc/hostname").map(|s| s.trim().to_string()).unwrap_or_else(|_| "worker".into()));
    let config = tessera_worker::client::WorkerConfig { coordinator: a.coordinator, token: a.token, threads: a.threads, name };
    let rt = tokio::runtime::Runtime::new()?;
    let report = rt.block_on(tessera_worker::client::run(config, super::shutdown_signal()))?;
    tracing::info!(units_done = report.units_done, "worker exiting");
    Ok(())
}
