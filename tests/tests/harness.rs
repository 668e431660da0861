//! Shared helpers: the `tessera` binary, bundled scenes, pooled statistics.
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use tessera_render::tracer::PixelSums;

pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("workspace root").to_path_buf()
}

/// Path to a freshly built `tessera` binary of the same profile as this test.
pub fn tessera_bin() -> PathBuf {
    built_bins().join("tessera")
}

/// Path to a freshly built `tessera-bench` binary of the same profile as this test.
pub fn tessera_bench_bin() -> PathBuf {
    built_bins().join("tessera-bench")
}

/// The directory of the workspace's binaries, built once per test process as `cargo test
/// --workspace` (the README's test command) builds the tests: in the same profile (`test`, or
/// `release` under `--release`) and with the features that command resolves (the workspace's,
/// unified with its dev-dependencies' and every test target's), so every library the binaries
/// link is one that run already compiled and only the binaries themselves are built (≈ 30 s).
/// `cargo build -p tessera-server` in the dev profile resolved other features for the shared
/// dependencies, so it rebuilt them and the workspace's crates: ≈ 4 minutes of a cold CI run.
fn built_bins() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let release = !cfg!(debug_assertions);
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut cmd = Command::new(cargo);
        cmd.args(["build", "-q", "--workspace", "--tests", "--bins"]).current_dir(repo_root());
        cmd.arg(if release { "--release" } else { "--profile=test" });
        let status = cmd.status().expect("run cargo build");
        assert!(status.success(), "building the workspace's binaries failed");
        let target = std::env::var("CARGO_TARGET_DIR")
            .map(PathBuf::from)
            .unwrap_or_else(|_| repo_root().join("target"));
        target.join(if release { "release" } else { "debug" })
    })
}

pub fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("tessera-test-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temp dir");
    dir
}

/// Mean of the pixel means over a rectangle, and the standard error of that mean, per channel.
pub fn region_mean(
    pixels: &[(f64, f64)],
    width: usize,
    x0: usize,
    y0: usize,
    w: usize,
    h: usize,
) -> (f64, f64) {
    let (mut m, mut v) = (0.0, 0.0);
    for y in y0..y0 + h {
        for x in x0..x0 + w {
            let (pm, pv) = pixels[y * width + x];
            m += pm;
            v += pv;
        }
    }
    let n = (w * h) as f64;
    (m / n, (v / (n * n)).sqrt())
}

/// Per-pixel (mean, variance of the mean) of channel `c`.
pub fn channel(pixels: &[PixelSums], c: usize) -> Vec<(f64, f64)> {
    pixels.iter().map(|p| (p.mean()[c], p.variance_of_mean()[c])).collect()
}

/// Cornell-box render settings with independent samples, so the measured spread is a valid error bar.
pub fn independent_settings(
    size: (u32, u32),
    seed: u64,
    estimator: tessera_render::tracer::Estimator,
) -> tessera_render::tracer::RenderSettings {
    use tessera_render::tracer::{RenderSettings, integrator::PathSettings, sampler::SamplerKind};
    RenderSettings {
        width: size.0,
        height: size.1,
        seed,
        sampler: SamplerKind::Independent,
        path: PathSettings { estimator, ..PathSettings::default() },
        background: glam::Vec3::ZERO,
        camera: None,
    }
}
