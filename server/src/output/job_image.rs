//! One frame of a job as an image: its merged sums and the EXR header attributes that say how
//! it was made (`tessera.*`: job, scene, spp, seed, estimator, sampler, light sampler, effects, noise, the
//! renderers whose samples it holds, and for animations the frame, its time, fps and animation).
//! The figures are the frame's as it is written; the render time and renderers are the job's
//! at that moment (a frame completed early is written while later frames still render).
use super::{ImageLayers, MetaValue};
use crate::image;
use crate::scheduler::JobRun;
use tessera_render::tracer::LightSampler;

/// A frame's layers (mean, variance of the mean, samples: 28 bytes a pixel, not the sums' 64)
/// and metadata, taken under the scheduler lock so that encoding (tens of milliseconds and up)
/// happens outside it.
pub struct JobImage {
    pub layers: ImageLayers,
    meta: Vec<(String, MetaValue)>,
}

impl JobImage {
    /// Frame index `index` of the job (0 for a still).
    pub fn of(job: &JobRun, index: usize, now: u64) -> JobImage {
        JobImage { layers: frame_layers(job, index), meta: exr_meta(job, index, now) }
    }

    pub fn encode_exr(&self) -> anyhow::Result<Vec<u8>> {
        super::encode_exr(&self.layers, &self.meta)
    }

    pub fn encode_png(&self) -> Vec<u8> {
        super::encode_png_preview(self.layers.width, self.layers.height, &self.layers.rgb)
    }
}

/// One frame's layers, straight from its tiles' sums (no copy of the sums: a 4-megapixel frame's
/// are 256 MiB).
fn frame_layers(job: &JobRun, index: usize) -> ImageLayers {
    let width = job.cfg().params.width as usize;
    let mut img = ImageLayers::zeroed(width, job.cfg().params.height as usize);
    for t in job.tiles()[job.frame_tiles(index)].iter().filter(|t| !t.merged.is_empty()) {
        let (x0, y0, w) = (t.rect.x0 as usize, t.rect.y0 as usize, t.rect.w as usize);
        for (k, p) in t.merged.iter().enumerate() {
            image::set_pixel(&mut img, (y0 + k / w) * width + x0 + k % w, p);
        }
    }
    img
}

fn exr_meta(job: &JobRun, index: usize, now: u64) -> Vec<(String, MetaValue)> {
    let p = &job.cfg().params;
    let mut meta = vec![
        ("software".to_string(), MetaValue::Text(format!("tessera {}", env!("CARGO_PKG_VERSION")))),
        ("tessera.job".into(), MetaValue::Text(job.cfg().id.clone())),
        ("tessera.scene".into(), MetaValue::Text(job.cfg().scene_id.clone())),
        ("tessera.spp".into(), MetaValue::Double(job.frame_samples_done(index))),
        ("tessera.seed".into(), MetaValue::Text(p.seed.to_string())),
        ("tessera.estimator".into(), MetaValue::Text(p.estimator.clone())),
        ("tessera.sampler".into(), MetaValue::Text(p.sampler.clone())),
        (
            "tessera.light_sampler".into(),
            MetaValue::Text(
                p.light_sampler.clone().unwrap_or_else(|| LightSampler::Auto.name().into()),
            ),
        ),
        ("tessera.effects".into(), MetaValue::Text(job.cfg().effects.join(","))),
        // The frame's own: an animation's frame may be written while later frames still render.
        ("tessera.dropped_samples".into(), MetaValue::Text(job.frame_dropped(index).to_string())),
        ("tessera.max_sample_weight".into(), MetaValue::Double(job.frame_max_weight(index))),
        ("tessera.render_time_s".into(), MetaValue::Double(job.elapsed_ms(now) as f64 / 1000.0)),
        ("tessera.noise".into(), MetaValue::Double(job.frame_noise(index).unwrap_or(0.0))),
        // One renderer id, or several separated by "; " (see scheduler/renderers.rs).
        ("tessera.renderers".into(), MetaValue::Text(job.renderers().join("; "))),
    ];
    if job.is_animation() {
        meta.push(("tessera.frame".into(), MetaValue::Text(job.frame_number(index).to_string())));
        meta.push(("tessera.time_s".into(), MetaValue::Double(job.frame_time_s(index))));
        meta.push(("tessera.fps".into(), MetaValue::Double(p.fps)));
        meta.push((
            "tessera.animation".into(),
            MetaValue::Text(p.animation.clone().unwrap_or_else(|| "first".into())),
        ));
    }
    meta
}
