//! `tessera`: the render farm's one binary.
use anyhow::{Context, Result};
use clap::{Args, Parser, Subcommand};
use glam::Vec3;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::PathBuf;
use tessera_server::output::{self, MetaValue};
use tessera_server::{bundled, image, local};
use tessera_worker::tracer::integrator::PathSettings;
use tessera_worker::tracer::sampler::SamplerKind;
use tessera_worker::tracer::{Estimator, RenderSettings, Roulette};

#[derive(Parser)]
#[command(name = "tessera", version, about = "Tessera: a distributed render farm for physically based images")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene on this machine, using all cores, and write an OpenEXR image.
    Render(RenderArgs),
}

#[derive(Args)]
struct RenderArgs {
    /// A bundled scene name (cornell-box, furnace, glossy, phong, punctual) or a .gltf/.glb file.
    scene: String,
    /// Samples per pixel.
    #[arg(long, default_value_t = 64)]
    spp: u32,
    /// Image width in pixels.
    #[arg(long, default_value_t = 256)]
    width: u32,
    /// Image height in pixels.
    #[arg(long, default_value_t = 256)]
    height: u32,
    /// Path estimator: naive (the seed's ½ emit / ½ reflect), bsdf, light, or mis.
    #[arg(long, default_value = "mis")]
    estimator: Estimator,
    /// Random sequence: sobol (Owen-scrambled) or independent.
    #[arg(long, default_value = "sobol")]
    sampler: SamplerKind,
    /// Seed of every random number (with pixel, sample index and dimension).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Camera name in the scene (default: the first perspective camera).
    #[arg(long)]
    camera: Option<String>,
    /// Constant background radiance, as R,G,B (linear).
    #[arg(long, value_parser = parse_rgb, default_value = "0,0,0")]
    background: Vec3,
    /// Safety cap on bounces per path (paths end by Russian roulette long before).
    #[arg(long, default_value_t = 1024)]
    max_depth: u32,
    /// Russian roulette: throughput (survive with probability max β), seed (threshold 0.1, stop
    /// with probability 0.5), or off.
    #[arg(long, default_value = "throughput")]
    roulette: String,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Samples per pixel rendered between progress updates.
    #[arg(long, default_value_t = 8)]
    batch: u32,
    /// Output OpenEXR file.
    #[arg(short, long, default_value = "out.exr")]
    output: PathBuf,
    /// Also write a tone-mapped sRGB PNG preview here.
    #[arg(long)]
    preview: Option<PathBuf>,
}

fn parse_rgb(s: &str) -> Result<Vec3, String> {
    let v: Vec<f32> = s.split(',').map(|x| x.trim().parse::<f32>()).collect::<Result<_, _>>().map_err(|e| format!("{s:?}: {e}"))?;
    match v[..] {
        [r, g, b] if v.iter().all(|x| x.is_finite() && *x >= 0.0) => Ok(Vec3::new(r, g, b)),
        [x] if x.is_finite() && x >= 0.0 => Ok(Vec3::splat(x)),
        _ => Err(format!("{s:?}: expected R,G,B (three finite numbers ≥ 0)")),
    }
}

fn parse_roulette(s: &str) -> Result<Roulette> {
    Ok(match s {
        "throughput" => Roulette::default(),
        "seed" => Roulette::Threshold { threshold: 0.1, p: 0.5 },
        "off" => Roulette::Off,
        _ => anyhow::bail!("unknown roulette {s:?} (expected throughput, seed or off)"),
    })
}

fn main() -> Result<()> {
    match Cli::parse().command {
        Command::Render(args) => render(args),
    }
}

fn render(a: RenderArgs) -> Result<()> {
    anyhow::ensure!(a.width > 0 && a.height > 0 && a.width <= 16384 && a.height <= 16384, "width and height must be in 1..=16384");
    anyhow::ensure!(a.spp > 0, "--spp must be at least 1");
    if let Some(t) = a.threads {
        rayon::ThreadPoolBuilder::new().num_threads(t).build_global().context("setting up threads")?;
    }
    let load_start = std::time::Instant::now();
    let scene = bundled::load(&a.scene)?;
    let load_time = load_start.elapsed();
    let settings = RenderSettings {
        width: a.width,
        height: a.height,
        seed: a.seed,
        sampler: a.sampler,
        path: PathSettings { estimator: a.estimator, roulette: parse_roulette(&a.roulette)?, max_depth: a.max_depth },
        background: a.background,
        camera: a.camera.clone(),
    };
    scene.camera(settings.camera.as_deref()).map_err(anyhow::Error::msg)?;
    let bar = ProgressBar::new(a.spp as u64).with_style(
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} spp, eta {eta}").expect("valid template"),
    );
    let r = local::render(&scene, &settings, a.spp, a.batch, |done| bar.set_position(done as u64)).map_err(anyhow::Error::msg)?;
    bar.finish_and_clear();
    let layers = image::layers(a.width, a.height, &r.pixels);
    let secs = r.elapsed.as_secs_f64();
    let meta = vec![
        ("software".to_string(), MetaValue::Text(format!("tessera {}", env!("CARGO_PKG_VERSION")))),
        ("tessera.scene".into(), MetaValue::Text(a.scene.clone())),
        ("tessera.spp".into(), MetaValue::Int(a.spp as i32)),
        ("tessera.seed".into(), MetaValue::Text(a.seed.to_string())),
        ("tessera.estimator".into(), MetaValue::Text(a.estimator.name().into())),
        ("tessera.sampler".into(), MetaValue::Text(a.sampler.name().into())),
        ("tessera.render_time_s".into(), MetaValue::Double(secs)),
        ("tessera.dropped_samples".into(), MetaValue::Text(r.dropped.to_string())),
        ("tessera.max_sample_weight".into(), MetaValue::Float(r.max_weight)),
    ];
    output::write_exr(&a.output, &layers, &meta)?;
    if let Some(p) = &a.preview {
        std::fs::write(p, output::encode_png_preview(layers.width, layers.height, &layers.rgb)).with_context(|| format!("writing {}", p.display()))?;
    }
    let samples = a.width as f64 * a.height as f64 * a.spp as f64;
    println!(
        "{}: {}x{} at {} spp in {:.2} s ({:.0} samples/s; scene load + BVH {:.3} s); estimated relMSE {:.3e}; dropped {} non-finite samples; max sample weight {:.3}",
        a.output.display(),
        a.width,
        a.height,
        a.spp,
        secs,
        samples / secs,
        load_time.as_secs_f64(),
        image::rel_mse(&r.pixels),
        r.dropped,
        r.max_weight
    );
    Ok(())
}
