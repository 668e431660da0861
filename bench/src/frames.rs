//! `tessera-bench frames`: an animation job on a local farm with frame affinity on and off.
//!
//! Both runs render the same frames through a coordinator and `--workers` worker tasks on
//! loopback; they alternate `--repeats` times and the fastest of each is reported, with the
//! scene preparations the workers reported (full builds, refits, their milliseconds). Affinity
//! off hands out units in plain frame order, so every worker prepares every frame.
use std::time::Instant;
use tessera_proto::{FrameRange, Job, JobRequest, JobState};
use tessera_server::client::Coordinator;
use tessera_server::local::{LocalFarm, with_farm};

/// What one run measured.
#[derive(Clone, Debug, Default)]
pub struct FramesRun {
    pub seconds: f64,
    pub builds: u32,
    pub refits: u32,
    pub prepare_ms: f64,
    /// Of each frame whose preparations were all refits, milliseconds per refit (a frame may be
    /// prepared by several workers).
    pub refit_ms: Vec<f64>,
    /// The largest peak resident memory the workers reported (the process's: the coordinator's
    /// and every local worker's), if they did.
    pub peak_rss_bytes: Option<u64>,
}

#[derive(Clone, Debug, clap::Args)]
pub struct FramesBench {
    /// An animated bundled scene or a .gltf/.glb file.
    #[arg(long, default_value = "cornell-animated")]
    pub scene: String,
    /// Frame width and height in pixels.
    #[arg(long, default_value_t = 128)]
    pub size: u32,
    /// Samples per pixel of every frame.
    #[arg(long, default_value_t = 32)]
    pub spp: u32,
    /// Frames 0..N−1 of the scene's first animation.
    #[arg(long, default_value_t = 8)]
    pub frames: u32,
    /// Local workers.
    #[arg(long, default_value_t = 3)]
    pub workers: usize,
    /// Render threads per worker; a worker prepares each frame's scene (posing, face normals,
    /// BVH build or refit) on these threads too.
    #[arg(long, default_value_t = 1)]
    pub threads: usize,
    /// Alternating runs with affinity on and off; the fastest of each is reported.
    #[arg(long, default_value_t = 3)]
    pub repeats: u32,
}

pub fn run(b: &FramesBench) -> anyhow::Result<()> {
    tessera_server::purge::for_scene_builders(); // as `tessera render` does
    let rt = tokio::runtime::Runtime::new()?;
    let (mut on, mut off) = (
        FramesRun { seconds: f64::INFINITY, ..FramesRun::default() },
        FramesRun { seconds: f64::INFINITY, ..FramesRun::default() },
    );
    for _ in 0..b.repeats.max(1) {
        for affinity in [true, false] {
            let r = rt.block_on(once(b, affinity))?;
            let best = if affinity { &mut on } else { &mut off };
            if r.seconds < best.seconds {
                *best = r;
            }
        }
    }
    crate::say!(
        "{} frames of {} at {}×{}, {} spp, {} local workers ({} thread{} each), fastest of {}:",
        b.frames,
        b.scene,
        b.size,
        b.size,
        b.spp,
        b.workers,
        b.threads,
        if b.threads == 1 { "" } else { "s" },
        b.repeats
    );
    for (name, r) in [("affinity on ", &on), ("affinity off", &off)] {
        let median = if r.refit_ms.is_empty() {
            String::new()
        } else {
            format!(" (a refit's median {:.1} ms)", super::median(&r.refit_ms))
        };
        let peak =
            r.peak_rss_bytes.map_or(String::new(), |b| format!("; peak resident {} MiB", b >> 20));
        crate::say!(
            "  {name}: {:.2} s ({:.3} s per frame); scene preparations: {} builds + {} refits = {:.1} ms{median}{peak}",
            r.seconds,
            r.seconds / b.frames as f64,
            r.builds,
            r.refits,
            r.prepare_ms
        );
    }
    crate::say!("  off/on time ratio: {:.3}", off.seconds / on.seconds);
    Ok(())
}

async fn once(b: &FramesBench, affinity: bool) -> anyhow::Result<FramesRun> {
    let scene = b.scene.clone();
    let scratch = tessera_server::scratch::ScratchDir::new(&format!("bench-frames-{affinity}"));
    let farm =
        LocalFarm { worker_threads: vec![b.threads.max(1); b.workers], frame_affinity: affinity };
    let mut request = JobRequest {
        scene: String::new(),
        width: b.size,
        height: b.size,
        spp: Some(b.spp),
        tile_size: Some(32),
        batch_spp: Some(16.min(b.spp)),
        frames: Some(FrameRange { start: 0, end: b.frames.max(1) - 1, step: None, fps: None }),
        ..JobRequest::default()
    };
    let out = with_farm(scratch.path(), farm, |c: Coordinator| async move {
        let t0 = Instant::now();
        request.scene = tessera_server::client::scene_ref(&c, &scene).await?;
        let job = c.submit(&request).await?;
        let job: Job = c.wait(&job.id, |_| {}).await?;
        anyhow::ensure!(
            job.state == JobState::Done,
            "job ended {:?}: {:?}",
            job.state,
            job.message
        );
        Ok((t0.elapsed().as_secs_f64(), job))
    })
    .await;
    let (seconds, job) = out?;
    Ok(FramesRun {
        seconds,
        builds: job.frames.iter().map(|f| f.builds).sum(),
        refits: job.frames.iter().map(|f| f.refits).sum(),
        prepare_ms: job.frames.iter().map(|f| f.prepare_ms).sum(),
        refit_ms: job
            .frames
            .iter()
            .filter(|f| f.builds == 0 && f.refits > 0)
            .map(|f| f.prepare_ms / f64::from(f.refits))
            .collect(),
        peak_rss_bytes: job.frames.iter().filter_map(|f| f.worker_peak_rss_bytes).max(),
    })
}
