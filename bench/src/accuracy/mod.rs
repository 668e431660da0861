//! The accuracy study: what accuracy costs in time.
//!
//! For each scene of [`SCENES`], each estimator (naive, bsdf, light, mis), each sampler
//! (independent, Sobol) and Russian roulette on/off, the tracer renders progressively at
//! 1, 2, 4, … spp within a time budget ([`measure`]), and relMSE is measured against a
//! reference ([`reference`]: analytic for the furnace, otherwise a cached `mis` + Sobol render at
//! 16× the largest measured spp). [`stats`] turns each curve into the time to reach relMSE 10⁻²
//! and 10⁻³, the efficiency 1/(relMSE·time) and the log-log slope; [`report`] writes them as a
//! markdown table and [`plot`] as one SVG per scene. [`farm`] adds the distributed price: the
//! time a coordinator with 1 or 3 local workers needs to reach a noise target, by tile size and
//! batch size.
//!
//! Run it with `tessera-bench accuracy`; `--quick` runs everything
//! at tiny sizes in seconds (a test keeps that working).
pub mod farm;
pub mod measure;
pub mod plot;
pub mod reference;
pub mod report;
pub mod stats;
#[cfg(test)]
mod tests;

use measure::{Budget, Config, Point};
use reference::Reference;
use std::path::PathBuf;

/// The studied scenes and their analytic answer, where one exists.
pub const SCENES: &[(&str, Option<f64>)] = &[
    ("cornell-box", None),
    ("cornell-small-light", None),
    ("glossy", None),
    ("phong", None),
    ("furnace", Some(0.5)),
];

#[derive(clap::Args, Clone, Debug)]
pub struct Options {
    /// Directory the report (README.md) and the plots (<scene>.svg) are written to.
    #[arg(long, default_value = "docs/accuracy")]
    pub out: PathBuf,
    /// Directory of cached reference renders (keyed by scene, size, spp, seed and version).
    #[arg(long, default_value = "target/accuracy-cache")]
    pub cache: PathBuf,
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 64)]
    pub size: u32,
    /// Seconds of rendering per configuration: the spp ladder stops before a doubling that would
    /// take it past this.
    #[arg(long, default_value_t = 2.0)]
    pub budget: f64,
    /// Most samples per pixel of any configuration (the ladder also stops here).
    #[arg(long, default_value_t = 256)]
    pub max_spp: u32,
    /// The reference renders this many times --max-spp samples per pixel.
    #[arg(long, default_value_t = 16)]
    pub reference_factor: u32,
    /// Seed of the measured renders (references use their own).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Bundled scenes to study, comma-separated (default: all five of the study).
    #[arg(long, value_delimiter = ',')]
    pub scenes: Vec<String>,
    /// Skip the distributed part (tile and batch sizes through a local farm).
    #[arg(long)]
    pub no_farm: bool,
    #[command(flatten)]
    pub farm: farm::FarmOptions,
    /// Tiny sizes and budgets, for CI: checks that the study runs end to end in seconds; its
    /// figures mean nothing.
    #[arg(long)]
    pub quick: bool,
    /// Date written in the report (default: today, UTC).
    #[arg(long)]
    pub date: Option<String>,
    /// Machine description written in the report (default: this one's CPU model, CPUs, widest
    /// vectors and memory, from /proc/cpuinfo and /proc/meminfo).
    #[arg(long)]
    pub machine: Option<String>,
}

impl Options {
    /// `--quick` applied: the sizes CI can afford.
    fn effective(mut self) -> Options {
        if self.quick {
            (self.size, self.budget, self.max_spp) = (8, 0.05, 4);
            self.farm = farm::FarmOptions {
                farm_size: 16,
                farm_noise: 0.05,
                farm_max_spp: 8,
                farm_tiles: vec![8, 16],
                farm_batches: vec![1, 4],
                farm_workers: vec![1, 3],
            };
        }
        if self.scenes.is_empty() {
            self.scenes = SCENES.iter().map(|(n, _)| n.to_string()).collect();
        }
        self
    }
}

/// One scene's curves.
pub struct SceneResult {
    pub name: String,
    pub reference: String,
    pub reference_floor: f64,
    pub curves: Vec<(Config, Vec<Point>)>,
}

pub struct Study {
    pub options: Options,
    pub scenes: Vec<SceneResult>,
    pub farm: Vec<farm::FarmRow>,
}

/// Runs the study and writes `README.md` and one SVG per scene into `--out`.
pub fn run(options: Options) -> anyhow::Result<Study> {
    let options = options.effective();
    anyhow::ensure!(
        options.size > 0 && options.max_spp > 0 && options.reference_factor > 0,
        "--size, --max-spp and --reference-factor must be positive"
    );
    anyhow::ensure!(
        options.budget.is_finite() && options.budget > 0.0,
        "--budget must be a positive number of seconds"
    );
    let mut scenes = Vec::new();
    for name in &options.scenes {
        scenes.push(study_scene(name, &options)?);
    }
    let farm = if options.no_farm { Vec::new() } else { farm::run(&options.farm, options.seed)? };
    let study = Study { options, scenes, farm };
    std::fs::create_dir_all(&study.options.out)?;
    for s in &study.scenes {
        std::fs::write(study.options.out.join(format!("{}.svg", s.name)), plot::svg(s)?)?;
    }
    std::fs::write(study.options.out.join("README.md"), report::markdown(&study))?;
    eprintln!("wrote {}/README.md and {} plots", study.options.out.display(), study.scenes.len());
    Ok(study)
}

fn study_scene(name: &str, options: &Options) -> anyhow::Result<SceneResult> {
    let analytic = SCENES.iter().find(|(n, _)| *n == name).and_then(|(_, v)| *v);
    let bytes = tessera_server::bundled::get(name).ok_or_else(|| {
        anyhow::anyhow!(
            "{name:?} is not a bundled scene ({})",
            tessera_server::bundled::names().join(", ")
        )
    })?;
    let scene = tessera_render::scene::load_bytes(bytes, None)?;
    let pixels = (options.size * options.size) as usize;
    let reference = match analytic {
        Some(v) => Reference::analytic(pixels, v, &format!("analytic {v}")),
        None => reference::rendered(
            &scene,
            bytes,
            name,
            options.size,
            options.max_spp * options.reference_factor,
            &options.cache,
        )?,
    };
    let budget = Budget { seconds: options.budget, max_spp: options.max_spp };
    let mut curves = Vec::new();
    for config in Config::all() {
        let points = measure::converge(
            &scene,
            &config.settings(options.size, options.seed),
            &reference,
            budget,
        )
        .map_err(anyhow::Error::msg)?;
        let last = points.last().expect("at least one rung");
        eprintln!(
            "  {name:<20} {:<24} {:>5} spp {:>7.3} s  relMSE {:.3e}  slope {}",
            config.label(),
            last.spp,
            last.time_s,
            last.rel_mse,
            stats::time_slope(&points).map_or("-".into(), |s| format!("{s:+.2}"))
        );
        curves.push((config, points));
    }
    Ok(SceneResult {
        name: name.into(),
        reference: reference.description.clone(),
        reference_floor: reference.noise_floor(),
        curves,
    })
}
