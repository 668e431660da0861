//! The images each configuration is compared with: analytic where the answer is known (the
//! white furnace: 0.5 everywhere), otherwise a `mis` + Sobol render at many more samples per
//! pixel than any measured one, with a seed no measured render uses, cached on disk.
//!
//! Cache files are keyed by the scene's SHA-256, the size, the spp, the seed and the crate version
//! (bump [`CACHE_VERSION`] when the tracer's output changes) and hold per pixel the mean and the
//! estimated variance of the mean (f64, little-endian) after a 32-byte header.
use super::measure::rel_mse;
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::integrator::PathSettings;
use tessera_render::tracer::sampler::SamplerKind;
use tessera_render::tracer::{PixelSums, RenderSettings, Scene, render_tile};

pub const CACHE_VERSION: u32 = 1;
const MAGIC: &[u8; 8] = b"TSACREF1";
/// Reference renders use this seed; measured renders use small seeds.
#[allow(clippy::unusual_byte_groupings)] // spelt "seed of ref"
pub const REFERENCE_SEED: u64 = 0x5eed_0f_2ef;

pub struct Reference {
    pub means: Vec<[f64; 3]>,
    /// Estimated variance of each reference pixel's mean (zero for analytic references).
    pub variance: Vec<[f64; 3]>,
    /// "analytic 0.5" or "mis+sobol 16384 spp".
    pub description: String,
}

impl Reference {
    pub fn analytic(pixels: usize, value: f64, what: &str) -> Reference {
        Reference {
            means: vec![[value; 3]; pixels],
            variance: vec![[0.0; 3]; pixels],
            description: what.into(),
        }
    }

    pub fn rel_mse(&self, sums: &[PixelSums]) -> f64 {
        rel_mse(sums.iter().map(PixelSums::mean), &self.means)
    }

    /// The reference's own expected contribution to a measured relMSE: its estimated error in the
    /// same units. For a Sobol reference the sample variance overstates the error, so this is an
    /// upper bound: a curve far above it is not limited by the reference.
    pub fn noise_floor(&self) -> f64 {
        let mut acc = 0.0;
        for (m, v) in self.means.iter().zip(&self.variance) {
            for c in 0..3 {
                acc += v[c] / (m[c] + 0.01).powi(2);
            }
        }
        acc / (3 * self.means.len()).max(1) as f64
    }
}

/// Loads the reference of `name` from `cache` or renders (and caches) it.
pub fn rendered(
    scene: &Scene,
    scene_bytes: &[u8],
    name: &str,
    size: u32,
    spp: u32,
    cache: &Path,
) -> anyhow::Result<Reference> {
    rendered_with(scene, scene_bytes, name, size, spp, SamplerKind::Sobol, cache)
}

/// As [`rendered`], with the reference's sampler chosen: an independent-sampler reference has an
/// unbiased per-pixel variance estimate, so its noise can be subtracted from a measured error.
pub fn rendered_with(
    scene: &Scene,
    scene_bytes: &[u8],
    name: &str,
    size: u32,
    spp: u32,
    sampler: SamplerKind,
    cache: &Path,
) -> anyhow::Result<Reference> {
    let hash = hex::encode(&Sha256::digest(scene_bytes)[..6]);
    let tag = if sampler == SamplerKind::Sobol { String::new() } else { format!("-{sampler}") };
    let file = cache.join(format!(
        "{name}-{hash}-{size}px-{spp}spp{tag}-seed{REFERENCE_SEED:x}-v{CACHE_VERSION}.bin"
    ));
    let description = format!("mis+{sampler} {spp} spp");
    if let Some((means, variance)) = read(&file, size, spp) {
        return Ok(Reference { means, variance, description });
    }
    let settings = RenderSettings {
        width: size,
        height: size,
        seed: REFERENCE_SEED,
        sampler,
        path: PathSettings::default(),
        background: glam::Vec3::ZERO,
        camera: None,
    };
    let started = std::time::Instant::now();
    let mut sums = vec![PixelSums::default(); (size * size) as usize];
    let chunk = 256.min(spp);
    for s0 in (0..spp).step_by(chunk as usize) {
        let part = render_tile(
            scene,
            &settings,
            settings.full_frame(),
            s0..(s0 + chunk).min(spp),
            &RenderOptions::default(),
        )
        .map_err(anyhow::Error::msg)?;
        sums.iter_mut().zip(&part.pixels).for_each(|(s, p)| s.merge(p));
    }
    eprintln!(
        "  reference {name}: {description} at {size}×{size} in {:.1} s → {}",
        started.elapsed().as_secs_f64(),
        file.display()
    );
    let means: Vec<_> = sums.iter().map(PixelSums::mean).collect();
    let variance: Vec<_> = sums.iter().map(PixelSums::variance_of_mean).collect();
    write(&file, size, spp, &means, &variance)?;
    Ok(Reference { means, variance, description })
}

/// A reference's per-pixel means and variances.
type Planes = (Vec<[f64; 3]>, Vec<[f64; 3]>);

fn read(file: &Path, size: u32, spp: u32) -> Option<Planes> {
    let bytes = std::fs::read(file).ok()?;
    let n = (size * size) as usize;
    if bytes.len() != 32 + n * 48
        || &bytes[..8] != MAGIC
        || bytes[8..12] != size.to_le_bytes()
        || bytes[12..16] != spp.to_le_bytes()
    {
        return None;
    }
    let f =
        |i: usize| f64::from_le_bytes(bytes[32 + i * 8..40 + i * 8].try_into().expect("8 bytes"));
    let means = (0..n).map(|p| [f(p * 6), f(p * 6 + 1), f(p * 6 + 2)]).collect();
    let variance = (0..n).map(|p| [f(p * 6 + 3), f(p * 6 + 4), f(p * 6 + 5)]).collect();
    Some((means, variance))
}

fn write(
    file: &Path,
    size: u32,
    spp: u32,
    means: &[[f64; 3]],
    variance: &[[f64; 3]],
) -> anyhow::Result<()> {
    let mut bytes = Vec::with_capacity(32 + means.len() * 48);
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&size.to_le_bytes());
    bytes.extend_from_slice(&spp.to_le_bytes());
    bytes.resize(32, 0);
    for (m, v) in means.iter().zip(variance) {
        m.iter().chain(v).for_each(|x| bytes.extend_from_slice(&x.to_le_bytes()));
    }
    let dir = file.parent().map(Path::to_path_buf).unwrap_or_else(|| PathBuf::from("."));
    std::fs::create_dir_all(&dir)?;
    let tmp = file.with_extension("tmp");
    std::fs::write(&tmp, bytes)?;
    std::fs::rename(&tmp, file)?;
    Ok(())
}
