//! `tessera submit`: send a job to a coordinator; `--wait` to follow it and download the image.
use super::args::{JobArgs, frame_path};
use anyhow::Context;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};
use tessera_proto::{Job, JobState};
pub use tessera_server::client::scene_ref;
use tessera_server::client::{Coordinator, progress_line};
use tessera_server::output::files_digest;

#[derive(Args)]
pub struct SubmitArgs {
    /// A bundled scene name, a scene id (sha256) already on the coordinator, or a .gltf/.glb file to upload.
    pub scene: String,
    /// The coordinator's URL.
    #[arg(long, env = "TESSERA_SERVER", default_value = "http://127.0.0.1:7878")]
    pub server: String,
    /// Client bearer token.
    #[arg(long, env = "TESSERA_CLIENT_TOKEN", hide_env_values = true)]
    pub token: Option<String>,
    /// Samples per pixel (at least one of --spp, --noise-target, --time-limit).
    #[arg(long)]
    pub spp: Option<u32>,
    #[command(flatten)]
    pub job: JobArgs,
    /// Wait for the job to end, showing progress.
    #[arg(long)]
    pub wait: bool,
    /// Download the final EXR here (implies --wait) and print its pixels' SHA-256 (equal for any two renders of the same settings by one renderer id).
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

pub fn run(a: SubmitArgs) -> anyhow::Result<()> {
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(async {
        let c = Coordinator::new(&a.server, a.token.clone());
        let scene = scene_ref(&c, &a.scene).await?;
        let job = c.submit(&a.job.request(scene, a.spp)).await?;
        super::say(format_args!("{}", job.id))?;
        if a.wait || a.output.is_some() {
            let job = follow(&c, &job.id).await?;
            if let Some(out) = &a.output {
                let files = download(&c, &job, out).await?;
                super::say(format_args!("pixels sha256: {}", files_digest(&files)?))?;
            }
        }
        Ok(())
    })
}

/// Follows a job to its end with a progress bar; errors if it failed or was canceled.
pub async fn follow(c: &Coordinator, id: &str) -> anyhow::Result<Job> {
    let bar = ProgressBar::new(1000).with_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:30}] {msg}").expect("valid template"),
    );
    let job = c
        .wait(id, |j| {
            bar.set_position((j.progress.fraction * 1000.0) as u64);
            bar.set_message(progress_line(j));
        })
        .await?;
    bar.finish_and_clear();
    match job.state {
        JobState::Done => Ok(job),
        s => anyhow::bail!("job {id} ended {s:?}: {}", job.message.clone().unwrap_or_default()),
    }
}

/// Writes the job's EXR to `out`; for a job with a frame range, one file per frame named by
/// [`frame_path`]. Returns the files written.
pub async fn download(c: &Coordinator, job: &Job, out: &Path) -> anyhow::Result<Vec<PathBuf>> {
    download_each(c, job, out, "image.exr").await
}

/// As [`download`], for any per-frame image (`image.exr`, `preview.png`).
pub async fn download_each(
    c: &Coordinator,
    job: &Job,
    out: &Path,
    what: &str,
) -> anyhow::Result<Vec<PathBuf>> {
    let targets: Vec<(String, PathBuf)> = match job.request.frames {
        None => vec![(format!("/v1/jobs/{}/{what}", job.id), out.to_path_buf())],
        Some(_) => job
            .frames
            .iter()
            .map(|f| {
                (format!("/v1/jobs/{}/frames/{}/{what}", job.id, f.frame), frame_path(out, f.frame))
            })
            .collect(),
    };
    for (url, path) in &targets {
        let bytes = c.bytes(url).await?;
        std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))?;
    }
    Ok(targets.into_iter().map(|(_, p)| p).collect())
}
