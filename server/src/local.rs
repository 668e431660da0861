//! A farm in one process: a coordinator on a loopback port and local workers, talking the same
//! HTTP protocol as a real farm (used by `tessera render` and the benchmarks).
use crate::client::Coordinator;
use crate::state::{AppState, Config};
use std::path::Path;
use tessera_worker::client::{WorkerConfig, WorkerReport};

/// The shape of a local farm.
#[derive(Clone, Debug)]
pub struct LocalFarm {
    /// One worker per entry: its render threads (0: all cores). Each renders one unit at a time.
    pub worker_threads: Vec<usize>,
    /// See `scheduler::frames`.
    pub frame_affinity: bool,
}

impl Default for LocalFarm {
    fn default() -> LocalFarm {
        LocalFarm { worker_threads: vec![0], frame_affinity: true }
    }
}

/// Starts a coordinator and one worker using `threads` threads, runs `f` against the
/// coordinator, then stops both.
pub async fn with_local_farm<T, F, Fut>(data: &Path, threads: usize, f: F) -> anyhow::Result<T>
where
    F: FnOnce(Coordinator) -> Fut,
    Fut: std::future::Future<Output = anyhow::Result<T>>,
{
    with_local_workers(data, &[threads], f).await
}

/// As [`with_local_farm`] with one worker per entry of `threads` (its thread count; 0 = all cores).
pub async fn with_local_workers<T, F, Fut>(
    data: &Path,
    threads: &[usize],
    f: F,
) -> anyhow::Result<T>
where
    F: FnOnce(Coordinator) -> Fut,
    Fut: std::future::Future<Output = anyhow::Result<T>>,
{
    with_farm(data, LocalFarm { worker_threads: threads.to_vec(), ..LocalFarm::default() }, f).await
}

/// Starts the coordinator and workers `farm` describes, runs `f` against the coordinator, then
/// stops them.
pub async fn with_farm<T, F, Fut>(data: &Path, farm: LocalFarm, f: F) -> anyhow::Result<T>
where
    F: FnOnce(Coordinator) -> Fut,
    Fut: std::future::Future<Output = anyhow::Result<T>>,
{
    with_farm_reports(data, farm, f).await.map(|(t, _)| t)
}

/// As [`with_farm`], also returning each worker's report (None for a worker whose `run` failed).
pub async fn with_farm_reports<T, F, Fut>(
    data: &Path,
    farm: LocalFarm,
    f: F,
) -> anyhow::Result<(T, Vec<Option<WorkerReport>>)>
where
    F: FnOnce(Coordinator) -> Fut,
    Fut: std::future::Future<Output = anyhow::Result<T>>,
{
    // The farm lives and dies with this process: nothing to resume, so no checkpoints; and
    // its workers' memory is the process's (`Config::purge_each_frame`).
    let config = Config {
        checkpoint_ms: None,
        frame_affinity: farm.frame_affinity,
        purge_each_frame: false,
        ..Config::new(data.to_path_buf())
    };
    let state = AppState::new(config)?;
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let url = format!("http://{}", listener.local_addr()?);
    let (stop_server, server_stopped) = tokio::sync::oneshot::channel::<()>();
    let server = tokio::spawn(crate::app::run(listener, state, async {
        let _ = server_stopped.await;
    }));
    let (stop_workers, _) = tokio::sync::broadcast::channel::<()>(1);
    let workers: Vec<_> = farm
        .worker_threads
        .iter()
        .enumerate()
        .map(|(i, &threads)| {
            let name = if i == 0 { "local".to_string() } else { format!("local-{i}") };
            let config = WorkerConfig { coordinator: url.clone(), token: None, threads, name };
            let mut stopped = stop_workers.subscribe();
            tokio::spawn(tessera_worker::client::run(config, async move {
                let _ = stopped.recv().await;
            }))
        })
        .collect();
    // Waits follow the job's event stream; should it break, loopback polls are cheap: poll often.
    let outcome =
        f(Coordinator::new(&url, None).polling_every(std::time::Duration::from_millis(50))).await;
    let _ = stop_workers.send(());
    let mut reports = Vec::with_capacity(workers.len());
    for worker in workers {
        reports.push(worker.await.ok().and_then(Result::ok));
    }
    let _ = stop_server.send(());
    let _ = server.await;
    outcome.map(|t| (t, reports))
}
