//! `JobRequest` → `JobConfig`: every setting checked, every default made explicit.
use crate::error::AppError;
use crate::scenes::SceneMeta;
use crate::scheduler::JobConfig;
use tessera_proto::job::DEFAULT_FPS;
use tessera_proto::{FrameRange, JobRequest, RenderParams};
use tessera_render::tracer::integrator::{DEFAULT_ROULETTE_DEPTH, UnknownEstimator};
use tessera_render::tracer::light::UnknownLightSampler;
use tessera_render::tracer::sampler::{SamplerKind, UnknownSamplerKind};
use tessera_render::tracer::{Estimator, LightSampler};

pub const MAX_SIDE: u32 = 16384;
/// 16 Mpixel: the coordinator keeps 64 bytes of f64 sums per pixel (1 GiB at this size).
pub const MAX_PIXELS: u64 = 1 << 24;
pub const MAX_SPP: u32 = 1 << 20;
/// Cap on samples per pixel for jobs stopped only by noise or time.
pub const OPEN_ENDED_SPP: u32 = 1 << 16;
/// Pixels of all frames of a time-limited job together: such a job refines all its frames
/// together (batch-major, `scheduler::frames`), so it holds every frame's sums until it ends
/// (4 GiB at this size); longer sequences are split into several jobs.
pub const MAX_JOB_PIXELS: u64 = 1 << 26;
/// Tiles of all frames of a job. Other jobs hold the sums of their frames in flight only (a
/// complete frame's image is written and its sums dropped), but the coordinator keeps about 200
/// bytes per tile for the job's life and writes a mark per tile into each checkpoint of its
/// record: 2¹⁷ tiles are about 25 MiB and a record of 3 MiB, up to 12 MiB once their frames are
/// released and each mark carries its figures (257 frames of 1920×1080 in 64-pixel tiles, 2,048
/// of 512×512).
pub const MAX_JOB_TILES: u64 = 1 << 17;
pub const MAX_FPS: f64 = 1000.0;

pub fn job_config(
    id: String,
    req: JobRequest,
    scene: &SceneMeta,
    created_unix_ms: u64,
) -> Result<JobConfig, AppError> {
    let in_range = |field: &str, v: u32, lo: u32, hi: u32| {
        if v < lo || v > hi {
            Err(AppError::field(field, format!("{field} must be in {lo}..={hi} (got {v})")))
        } else {
            Ok(v)
        }
    };
    let width = in_range("width", req.width, 1, MAX_SIDE)?;
    let height = in_range("height", req.height, 1, MAX_SIDE)?;
    if width as u64 * height as u64 > MAX_PIXELS {
        return Err(AppError::field(
            "width",
            format!("width × height must be at most {MAX_PIXELS} pixels"),
        ));
    }
    if req.spp.is_none() && req.noise_target.is_none() && req.time_limit_s.is_none() {
        return Err(AppError::field(
            "spp",
            "give at least one stop condition: spp, noise_target or time_limit_s",
        ));
    }
    let spp = match req.spp {
        Some(s) => in_range("spp", s, 1, MAX_SPP)?,
        None => OPEN_ENDED_SPP,
    };
    if let Some(n) = req.noise_target
        && !(n.is_finite() && n > 0.0)
    {
        return Err(AppError::field("noise_target", "noise_target must be a finite number > 0"));
    }
    let time_limit_ms = match req.time_limit_s {
        Some(t) if t.is_finite() && t > 0.0 && t <= 1e7 => Some((t * 1000.0).ceil() as u64),
        Some(_) => {
            return Err(AppError::field(
                "time_limit_s",
                "time_limit_s must be in (0, 1e7] seconds",
            ));
        }
        None => None,
    };
    let estimator: Estimator = req
        .estimator
        .as_deref()
        .unwrap_or("mis")
        .parse()
        .map_err(|e: UnknownEstimator| AppError::field("estimator", e.to_string()))?;
    let sampler: SamplerKind = req
        .sampler
        .as_deref()
        .unwrap_or("sobol")
        .parse()
        .map_err(|e: UnknownSamplerKind| AppError::field("sampler", e.to_string()))?;
    let tile_size = in_range("tile_size", req.tile_size.unwrap_or(64), 8, 1024)?;
    let tiles = width.div_ceil(tile_size) as u64 * height.div_ceil(tile_size) as u64;
    let (frames, fps) =
        frames(req.frames.as_ref(), width as u64 * height as u64, tiles, time_limit_ms.is_some())?;
    check_animation(req.animation.as_deref(), &frames, scene)?;
    let batch_spp = in_range("batch_spp", req.batch_spp.unwrap_or(16), 1, 4096)?;
    let max_depth = in_range("max_depth", req.max_depth.unwrap_or(1024), 1, 65536)?;
    let roulette_depth =
        in_range("roulette_depth", req.roulette_depth.unwrap_or(DEFAULT_ROULETTE_DEPTH), 0, 65536)?;
    let light_sampler: LightSampler = req
        .light_sampler
        .as_deref()
        .unwrap_or(LightSampler::Auto.name())
        .parse()
        .map_err(|e: UnknownLightSampler| AppError::field("light_sampler", e.to_string()))?;
    let background = req.background.unwrap_or([0.0; 3]);
    if background.iter().any(|c| !(c.is_finite() && *c >= 0.0)) {
        return Err(AppError::field("background", "background must be three finite numbers ≥ 0"));
    }
    if let Some(cam) = &req.camera {
        if !scene.cameras.contains(cam) {
            return Err(AppError::field(
                "camera",
                format!("no camera named {cam:?} (the scene has {:?})", scene.cameras),
            ));
        }
    } else if scene.cameras.is_empty() {
        return Err(AppError::field("camera", "the scene has no perspective camera"));
    }
    let mut effects = scene.effects.clone();
    if background.iter().any(|c| *c > 0.0) {
        effects.push("background".into());
    }
    let light_sampler = settled(light_sampler, &scene.effects);
    effects.retain(|e| e != "light_tree");
    // A tree is walked only where there are area lights to choose among.
    if light_sampler == LightSampler::Tree && scene.effects.iter().any(|e| e == "area_lights") {
        effects.push("light_tree".into());
    }
    effects.sort();
    let params = RenderParams {
        width,
        height,
        seed: req.seed.unwrap_or(0),
        estimator: estimator.name().into(),
        sampler: sampler.name().into(),
        camera: req.camera.clone(),
        max_depth,
        roulette_depth: Some(roulette_depth),
        light_sampler: Some(light_sampler.name().into()),
        background,
        animation: req.animation.clone(),
        fps,
    };
    Ok(JobConfig {
        id,
        scene_id: scene.id.clone(),
        params,
        spp,
        spp_given: req.spp.is_some(),
        noise_target: req.noise_target,
        time_limit_ms,
        tile_size,
        batch_spp,
        priority: req.priority.unwrap_or(0),
        effects,
        request: req,
        created_unix_ms,
        frames,
    })
}

