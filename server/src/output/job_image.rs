//! One frame of a job as an image: its merged sums and the EXR header attributes that say how
//! it was made (`tessera.*`: job, scene, spp, seed, estimator, sampler, effects, noise, the
//! renderers whose samples it holds, and for animations the frame, its time, fps and animation).
use super::MetaValue;
use crate::image;
use crate::scheduler::JobRun;
use tessera_worker::tracer::PixelSums;

/// A copy of a job's merged sums and metadata, taken under the scheduler lock so that encoding
/// (tens of milliseconds and up) happens outside it.
pub struct JobImage {
    pub width: u32,
    pub height: u32,
    pub frame: Vec<PixelSums>,
    meta: Vec<(String, MetaValue)>,
}

impl JobImage {
    /// Frame index `index` of the job (0 for a still).
    pub fn of(job: &JobRun, index: usize, now: u64) -> JobImage {
        let p = &job.cfg.params;
        JobImage { width: p.width, height: p.height, frame: job.frame_sums(index), meta: exr_meta(job, index, now) }
    }

    pub fn encode_exr(&self) -> anyhow::Result<Vec<u8>> {
        super::encode_exr(&image::layers(self.width, self.height, &self.frame), &self.meta)
    }

    pub fn encode_png(&self) -> Vec<u8> {
        let layers = image::layers(self.width, self.height, &self.frame);
        super::encode_png_preview(layers.width, layers.height, &layers.rgb)
    }
}

fn exr_meta(job: &JobRun, index: usize, now: u64) -> Vec<(String, MetaValue)> {
    let p = &job.cfg.params;
    let mut meta = vec![
        ("software".to_string(), MetaValue::Text(format!("tessera {}", env!("CARGO_PKG_VERSION")))),
        ("tessera.job".into(), MetaValue::Text(job.cfg.id.clone())),
        ("tessera.scene".into(), MetaValue::Text(job.cfg.scene_id.clone())),
        ("tessera.spp".into(), MetaValue::Double(job.frame_samples_done(index))),
        ("tessera.seed".into(), MetaValue::Text(p.seed.to_string())),
        ("tessera.estimator".into(), MetaValue::Text(p.estimator.clone())),
        ("tessera.sampler".into(), MetaValue::Text(p.sampler.clone())),
        ("tessera.effects".into(), MetaValue::Text(job.cfg.effects.join(","))),
        ("tessera.dropped_samples".into(), MetaValue::Text(job.dropped().to_string())),
        ("tessera.max_sample_weight".into(), MetaValue::Double(job.max_weight())),
        ("tessera.render_time_s".into(), MetaValue::Double(job.elapsed_ms(now) as f64 / 1000.0)),
        ("tessera.noise".into(), MetaValue::Double(job.frame_noise(index).unwrap_or(0.0))),
        // One renderer id, or several separated by "; " (see scheduler/renderers.rs).
        ("tessera.renderers".into(), MetaValue::Text(job.renderers.join("; "))),
    ];
    if job.is_animation() {
        meta.push(("tessera.frame".into(), MetaValue::Text(job.frame_number(index).to_string())));
        meta.push(("tessera.time_s".into(), MetaValue::Double(job.frame_time_s(index))));
        meta.push(("tessera.fps".into(), MetaValue::Double(p.fps)));
        meta.push(("tessera.animation".into(), MetaValue::Text(p.animation.clone().unwrap_or_else(|| "first".into()))));
    }
    meta
}

