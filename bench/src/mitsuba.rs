//! `tessera-bench mitsuba`: time to quality against Mitsuba 3 in one run.
//!
//! The yardstick is relMSE × seconds to render the Cornell box (lower is better): the error of
//! an image against a shared reference times the time it took. Both renderers render the same
//! triangles, normals, materials, lights and camera (`tests/reference/mitsuba_render.py` builds
//! Mitsuba's scene from the bundled glTF with `gltf_scene.py`) with a box filter and unbounded
//! depth, at the same spp, on the same cores, one after the other. `--scene` measures other
//! bundled scenes, one or a list (then `mitsuba_suite.rs` sums them up); where Mitsuba cannot
//! render one as Tessera does, Tessera's side alone.
//!
//! - Reference: Tessera `mis` + independent sampler at `--reference-spp` with a seed no measured
//!   render uses, cached under `--cache`. Its per-pixel variance is known without bias, so its
//!   expected contribution to each squared error is subtracted; the error left is the measured
//!   image's own. (Mitsuba's images agree with ours within their error bars on the Cornell box
//!   and the absorbing glass, `tests/tests/mitsuba.rs`.)
//! - relMSE: mean over pixels and channels of (value − ref)² / (ref + 0.01)², as in the accuracy
//!   study.
//! - Time: rendering only. Tessera: `render_tile` over the full frame on all cores (no farm);
//!   Mitsuba: one `mi.render` call after a warm-up render has compiled its kernels.
//! - Each configuration renders `--repeats` times with different seeds; the relMSE is the mean
//!   over them and the time the fastest (this machine's run-to-run noise is one-sided).
//! - After a scene's ratios: the floor speed alone sets under them (`speed_floor.rs`), the
//!   ratio were Tessera's time only its rays, traced at Embree's rate.
//!
//! Without Mitsuba the command renders Tessera's side and says how to install it.
use super::accuracy::measure::rel_mse;
use super::accuracy::reference::{self, Reference};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::integrator::{DEFAULT_ROULETTE_DEPTH, PathSettings, Roulette};
use tessera_render::tracer::sampler::SamplerKind;
use tessera_render::tracer::{PixelSums, RenderSettings, Scene, render_tile};

#[derive(Clone, Debug, clap::Args)]
pub struct MitsubaBench {
    /// Image width and height in pixels.
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    /// Samples per pixel to compare at, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "64,256")]
    pub spp: Vec<u32>,
    /// Renders per configuration (seeds 1, 2, …): mean relMSE, fastest time.
    #[arg(long, default_value_t = 3)]
    pub repeats: u32,
    /// Samples per pixel of the shared reference (rendered once, then cached).
    #[arg(long, default_value_t = 8192)]
    pub reference_spp: u32,
    /// Mitsuba samplers to try, comma-separated (the best is the yardstick).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "independent,stratified,multijitter,ldsampler"
    )]
    pub samplers: Vec<String>,
    /// Mitsuba variant.
    #[arg(long, default_value = "llvm_ad_rgb")]
    pub variant: String,
    /// Python interpreter with the `mitsuba` package.
    #[arg(long, default_value = "python3")]
    pub python: String,
    /// Directory of cached reference renders.
    #[arg(long, default_value = "target/accuracy-cache")]
    pub cache: PathBuf,
    /// Render Tessera's side only (e.g. to compare tracer changes quickly).
    #[arg(long)]
    pub skip_mitsuba: bool,
    /// Tessera's Russian roulette: survive with probability max(β·η²) from this non-specular bounce on
    /// (0: roulette off); several, comma-separated, are compared side by side.
    #[arg(long, value_delimiter = ',', default_values_t = [DEFAULT_ROULETTE_DEPTH])]
    pub roulette_depth: Vec<u32>,
    /// Bundled scenes to render, comma-separated (several: a table of each one's ratio and their
    /// geometric mean follows). Mitsuba renders each from the same glTF
    /// (`tests/reference/gltf_scene.py`) where it can render it as Tessera does (matte surfaces,
    /// pure metals, Phong, area lights, smooth glass with or without absorption); for other scenes it says what it
    /// lacks and Tessera's side is measured alone.
    #[arg(long, value_delimiter = ',', default_value = "cornell-box")]
    pub scene: Vec<String>,
}

