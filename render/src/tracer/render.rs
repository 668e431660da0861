//! Rendering one unit: a tile over a range of sample indices, in parallel over rows.
//!
//! Each pixel's samples are summed in sample-index order by a single thread, and each sample's
//! random numbers depend only on (seed, pixel, sample index, dimension), so the result is
//! bit-identical whatever the thread count or the machine.
//!
//! The scene chooses the kernel (its effects) and caps the path depth (its needed depth: 0 when
//! nothing can scatter or nothing emits) unless the caller forces a kernel.
use crate::dispatch_kernel;
use crate::tracer::camera::{CameraError, RasterCamera};
use crate::tracer::film::{PixelSums, Tile, TileSums};
use crate::tracer::integrator::{Integrator, PathSettings};
use crate::tracer::kernel::{EffectSet, KernelBits};
#[cfg(feature = "bench")]
use crate::tracer::ray_log::RayLog;
use crate::tracer::sampler::{PixelSeeds, Sampler, SamplerKind};
use crate::tracer::scene::Scene;
use glam::Vec3;
use rayon::prelude::*;
use std::ops::Range;
use std::sync::atomic::{AtomicBool, Ordering};

#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    pub sampler: SamplerKind,
    pub path: PathSettings,
    /// Constant background radiance (linear RGB); zero means none.
    pub background: Vec3,
    /// Camera name; the scene's first camera when None.
    pub camera: Option<String>,
}

impl RenderSettings {
    pub fn full_frame(&self) -> Tile {
        Tile { x0: 0, y0: 0, w: self.width, h: self.height }
    }
}

/// What a caller may ask of one unit's render beyond its settings. The default renders the
/// kernel the scene's effects select, to the end, logging nothing.
#[derive(Clone, Copy, Debug, Default)]
pub struct RenderOptions<'a> {
    /// Gives up with [`RenderError::Canceled`] once set; checked per row.
    pub cancel: Option<&'a AtomicBool>,
    /// A kernel chosen by the caller (None: the one the scene's effects select, and the path
    /// depth the scene needs, [`Scene::needed_depth`]). A kernel with more effects than needed
    /// gives the same image in expectation, only slower (the "forced on" comparison of the
    /// benchmarks); a forced kernel also runs the job's full depth.
    pub kernel: Option<KernelBits>,
    /// Where every ray traced is recorded, so benchmarks can trace the same rays alone.
    #[cfg(feature = "bench")]
    pub ray_log: Option<&'a RayLog>,
}

/// Why a unit was not rendered.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RenderError {
    #[error("tile {tile:?} exceeds the {width}×{height} image")]
    TileOutsideImage { tile: Tile, width: u32, height: u32 },
    #[error(transparent)]
    Camera(#[from] CameraError),
    #[error("the render was canceled")]
    Canceled,
}

/// Renders sample indices `samples` of every pixel in `tile`.
pub fn render_tile(
    scene: &Scene,
    settings: &RenderSettings,
    tile: Tile,
    samples: Range<u32>,
    options: &RenderOptions,
) -> Result<TileSums, RenderError> {
    let plan = UnitPlan::new(scene, settings, tile, options.kernel)?;
    let integrator = Integrator::new(scene, settings.background, plan.path);
    #[cfg(feature = "bench")]
    let integrator = match options.ray_log {
        Some(log) => integrator.with_ray_log(log),
        None => integrator,
    };
    let never = AtomicBool::new(false);
    let cancel = options.cancel.unwrap_or(&never);
    dispatch_kernel!(
        plan.kernel,
        render_rows(&integrator, &plan.camera, settings, tile, samples, cancel)
    )
    .ok_or(RenderError::Canceled)
}

/// What a unit's rows share, worked out once: the camera bound to the image, the path
/// settings capped to the scene's needed depth, the kernel.
#[derive(Clone, Copy, Debug)]
pub(crate) struct UnitPlan {
    pub camera: RasterCamera,
    pub path: PathSettings,
    pub kernel: KernelBits,
}

