//! `tessera job`: read, pause, resume, cancel or delete a job on a coordinator.
use clap::{Args, ValueEnum};
use tessera_server::client::{Coordinator, progress_line};

#[derive(Args)]
pub struct JobCmdArgs {
    /// What to do: `status` reads the job; `pause` stops it being leased new units (units in
    /// flight finish and merge); `resume` lets it be leased again; `cancel` ends it (it stays
    /// listed, with its images); `delete` removes it for good, with its images and checkpoints
    /// (canceled first if it runs).
    pub action: JobAction,
    /// The job's id (as `tessera submit` prints it).
    pub id: String,
    /// The coordinator's URL.
    #[arg(long, env = "TESSERA_SERVER", default_value = "http://127.0.0.1:7878")]
    pub server: String,
    /// Client bearer token.
    #[arg(long, env = "TESSERA_CLIENT_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum JobAction {
    Status,
    Pause,
    Resume,
    Cancel,
    Delete,
}

/// Does the action and prints the job's state after it, `<id> <state>: <progress>`, or
/// `<id> deleted`.
pub fn run(a: JobCmdArgs) -> anyhow::Result<()> {
    let rt = tokio::runtime::Runtime::new()?;
    let job = rt.block_on(async {
        let c = Coordinator::new(&a.server, a.token.clone());
        match a.action {
            JobAction::Status => c.job(&a.id).await.map(Some),
            JobAction::Pause => c.set_paused(&a.id, true).await.map(Some),
            JobAction::Resume => c.set_paused(&a.id, false).await.map(Some),
            JobAction::Cancel => c.cancel(&a.id).await.map(Some),
            JobAction::Delete => c.delete(&a.id).await.map(|()| None),
        }
    })?;
    match job {
        Some(job) => println!("{} {}: {}", job.id, job.state.name(), progress_line(&job)),
        None => println!("{} deleted", a.id),
    }
    Ok(())
}
