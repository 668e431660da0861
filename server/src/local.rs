//! A farm in one process: a coordinator on a loopback port and local workers, talking the same
//! HTTP protocol as a real farm (used by `tessera render` and the benchmarks).
use crate::client::Coordinator;
use crate::state::{AppState, Config};
use std::path::Path;
use tessera_worker::client::WorkerConfig;

/// The shape of a local farm.
#[derive(Clone, Debug)]
pub struct LocalFarm {
    /// Worker processes (as tasks); each renders one unit at a time.
    pub workers: usize,
    /// Render threads per worker (0: all cores).
    pub threads: usize,
    pub frame_affinity: bool,
}

impl Default for LocalFarm {
    fn default() -> LocalFarm {
        LocalFarm { workers: 1, threads: 0, frame_affinity: true }
    }
}

/// Starts a coordinator and one worker using `threads` threads, runs `f` against the
/// coordinator, then stops both.
pub async fn with_local_farm<T, F, Fut>(data: &Path, threads: usize, f: F) -> anyhow::Result<T>
where
    F: FnOnce(Coordinator) -> Fut,
    Fut: std::future::Future<Output = anyhow::Result<T>>,
{
    with_farm(data, LocalFarm { threads, ..LocalFarm::default() }, f).await
}

/// As [`with_local_farm`], with any number of workers.
pub async fn with_farm<T, F, Fut>(data: &Path, farm: LocalFarm, f: F) -> anyhow::Result<T>
where
    F: FnOnce(Coordinator) -> Fut,
    Fut: std::future::Future<Output = anyhow::Result<T>>,
{
    // The farm lives and dies with this process: nothing to resume, so no checkpoints.
    let config = Config { checkpoint_ms: None, frame_affinity: farm.frame_affinity, ..Config::new(data.to_path_buf()) };
    let state = AppState::new(config)?;
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let url = format!("http://{}", listener.local_addr()?);
    let (stop_server, server_stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(crate::app::run(listener, state, async {
        let _ = server_stopped.await;
    }));
    let mut workers = Vec::new();
    for i in 0..farm.workers.max(1) {
        let (stop, stopped) = tokio::sync::oneshot::channel::<()>();
        let name = if farm.workers > 1 { format!("local-{}", i + 1) } else { "local".into() };
        let config = WorkerConfig { coordinator: url.clone(), token: None, threads: farm.threads, name };
        let task = tokio::spawn(tessera_worker::client::run(config, async {
            let _ = stopped.await;
        }));
        workers.push((stop, task));
    }
    // Loopback polls are cheap: poll often so the job's end is noticed within milliseconds.
    let outcome = f(Coordinator::new(&url, None).polling_every(std::time::Duration::from_millis(50))).await;
    let (stops, tasks): (Vec<_>, Vec<_>) = workers.into_iter().unzip();
    for stop in stops {
        let _ = stop.send(());
    }
    for task in tasks {
        let _ = task.await;
    }
    let _ = stop_server.send(());
    let _ = server.await;
    outcome
}