/// One configuration's figures.
#[derive(Clone, Debug)]
pub struct Row {
    pub scene: String,
    pub renderer: &'static str,
    /// Rays per second (closest-hit and shadow), where the renderer counts them.
    pub rays_per_s: Option<f64>,
    pub sampler: String,
    pub spp: u32,
    pub seconds: f64,
    pub rel_mse: f64,
}

impl Row {
    pub fn product(&self) -> f64 {
        self.rel_mse * self.seconds
    }
}

const INSTALL: &str = "pip install mitsuba numpy OpenEXR; apt-get install -y libllvm19; \
                       export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1";
/// The script's exit status for a scene it cannot give Mitsuba faithfully.
const UNTRANSLATABLE_EXIT: i32 = 2;

/// Mitsuba runs, but the scene uses something the translation would get wrong (its message).
#[derive(Debug)]
struct Untranslatable(String);

impl std::fmt::Display for Untranslatable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Untranslatable {}

/// Every scene's rows, Tessera's and (where it ran) Mitsuba's.
pub fn run(b: &MitsubaBench) -> anyhow::Result<Vec<Row>> {
    anyhow::ensure!(
        b.size > 0 && b.repeats > 0 && b.reference_spp > 0 && !b.spp.contains(&0),
        "sizes, spp and repeats must be positive"
    );
    anyhow::ensure!(!b.roulette_depth.is_empty(), "give at least one --roulette-depth");
    anyhow::ensure!(!b.scene.is_empty(), "give at least one --scene");
    let mut rows = Vec::new();
    for name in &b.scene {
        rows.append(&mut run_scene(b, name)?);
    }
    if b.scene.len() > 1 {
        super::mitsuba_suite::print_summary(&rows, &b.scene, &b.spp);
    }
    Ok(rows)
}

fn run_scene(b: &MitsubaBench, name: &str) -> anyhow::Result<Vec<Row>> {
    let bytes = tessera_server::bundled::get(name).ok_or_else(|| {
        anyhow::anyhow!(
            "no bundled scene {name:?}; bundled: {}",
            tessera_server::bundled::names().join(", ")
        )
    })?;
    let scene = tessera_render::scene::load_bytes(bytes, None)?;
    let reference = reference::rendered_with(
        &scene,
        bytes,
        name,
        b.size,
        b.reference_spp,
        SamplerKind::Independent,
        &b.cache,
    )?;
    let mut skip_mitsuba = b.skip_mitsuba;
    crate::say!(
        "time to quality: {name} {0}×{0}, {1} threads; reference {2} (its noise, relMSE {3:.2e}, subtracted)",
        b.size,
        rayon::current_num_threads(),
        reference.description,
        reference.noise_floor()
    );
    let mut rows = Vec::new();
    let mut mitsuba_missing = None;
    for &spp in &b.spp {
        for &depth in &b.roulette_depth {
            for sampler in [SamplerKind::Sobol, SamplerKind::Independent] {
                rows.push(tessera_row(&scene, name, &reference, b, spp, sampler, depth)?);
                print_row(rows.last().expect("pushed"));
            }
        }
        if mitsuba_missing.is_some() || skip_mitsuba {
            continue;
        }
        match mitsuba_rows(name, &reference, b, spp) {
            Ok(mut found) => {
                found.iter().for_each(print_row);
                rows.append(&mut found);
            }
            Err(e) if e.is::<Untranslatable>() => {
                crate::say!("{e}: measuring Tessera alone");
                skip_mitsuba = true;
            }
            Err(e) => mitsuba_missing = Some(e),
        }
    }
    if skip_mitsuba {
        return Ok(rows);
    }
    if let Some(e) = mitsuba_missing {
        crate::say!("Mitsuba 3 was not run ({e:#}).\nTo compare, install it: {INSTALL}");
        return Ok(rows);
    }
    let mut ratios = Vec::new();
    for &spp in &b.spp {
        if let Some(ratio) = print_ratio(&rows, spp) {
            ratios.push((spp, ratio));
        }
    }
    super::speed_floor::say(&b.python, name, &scene, &ratios);
    Ok(rows)
}

