//! `tessera render`: a coordinator and a worker in one process, on a loopback port, through the
//! same protocol as a farm — so the default path is the distributed path.
use super::args::JobArgs;
use super::submit::{download, download_each, follow, scene_ref};
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Instant;
use tessera_server::bundled;
use tessera_server::client::Coordinator;
use tessera_server::output::files_digest;

#[derive(Args)]
pub struct RenderArgs {
    /// A bundled scene name (e.g. cornell-box; an unknown name lists them all) or a .gltf/.glb file.
    pub scene: String,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    #[command(flatten)]
    pub job: JobArgs,
    /// Render threads (default: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Output OpenEXR file.
    #[arg(short, long, default_value = "out.exr")]
    pub output: PathBuf,
    /// Also write an sRGB PNG preview (clamped, exposure 1) here (numbered like the EXR for frames).
    #[arg(long)]
    pub preview: Option<PathBuf>,
}

pub fn run(a: RenderArgs) -> anyhow::Result<()> {
    tessera_server::purge::for_scene_builders();
    if !Path::new(&a.scene).is_file() && bundled::get(&a.scene).is_none() {
        anyhow::bail!(
            "{:?} is neither a file nor a bundled scene ({})",
            a.scene,
            bundled::names().join(", ")
        );
    }
    let scratch = tessera_server::scratch::ScratchDir::new("render");
    let rt = tokio::runtime::Runtime::new()?;
    rt.block_on(tessera_server::local::with_local_farm(scratch.path(), a.threads, |c| {
        submit_and_fetch(&a, c)
    }))
}

async fn submit_and_fetch(a: &RenderArgs, c: Coordinator) -> anyhow::Result<()> {
    let start = Instant::now();
    let scene = scene_ref(&c, &a.scene).await?;
    let job = c.submit(&a.job.request(scene, Some(a.spp))).await?;
    let job = follow(&c, &job.id).await?;
    let files = download(&c, &job, &a.output).await?;
    if let Some(p) = &a.preview {
        download_each(&c, &job, p, "preview.png").await?;
    }
    let secs = start.elapsed().as_secs_f64();
    let samples = job.progress.samples_done
        * (a.job.width as f64 * a.job.height as f64)
        * job.frames.len().max(1) as f64;
    // What the workers reported for loading the scene and building (or refitting) its BVH.
    let prepare_ms: f64 = job.frames.iter().map(|f| f.prepare_ms).sum();
    // One process holds coordinator and workers here, so this is the whole render's peak.
    let peak_mib =
        job.frames.iter().filter_map(|f| f.worker_peak_rss_bytes).max().map_or_else(
            || "unknown".into(),
            |b| format!("{:.0} MiB", b as f64 / f64::from(1 << 20)),
        );
    super::say(format_args!(
        "{}: {}x{} at {:.0} spp in {:.2} s ({:.0} samples/s); estimated relMSE {:.3e}; dropped {} non-finite samples; max sample weight {:.3}; effects: {}; scene load + BVH build {:.1} ms; peak memory {}",
        files_label(&files),
        a.job.width,
        a.job.height,
        job.progress.samples_done,
        secs,
        samples / secs,
        job.noise.unwrap_or(0.0),
        job.dropped_samples,
        job.max_sample_weight,
        job.effects.join(", "),
        prepare_ms,
        peak_mib
    ))?;
    // The pixels alone: equal for any two renders of these settings by one renderer id.
    super::say(format_args!("pixels sha256: {}", files_digest(&files)?))?;
    Ok(())
}

/// `out.exr`, or `out_0000.exr … out_0047.exr (48 frames)`.
fn files_label(files: &[PathBuf]) -> String {
    match files {
        [one] => one.display().to_string(),
        [first, .., last] => {
            format!("{} … {} ({} frames)", first.display(), last.display(), files.len())
        }
        [] => String::new(),
    }
}