/// The sampler a job's units carry: `auto` settled, once per job, as the scene's effects say
/// (`light_tree`: `LightTree::suits` the scene), so that every frame of an animation chooses its
/// lights alike (a worker judging each frame could switch between two noise characters from one
/// frame to the next) and the units and the images' metadata name the sampler used.
fn settled(sampler: LightSampler, scene_effects: &[String]) -> LightSampler {
    match sampler {
        LightSampler::Auto if scene_effects.iter().any(|e| e == "light_tree") => LightSampler::Tree,
        LightSampler::Auto => LightSampler::Power,
        chosen => chosen,
    }
}

/// The frame numbers of a `frames` range, and its fps. `pixels` and `tiles` are per frame.
fn frames(
    range: Option<&FrameRange>,
    pixels: u64,
    tiles: u64,
    time_limited: bool,
) -> Result<(Vec<u32>, f64), AppError> {
    let Some(r) = range else { return Ok((vec![0], DEFAULT_FPS)) };
    let step = r.step.unwrap_or(1);
    if r.start > r.end {
        return Err(AppError::field(
            "frames",
            format!("frames.start ({}) must be ≤ frames.end ({})", r.start, r.end),
        ));
    }
    if step == 0 {
        return Err(AppError::field("frames", "frames.step must be ≥ 1"));
    }
    let fps = r.fps.unwrap_or(DEFAULT_FPS);
    if !(fps.is_finite() && fps > 0.0 && fps <= MAX_FPS) {
        return Err(AppError::field(
            "frames",
            format!("frames.fps must be in (0, {MAX_FPS}] (got {fps})"),
        ));
    }
    let count = (r.end - r.start) as u64 / step as u64 + 1;
    if time_limited && count * pixels > MAX_JOB_PIXELS {
        return Err(AppError::field(
            "frames",
            format!(
                "{count} frames of {pixels} pixels exceed {MAX_JOB_PIXELS} pixels per time-limited job (its frames are refined together, \
                 all in memory): split the range into several jobs, or stop by spp or noise_target"
            ),
        ));
    }
    if count * tiles > MAX_JOB_TILES {
        return Err(AppError::field(
            "frames",
            format!(
                "{count} frames of {tiles} tiles exceed {MAX_JOB_TILES} tiles per job: split the range into several jobs, or use larger tiles"
            ),
        ));
    }
    Ok(((r.start..=r.end).step_by(step as usize).collect(), fps))
}

/// The animation a job names must exist (by name, else by index); several frames need one.
fn check_animation(
    selector: Option<&str>,
    frames: &[u32],
    scene: &SceneMeta,
) -> Result<(), AppError> {
    let anims = &scene.animations;
    let has = |s: &str| {
        anims.iter().any(|a| a.name.as_deref() == Some(s))
            || s.parse::<usize>().is_ok_and(|i| i < anims.len())
    };
    if let Some(s) = selector
        && !has(s)
    {
        let list: Vec<String> = anims
            .iter()
            .enumerate()
            .map(|(i, a)| a.name.clone().unwrap_or_else(|| format!("{i} (unnamed)")))
            .collect();
        let have = if list.is_empty() {
            "the scene has no animations".to_string()
        } else {
            format!("the scene has: {}", list.join(", "))
        };
        return Err(AppError::field("animation", format!("no animation {s:?} ({have})")));
    }
    if frames.len() > 1 && anims.is_empty() {
        return Err(AppError::field(
            "frames",
            "the scene has no animation: every frame would show the same pose (render one frame)",
        ));
    }
    Ok(())
}