impl UnitPlan {
    /// Checks the tile against the image and resolves the camera (None: the scene's first).
    pub(crate) fn new(
        scene: &Scene,
        settings: &RenderSettings,
        tile: Tile,
        kernel: Option<KernelBits>,
    ) -> Result<UnitPlan, RenderError> {
        if tile.x0.checked_add(tile.w).is_none_or(|x| x > settings.width)
            || tile.y0.checked_add(tile.h).is_none_or(|y| y > settings.height)
        {
            return Err(RenderError::TileOutsideImage {
                tile,
                width: settings.width,
                height: settings.height,
            });
        }
        let camera = scene.camera(settings.camera.as_deref())?;
        let mut path = settings.path;
        if kernel.is_none() {
            path.max_depth = path.max_depth.min(scene.needed_depth(settings.background));
        }
        let kernel =
            kernel.unwrap_or_else(|| scene.effects_for(camera, settings.background).kernel());
        Ok(UnitPlan { camera: camera.raster(settings.width, settings.height), path, kernel })
    }
}

fn render_rows<E: EffectSet>(
    integrator: &Integrator,
    camera: &RasterCamera,
    settings: &RenderSettings,
    tile: Tile,
    samples: Range<u32>,
    cancel: &AtomicBool,
) -> Option<TileSums> {
    let mut out = TileSums::new(tile);
    let rows: Vec<RowStats> = out
        .pixels
        .par_chunks_mut(tile.w.max(1) as usize)
        .enumerate()
        // One row per task: rows cost ~1 ms and differ a lot (light, walls), and rayon's default
        // splitting leaves one thread idle for many rows at the end of each unit.
        .with_max_len(1)
        .map(|(row, pixels)| {
            if cancel.load(Ordering::Relaxed) {
                return RowStats::default();
            }
            render_row::<E>(
                integrator,
                camera,
                settings,
                tile.x0,
                tile.y0 + row as u32,
                samples.clone(),
                pixels,
            )
        })
        .collect();
    if cancel.load(Ordering::Relaxed) {
        return None;
    }
    for stats in rows {
        stats.add_to(&mut out);
    }
    Some(out)
}

/// What a row adds to its tile's totals besides its pixels.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RowStats {
    dropped: u64,
    max_weight: f32,
    rays: u64,
}

impl RowStats {
    /// Integer sums and a maximum: the same whatever order rows are added in.
    pub(crate) fn add_to(self, out: &mut TileSums) {
        out.dropped += self.dropped;
        out.max_weight = out.max_weight.max(self.max_weight);
        out.rays += self.rays;
    }
}

/// Adds samples `samples` of the pixels of row `py` starting at column `x0` into `pixels`, each
/// pixel's samples in index order, so a pixel's sums do not depend on which thread ran the row.
pub(crate) fn render_row<E: EffectSet>(
    integrator: &Integrator,
    camera: &RasterCamera,
    settings: &RenderSettings,
    x0: u32,
    py: u32,
    samples: Range<u32>,
    pixels: &mut [PixelSums],
) -> RowStats {
    let mut stats = RowStats::default();
    for (col, sums) in pixels.iter_mut().enumerate() {
        let px = x0 + col as u32;
        let seeds = PixelSeeds::new(settings.sampler, settings.seed, px, py);
        for index in samples.clone() {
            let mut sampler = Sampler::for_pixel(&seeds, index);
            let jitter = sampler.get_2d();
            let ray = if E::DOF {
                camera.ray_lens(px, py, jitter, sampler.get_2d())
            } else {
                camera.ray(px, py, jitter)
            };
            let s = integrator.li_for::<E>(ray, &mut sampler);
            stats.rays += u64::from(s.rays);
            if s.radiance.is_finite() {
                sums.add_sample(s.radiance);
                stats.max_weight = stats.max_weight.max(s.max_weight);
            } else {
                stats.dropped += 1;
            }
        }
    }
    stats
}

/// Mean radiance over a whole frame of sums (for tests and quick checks).
pub fn frame_mean(pixels: &[PixelSums]) -> [f64; 3] {
    let mut m = [0.0; 3];
    for p in pixels {
        let pm = p.mean();
        for c in 0..3 {
            m[c] += pm[c];
        }
    }
    m.map(|v| v / pixels.len().max(1) as f64)
}