fn print_row(r: &Row) {
    crate::say!(
        "  {:<8} {:<12} {:>5} spp {:>8.3} s  relMSE {:.3e}  relMSE·s {:.3e}{}",
        r.renderer,
        r.sampler,
        r.spp,
        r.seconds,
        r.rel_mse,
        r.product(),
        r.rays_per_s.map(|v| format!("  {:.1} M rays/s", v / 1e6)).unwrap_or_default()
    );
}

/// The lowest relMSE·s of `renderer` among `rows` at `spp`.
pub(super) fn best<'r>(
    rows: impl IntoIterator<Item = &'r Row>,
    renderer: &str,
    spp: u32,
) -> Option<&'r Row> {
    rows.into_iter()
        .filter(|r| r.renderer == renderer && r.spp == spp)
        .min_by(|a, b| a.product().total_cmp(&b.product()))
}

/// Prints Tessera's best relMSE·s over Mitsuba's at `spp` and returns it, if both rendered.
fn print_ratio(rows: &[Row], spp: u32) -> Option<f64> {
    let (t, m) = (best(rows, "tessera", spp)?, best(rows, "mitsuba", spp)?);
    let ratio = t.product() / m.product();
    crate::say!(
        "{spp} spp: tessera {} {:.3e} ÷ mitsuba {} {:.3e} = ratio {:.3} (target ≤ 0.33); time {:.2}×, relMSE {:.2}×",
        t.sampler,
        t.product(),
        m.sampler,
        m.product(),
        ratio,
        t.seconds / m.seconds,
        t.rel_mse / m.rel_mse
    );
    Some(ratio)
}

fn tessera_row(
    scene: &Scene,
    name: &str,
    reference: &Reference,
    b: &MitsubaBench,
    spp: u32,
    sampler: SamplerKind,
    depth: u32,
) -> anyhow::Result<Row> {
    let (mut seconds, mut error, mut rays) = (f64::INFINITY, 0.0, 0);
    for r in 0..b.repeats {
        let settings = RenderSettings {
            width: b.size,
            height: b.size,
            seed: 1 + r as u64,
            sampler,
            path: PathSettings { roulette: Roulette::from_depth(depth), ..PathSettings::default() },
            background: glam::Vec3::ZERO,
            camera: None,
        };
        let t = Instant::now();
        let sums =
            render_tile(scene, &settings, settings.full_frame(), 0..spp, &RenderOptions::default())
                .map_err(anyhow::Error::msg)?;
        seconds = seconds.min(t.elapsed().as_secs_f64());
        rays = sums.rays;
        error += rel_mse_above_reference(sums.pixels.iter().map(PixelSums::mean), reference);
    }
    let rays_per_s = Some(rays as f64 / seconds);
    // With one roulette depth the label stays the sampler's name, as the ratio lines print it.
    let label = if b.roulette_depth.len() > 1 {
        format!("{} rr{depth}", sampler.name())
    } else {
        sampler.name().into()
    };
    Ok(Row {
        scene: name.into(),
        renderer: "tessera",
        rays_per_s,
        sampler: label,
        spp,
        seconds,
        rel_mse: error / b.repeats as f64,
    })
}

/// relMSE with the reference's own expected share removed: E[(x − r)²] = E[(x − μ)²] + Var(r)
/// for a reference r independent of x, so the reference's noise floor (the same terms, same
/// weights) is subtracted from the plain relMSE.
pub fn rel_mse_above_reference(
    means: impl Iterator<Item = [f64; 3]>,
    reference: &Reference,
) -> f64 {
    rel_mse(means, &reference.means) - reference.noise_floor()
}

