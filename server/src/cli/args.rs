//! Job settings shared by `render` and `submit`.
use clap::Args;
use tessera_proto::JobRequest;

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
    /// Tile edge in pixels: one unit of work is a tile over a batch of samples.
    #[arg(long, default_value_t = 64)]
    pub tile_size: u32,
    /// Samples per pixel in one unit of work.
    #[arg(long, default_value_t = 16)]
    pub batch_spp: u32,
    /// Higher runs first; equal priorities share workers.
    #[arg(long, default_value_t = 0)]
    pub priority: i32,
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
            background: self.background,
            priority: Some(self.priority),
            frames: None,
            animation: None,
        }
    }
}

fn parse_rgb(s: &str) -> Result<[f32; 3], String> {
    let v: Vec<f32> = s.split(',').map(|x| x.trim().parse::<f32>()).collect::<Result<_, _>>().map_err(|e| format!("{s:?}: {e}"))?;
    match v[..] {
        [r, g, b] if v.iter().all(|x| x.is_finite() && *x >= 0.0) => Ok([r, g, b]),
        [x] if x.is_finite() && x >= 0.0 => Ok([x; 3]),
        _ => Err(format!("{s:?}: expected R,G,B (three finite numbers ≥ 0)")),
    }
}
