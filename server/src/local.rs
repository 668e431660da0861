//! Rendering a whole frame on this machine with the tracer directly (all cores, via rayon).
use std::time::{Duration, Instant};
use tessera_worker::tracer::{PixelSums, RenderSettings, Scene, render_tile};

pub struct LocalRender {
    pub pixels: Vec<PixelSums>,
    pub spp: u32,
    pub dropped: u64,
    pub max_weight: f32,
    pub elapsed: Duration,
}

/// Renders `spp` samples per pixel in batches of `batch`, calling `progress(samples_done)` after each.
pub fn render(scene: &Scene, settings: &RenderSettings, spp: u32, batch: u32, mut progress: impl FnMut(u32)) -> Result<LocalRender, String> {
    let start = Instant::now();
    let frame = settings.full_frame();
    let mut pixels = vec![PixelSums::default(); frame.pixel_count()];
    let (mut dropped, mut max_weight) = (0, 0f32);
    let mut s0 = 0;
    while s0 < spp {
        let s1 = (s0 + batch.max(1)).min(spp);
        let sums = render_tile(scene, settings, frame, s0..s1)?;
        sums.add_into_frame(&mut pixels, settings.width);
        dropped += sums.dropped;
        max_weight = max_weight.max(sums.max_weight);
        progress(s1);
        s0 = s1;
    }
    Ok(LocalRender { pixels, spp, dropped, max_weight, elapsed: start.elapsed() })
}