/// Runs the Mitsuba script at `spp` for every sampler and reads back its images.
fn mitsuba_rows(
    name: &str,
    reference: &Reference,
    b: &MitsubaBench,
    spp: u32,
) -> anyhow::Result<Vec<Row>> {
    let scratch = tessera_server::scratch::ScratchDir::new("bench-mitsuba");
    let out_dir = scratch.path();
    let mut cmd = python_script(&b.python, "mitsuba_render.py")?;
    cmd.args(["--scene", name])
        .args(["--variant", &b.variant, "--size", &b.size.to_string(), "--spp", &spp.to_string()])
        .args([
            "--samplers",
            &b.samplers.join(","),
            "--repeats",
            &b.repeats.to_string(),
            "--seed",
            "1",
        ])
        .arg("--out-dir")
        .arg(out_dir);
    let output = cmd.output().map_err(|e| anyhow::anyhow!("cannot start {}: {e}", b.python))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        let stderr = String::from_utf8_lossy(&output.stderr);
        let last = stderr.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message");
        if output.status.code() == Some(UNTRANSLATABLE_EXIT) {
            return Err(Untranslatable(last.to_owned()).into());
        }
        anyhow::bail!("the Mitsuba script failed: {last}");
    }
    let mut rows: Vec<Row> = Vec::new();
    for line in stdout.lines().filter(|l| l.starts_with("render ")) {
        let field = |k: &str| {
            line.split(' ')
                .find_map(|f| f.strip_prefix(k))
                .ok_or_else(|| anyhow::anyhow!("no {k} in {line:?}"))
        };
        let (sampler, seconds, out) =
            (field("sampler=")?, field("seconds=")?.parse::<f64>()?, field("out=")?);
        let (image, _) = tessera_server::output::decode_exr(&std::fs::read(out)?)?;
        anyhow::ensure!(
            image.width == b.size as usize && image.height == b.size as usize,
            "Mitsuba wrote a {}×{} image",
            image.width,
            image.height
        );
        let error = rel_mse_above_reference(image.rgb.iter().map(|p| p.map(f64::from)), reference);
        match rows.iter_mut().find(|r| r.sampler == sampler) {
            Some(row) => {
                row.seconds = row.seconds.min(seconds);
                row.rel_mse += error;
            }
            None => rows.push(Row {
                scene: name.into(),
                renderer: "mitsuba",
                rays_per_s: None,
                sampler: sampler.into(),
                spp,
                seconds,
                rel_mse: error,
            }),
        }
    }
    rows.iter_mut().for_each(|r| r.rel_mse /= b.repeats as f64);
    anyhow::ensure!(!rows.is_empty(), "the Mitsuba script rendered nothing");
    Ok(rows)
}

/// `python` running `tests/reference/<script>`, with Dr.Jit pointed at Debian's LLVM 19 unless
/// the environment already says where LLVM is.
pub(crate) fn python_script(python: &str, script: &str) -> anyhow::Result<Command> {
    let mut cmd = Command::new(python);
    cmd.arg(script_path(script)?);
    if std::env::var_os("DRJIT_LIBLLVM_PATH").is_none() {
        let debian = Path::new("/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1");
        if debian.exists() {
            cmd.env("DRJIT_LIBLLVM_PATH", debian);
        }
    }
    Ok(cmd)
}

/// The scripts ship in the repository; found from the working directory or the build's source.
fn script_path(script: &str) -> anyhow::Result<PathBuf> {
    let rel = Path::new("tests/reference").join(script);
    let from_build = Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(&rel);
    [rel.clone(), from_build]
        .into_iter()
        .find(|p| p.exists())
        .ok_or_else(|| anyhow::anyhow!("{} not found (run from the repository)", rel.display()))
}

#[cfg(test)]
mod tests;
