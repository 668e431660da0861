//! A row's samples rendered several paths at a time, stage by stage.
//!
//! [`render_row_lanes`] keeps [`LANES`] paths in flight and runs each stage of
//! [`crate::tracer::path`] for all of them before the next stage: eight traversals, then eight
//! surfaces shaded, then eight shadow rays, then eight continuations. A path that ends frees its
//! lane for the row's next sample. Paths finish out of order; their samples wait in a window
//! and are added to their pixel in sample-index order, so every pixel's sums are the bits
//! [`crate::tracer::render::render_row`] gives.
use crate::tracer::camera::RasterCamera;
use crate::tracer::effects::EffectSet;
use crate::tracer::film::PixelSums;
use crate::tracer::integrator::{Integrator, PathSample};
use crate::tracer::path::{Path, Shaded};
use crate::tracer::render::{RenderSettings, RowStats};
use crate::tracer::sampler::{PixelSeeds, Sampler};
use crate::tracer::surface::Surface;
use std::ops::Range;

/// Paths in flight per row.
pub const LANES: usize = 8;
/// Samples that may finish ahead of the oldest unfinished one (a long path holds back
/// refills, not results).
const WINDOW: usize = 64;

/// One path in flight and what its last stage left for the next.
struct Lane<'p> {
    item: usize,
    path: Path,
    sampler: Sampler<'p>,
    surface: Option<Surface>,
    shaded: Option<Shaded>,
}

/// Finished samples waiting for the ones before them.
struct Window<'a> {
    done: [Option<PathSample>; WINDOW],
    /// The oldest sample not yet added to its pixel.
    next_commit: usize,
    spp: usize,
    pixels: &'a mut [PixelSums],
    stats: RowStats,
}

impl Window<'_> {
    /// Records item `item`'s sample and adds every sample now next in line to its pixel.
    fn finish(&mut self, item: usize, sample: PathSample) {
        self.done[item % WINDOW] = Some(sample);
        while let Some(s) = self.done[self.next_commit % WINDOW].take() {
            self.stats.add_sample(&mut self.pixels[self.next_commit / self.spp], &s);
            self.next_commit += 1;
        }
    }
}

/// [`crate::tracer::render::render_row`], several paths at a time (the same sums, bit for bit).
pub(crate) fn render_row_lanes<E: EffectSet>(
    integrator: &Integrator,
    camera: &RasterCamera,
    settings: &RenderSettings,
    x0: u32,
    py: u32,
    samples: Range<u32>,
    pixels: &mut [PixelSums],
) -> RowStats {
    let spp = samples.len();
    let total = pixels.len() * spp;
    let seeds: Vec<PixelSeeds> = (0..pixels.len() as u32).map(|col| PixelSeeds::new(settings.sampler, settings.seed, x0 + col, py)).collect();
    let mut window = Window { done: [None; WINDOW], next_commit: 0, spp, pixels, stats: RowStats::default() };
    let mut lanes: [Option<Lane>; LANES] = std::array::from_fn(|_| None);
    let mut next = 0;
    loop {
        for slot in lanes.iter_mut().filter(|l| l.is_none()) {
            if next >= total || next - window.next_commit >= WINDOW {
                break;
            }
            let (col, index) = (next / spp, samples.start + (next % spp) as u32);
            let mut sampler = Sampler::for_pixel(&seeds[col], index);
            let px = x0 + col as u32;
            let jitter = sampler.get_2d();
            let ray = if E::DOF { camera.ray_lens(px, py, jitter, sampler.get_2d()) } else { camera.ray(px, py, jitter) };
            *slot = Some(Lane { item: next, path: Path::new(ray), sampler, surface: None, shaded: None });
            next += 1;
        }
        if lanes.iter().all(Option::is_none) {
            return window.stats;
        }
        for slot in lanes.iter_mut() {
            let Some(lane) = slot else { continue };
            lane.surface = integrator.arrive::<E>(&mut lane.path, &mut lane.sampler);
            if lane.surface.is_none() {
                end(slot, &mut window);
            }
        }
        for slot in lanes.iter_mut() {
            let Some(lane) = slot else { continue };
            let s = lane.surface.as_ref().expect("arrived");
            lane.shaded = integrator.shade::<E>(&mut lane.path, s, &mut lane.sampler);
            if lane.shaded.is_none() {
                end(slot, &mut window);
            }
        }
        for lane in lanes.iter_mut().flatten() {
            if let Some(test) = lane.shaded.as_ref().and_then(|s| s.shadow.as_ref()) {
                integrator.test_shadow::<E>(&mut lane.path, test);
            }
        }
        for slot in lanes.iter_mut() {
            let Some(lane) = slot else { continue };
            let (s, shaded) = (lane.surface.take().expect("arrived"), lane.shaded.take().expect("shaded"));
            if !integrator.continue_path::<E>(&mut lane.path, &s, shaded.bs, &mut lane.sampler) {
                end(slot, &mut window);
            }
        }
    }
}

/// Ends the path in `slot`, freeing the lane.
fn end(slot: &mut Option<Lane>, window: &mut Window) {
    if let Some(lane) = slot.take() {
        window.finish(lane.item, lane.path.sample());
    }
}
