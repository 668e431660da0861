//! Job settings shared by `render` and `submit`.
use clap::Args;
use std::path::{Path, PathBuf};
use tessera_proto::{FrameRange, JobRequest};

#[derive(Args, Clone, Debug)]
pub struct JobArgs {
    /// Image width in pixels.
    #[arg(long, default_value_t = 256)]
    pub width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 256)]
    pub height: u32,
    /// Stop each tile once its estimated relative MSE is at or below this.
    #[arg(long)]
    pub noise_target: Option<f64>,
    /// Stop after this many seconds and keep what is merged.
    #[arg(long)]
    pub time_limit: Option<f64>,
    /// Path estimator: naive (the seed's ½ emit / ½ reflect), bsdf, light, or mis.
    #[arg(long, default_value = "mis")]
    pub estimator: String,
    /// Random sequence: sobol (Owen-scrambled) or independent.
    #[arg(long, default_value = "sobol")]
    pub sampler: String,
    /// Seed of every random number (with pixel, sample index and dimension).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Camera name in the scene (default: the first perspective camera).
    #[arg(long)]
    pub camera: Option<String>,
    /// Constant background radiance, as R,G,B (linear).
    #[arg(long, value_parser = parse_rgb)]
    pub background: Option<[f32; 3]>,
    /// Safety cap on bounces per path (Russian roulette ends paths long before).
    #[arg(long, default_value_t = 1024)]
    pub max_depth: u32,
    /// Russian roulette may end paths from this non-specular bounce on (smooth glass does not
    /// count; 0: off, paths run to --max-depth).
    /// Lower is faster per sample and noisier; the expected image is the same.
    #[arg(long, default_value_t = tessera_render::tracer::integrator::DEFAULT_ROULETTE_DEPTH)]
    pub roulette_depth: u32,
    /// How a light sample chooses among the emissive triangles: auto (through a light tree from
    /// 32 of them on, or fewer that differ in what they give the scene's surfaces, such as lamps
    /// apart; else by power), power, or tree (always through the tree). `auto` is settled once
    /// per job, so every frame of an animation chooses alike; the image's metadata
    /// (`tessera.light_sampler`) names the choice. The expected image is the same.
    #[arg(long, default_value = "auto")]
    pub light_sampler: String,
    /// Tile edge in pixels: one unit of work is a tile over a batch of samples.
    #[arg(long, default_value_t = 64)]
    pub tile_size: u32,
    /// Samples per pixel in one unit of work.
    #[arg(long, default_value_t = 16)]
    pub batch_spp: u32,
    /// Higher runs first; equal priorities share workers.
    #[arg(long, default_value_t = 0)]
    pub priority: i32,
    /// Render frames of the scene's animation: A..B (inclusive), A..B:STEP, or one frame N.
    /// Output files get the frame number: out.exr → out_0003.exr (or put #### in the name).
    #[arg(long, value_parser = parse_frames)]
    pub frames: Option<(u32, u32, u32)>,
    /// Frames per second of animation time (frame n shows time n / fps).
    #[arg(long, default_value_t = tessera_proto::job::DEFAULT_FPS)]
    pub fps: f64,
    /// The glTF animation to play, by name or index (default: the first).
    #[arg(long)]
    pub animation: Option<String>,
}

impl JobArgs {
    pub fn request(&self, scene: String, spp: Option<u32>) -> JobRequest {
        JobRequest {
            scene,
            width: self.width,
            height: self.height,
            spp,
            noise_target: self.noise_target,
            time_limit_s: self.time_limit,
            estimator: Some(self.estimator.clone()),
            sampler: Some(self.sampler.clone()),
            seed: Some(self.seed),
            camera: self.camera.clone(),
            tile_size: Some(self.tile_size),
            batch_spp: Some(self.batch_spp),
            max_depth: Some(self.max_depth),
            roulette_depth: Some(self.roulette_depth),
            light_sampler: Some(self.light_sampler.clone()),
            background: self.background,
            priority: Some(self.priority),
            frames: self.frames.map(|(start, end, step)| FrameRange {
                start,
                end,
                step: Some(step),
                fps: Some(self.fps),
            }),
            animation: self.animation.clone(),
        }
    }
}

fn parse_rgb(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|x| x.trim().parse::<f32>())
        .collect::<Result<_, _>>()
        .map_err(|e| format!("{s:?}: {e}"))?;
    match v[..] {
        [r, g, b] if v.iter().all(|x| x.is_finite() && *x >= 0.0) => Ok([r, g, b]),
        [x] if x.is_finite() && x >= 0.0 => Ok([x; 3]),
        _ => Err(format!("{s:?}: expected R,G,B (three finite numbers ≥ 0)")),
    }
}

/// `A..B`, `A..B:STEP` or `N` → (start, end, step).
fn parse_frames(s: &str) -> Result<(u32, u32, u32), String> {
    let num = |x: &str| {
        x.trim().parse::<u32>().map_err(|e| format!("{s:?}: {x:?} is not a frame number ({e})"))
    };
    let (range, step) = match s.split_once(':') {
        Some((r, st)) => (r, num(st)?),
        None => (s, 1),
    };
    let (a, b) = match range.split_once("..") {
        Some((a, b)) => (num(a)?, num(b.trim_start_matches('='))?),
        None => (num(range)?, num(range)?),
    };
    if a > b || step == 0 {
        return Err(format!(
            "{s:?}: expected A..B with A ≤ B (inclusive), optionally :STEP with STEP ≥ 1"
        ));
    }
    Ok((a, b, step))
}

/// The file of frame `n` for an output name: a run of `#` in the name becomes the zero-padded
/// frame number (`shot_####.exr` → `shot_0003.exr`); otherwise `_####` goes before the extension.
pub fn frame_path(out: &Path, n: u32) -> PathBuf {
    let name = out.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_default();
    let file = match name.find('#') {
        Some(i) => {
            let width = name[i..].chars().take_while(|&c| c == '#').count();
            format!("{}{n:0width$}{}", &name[..i], &name[i + width..])
        }
        None => match name.rsplit_once('.') {
            Some((stem, ext)) => format!("{stem}_{n:04}.{ext}"),
            None => format!("{name}_{n:04}"),
        },
    };
    out.with_file_name(file)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_ranges_parse() {
        assert_eq!(parse_frames("0..7"), Ok((0, 7, 1)));
        assert_eq!(parse_frames("3..=9:2"), Ok((3, 9, 2)));
        assert_eq!(parse_frames("5"), Ok((5, 5, 1)));
        assert!(parse_frames("7..3").is_err());
        assert!(parse_frames("0..4:0").is_err());
        assert!(parse_frames("a..b").is_err());
    }

    #[test]
    fn frame_paths_number_the_files() {
        assert_eq!(frame_path(Path::new("out/shot.exr"), 3), PathBuf::from("out/shot_0003.exr"));
        assert_eq!(frame_path(Path::new("shot_##.exr"), 7), PathBuf::from("shot_07.exr"));
        assert_eq!(frame_path(Path::new("shot"), 12), PathBuf::from("shot_0012"));
    }
}
