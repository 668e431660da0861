//! A job's status as clients see it (`GET /v1/jobs/{id}`), built from the scheduler's state.
use crate::scheduler::JobRun;
use tessera_proto::{FrameStatus, Job, JobState, Progress, WorkerContribution, WorkerFailures};

/// The client's view of a job.
pub fn job_status(job: &JobRun, now: u64, workers: u32, max_failures: u32) -> Job {
    let elapsed_ms = job.elapsed_ms(now);
    let elapsed_s = elapsed_ms as f64 / 1000.0;
    let done = job.samples_done();
    let target = job.cfg().spp as f64;
    let noise = job.reported_noise();
    let mut fraction = (done / target).min(1.0);
    if let (Some(t), Some(n)) = (job.cfg().noise_target, noise) {
        fraction = fraction.max((t / n).min(1.0));
    }
    if let Some(limit) = job.cfg().time_limit_ms {
        fraction = fraction.max((elapsed_ms as f64 / limit as f64).min(1.0));
    }
    if job.state() == JobState::Done {
        fraction = 1.0;
    }
    let rate = if elapsed_s > 0.0 { done / elapsed_s } else { 0.0 };
    let eta_s = eta(job, done, rate, noise, elapsed_s);
    Job {
        id: job.cfg().id.clone(),
        state: job.state(),
        scene: job.cfg().scene_id.clone(),
        request: job.cfg().request.clone(),
        progress: Progress { samples_done: done, samples_target: target, fraction },
        noise,
        elapsed_s,
        eta_s,
        samples_per_s: rate * job.pixel_count() as f64,
        workers,
        effects: job.cfg().effects.clone(),
        history: job
            .history()
            .rows
            .iter()
            .map(|r| [r[0], r[1], if r[2].is_finite() { r[2] } else { 0.0 }])
            .collect(),
        dropped_samples: job.dropped(),
        max_sample_weight: job.max_weight(),
        message: job.message().map(str::to_owned),
        created_unix_ms: job.cfg().created_unix_ms,
        ended_unix_ms: job.ended_unix_ms(),
        worker_failures: job
            .failures()
            .iter()
            .map(|(id, f)| WorkerFailures {
                worker_id: id.clone(),
                name: f.name.clone(),
                failures: f.count,
                blocked: f.count >= max_failures,
            })
            .collect(),
        renderers: job.renderers().to_vec(),
        contributions: job
            .contributions()
            .iter()
            .map(|(id, (name, n))| WorkerContribution {
                worker_id: id.clone(),
                name: name.clone(),
                samples: *n,
            })
            .collect(),
        frames: (0..job.frame_count()).map(|i| frame_status(job, i)).collect(),
    }
}

fn frame_status(job: &JobRun, index: usize) -> FrameStatus {
    let prep = job.frame_prepare(index);
    FrameStatus {
        frame: job.frame_number(index),
        time_s: job.frame_time_s(index),
        samples_done: job.frame_samples_done(index),
        noise: job.reported_frame_noise(index),
        done: job.frame_complete(index),
        builds: prep.builds,
        refits: prep.refits,
        prepare_ms: prep.ms,
        worker_peak_rss_bytes: (prep.peak_rss_bytes > 0).then_some(prep.peak_rss_bytes),
    }
}

/// Seconds left: to the spp target at the current rate, to the noise target assuming noise ∝ 1/spp,
/// and to the time limit — whichever comes first.
fn eta(job: &JobRun, done: f64, rate: f64, noise: Option<f64>, elapsed_s: f64) -> Option<f64> {
    if job.state().is_final() {
        return Some(0.0);
    }
    if job.state() == JobState::Paused {
        return None;
    }
    if rate <= 0.0 {
        return None;
    }
    let mut samples_needed = job.cfg().spp as f64;
    if let (Some(t), Some(n)) = (job.cfg().noise_target, noise) {
        samples_needed = samples_needed.min(done * n / t);
    }
    let mut eta = ((samples_needed - done) / rate).max(0.0);
    if let Some(limit) = job.cfg().time_limit_ms {
        eta = eta.min((limit as f64 / 1000.0 - elapsed_s).max(0.0));
    }
    Some(eta)
}
