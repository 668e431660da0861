//! Jobs as clients see them.
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// `POST /v1/jobs`: what to render and when to stop. At least one of `spp`, `noise_target`,
/// `time_limit_s` must be given; all given ones apply and the first reached ends the job.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct JobRequest {
    /// A scene id (sha256 from `POST /v1/scenes`) or a bundled scene name such as "cornell-box".
    pub scene: String,
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (the most any pixel gets).
    pub spp: Option<u32>,
    /// Stop each tile once its estimated relative MSE is at or below this.
    pub noise_target: Option<f64>,
    /// Stop issuing work after this many seconds of render time (from the first unit leased;
    /// time paused or with the coordinator down does not count) and finish with what is merged.
    pub time_limit_s: Option<f64>,
    /// naive | bsdf | light | mis (default mis).
    pub estimator: Option<String>,
    /// sobol | independent (default sobol).
    pub sampler: Option<String>,
    pub seed: Option<u64>,
    /// Camera name (default: the scene's first perspective camera).
    pub camera: Option<String>,
    /// Tile edge in pixels (default 64).
    pub tile_size: Option<u32>,
    /// Samples per pixel in one unit of work (default 16).
    pub batch_spp: Option<u32>,
    /// Safety cap on bounces (default 1024).
    pub max_depth: Option<u32>,
    /// Russian roulette may end paths from this non-specular bounce on (default 5; refractions
    /// and reflections on smooth glass do not count); 0 turns it off, so paths run to `max_depth`. Any value gives the same expected image; lower is faster and
    /// noisier per sample.
    pub roulette_depth: Option<u32>,
    /// How a light sample chooses among the scene's emissive triangles: `auto` (default: through
    /// a light tree from 32 of them on, or fewer that differ in what they give the scene's
    /// surfaces, such as lamps apart; else in proportion to power), `power`, or `tree` (through
    /// the tree whatever their number). Any choice gives the same expected image. `auto` is
    /// settled when the job is accepted (the effects list `light_tree` where it means the tree),
    /// so every unit and every frame of an animation choose alike.
    pub light_sampler: Option<String>,
    /// Constant background radiance, linear RGB (default black).
    pub background: Option<[f32; 3]>,
    /// Higher runs first; equal priorities share workers fairly (default 0).
    pub priority: Option<i32>,
    /// Frames of the scene's animation to render (default: the single frame 0).
    pub frames: Option<FrameRange>,
    /// The glTF animation to play, by name or index (default: the first one, if any).
    pub animation: Option<String>,
}

/// An inclusive range of animation frames: `start`, `start + step`, … up to `end`. Frame n
/// shows the scene at time n / fps seconds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct FrameRange {
    pub start: u32,
    pub end: u32,
    /// Default 1.
    pub step: Option<u32>,
    /// Frames per second of animation time (default 24).
    pub fps: Option<f64>,
}

/// Frames per second when a job does not say.
pub const DEFAULT_FPS: f64 = 24.0;

fn default_fps() -> f64 {
    DEFAULT_FPS
}

/// The render settings a worker needs, fixed when the job is accepted.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct RenderParams {
    pub width: u32,
    pub height: u32,
    pub seed: u64,
    pub estimator: String,
    pub sampler: String,
    pub camera: Option<String>,
    pub max_depth: u32,
    /// Russian roulette from this non-specular bounce on (0: off). None, from a coordinator that predates the
    /// setting, leaves the worker's default.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roulette_depth: Option<u32>,
    /// `power` or `tree`: the coordinator settles a job's `auto` when it accepts the job, as its
    /// effects list says (`light_tree`), so every unit and frame choose lights alike. `auto`,
    /// or None from a coordinator that predates the setting, leaves the choice to each worker's
    /// scene.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_sampler: Option<String>,
    pub background: [f32; 3],
    /// The glTF animation, by name or index; None plays the first one (if the scene has any).
    #[serde(default)]
    pub animation: Option<String>,
    /// Frame n of a lease is the scene at time n / fps seconds.
    #[serde(default = "default_fps")]
    pub fps: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(rename_all = "lowercase")]
pub enum JobState {
    Queued,
    Running,
    /// Held by request (`POST /v1/jobs/{id}/pause`): no new units are leased; units already
    /// leased finish and are merged. `…/resume` makes it `queued` until a worker takes a unit.
    Paused,
    Done,
    Failed,
    Canceled,
}

impl JobState {
    pub const ALL: [JobState; 6] = [
        JobState::Queued,
        JobState::Running,
        JobState::Paused,
        JobState::Done,
        JobState::Failed,
        JobState::Canceled,
    ];

    pub fn is_final(self) -> bool {
        matches!(self, JobState::Done | JobState::Failed | JobState::Canceled)
    }

    /// The state as the API spells it (its serde name), for messages, metrics and the CLI.
    pub fn name(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Running => "running",
            JobState::Paused => "paused",
            JobState::Done => "done",
            JobState::Failed => "failed",
            JobState::Canceled => "canceled",
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Progress {
    /// Mean samples per pixel merged so far.
    pub samples_done: f64,
    /// Samples per pixel the job aims for (its `spp`, or its cap when only noise or time stop it).
    pub samples_target: f64,
    /// 0 to 1; for noise-target jobs the larger of the sample and the noise fractions.
    pub fraction: f64,
}

/// `GET /v1/jobs/{id}`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Job {
    pub id: String,
    pub state: JobState,
    pub scene: String,
    pub request: JobRequest,
    pub progress: Progress,
    /// Estimated relative MSE of the current image (mean over pixels and channels of
    /// Var(mean)/(mean + 0.01)²), as of the newest `history` row (exact once the job has
    /// ended); null before two samples per pixel are merged.
    pub noise: Option<f64>,
    /// Render time so far: from the first unit leased, without time paused or with the
    /// coordinator down.
    pub elapsed_s: f64,
    pub eta_s: Option<f64>,
    pub samples_per_s: f64,
    /// Workers holding a lease on this job now.
    pub workers: u32,
    pub effects: Vec<String>,
    /// [seconds since start, samples per pixel, noise]: a row after a merge at most every 100 ms,
    /// and 1 µs later for each pixel whose relMSE the last row recomputed (a 1-megapixel frame:
    /// about a row a second), and after the last merge; thinned to ≤ 512 rows.
    pub history: Vec<[f64; 3]>,
    pub dropped_samples: u64,
    pub max_sample_weight: f64,
    /// Why the job failed, or how it ended.
    pub message: Option<String>,
    pub created_unix_ms: u64,
    /// When the coordinator saw the job end (its images written), by the wall clock; what
    /// `tessera serve --delete-ended-after` counts from. Absent while it runs.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ended_unix_ms: Option<u64>,
    /// Workers that failed units of this job (leases expired, malformed results); those at the
    /// coordinator's limit (`--max-failures`) get no more of its units.
    #[serde(default)]
    pub worker_failures: Vec<WorkerFailures>,
    /// Samples each worker rendered into the merged image so far (counted as units merge).
    #[serde(default)]
    pub contributions: Vec<WorkerContribution>,
    /// Per animation frame, in frame order (one entry for a still).
    #[serde(default)]
    pub frames: Vec<FrameStatus>,
    /// Renderer ids of the workers whose samples are merged, in order of their first merge.
    /// One renderer per job while a worker of it is live; more only when a job outlived every
    /// worker of its renderer (e.g. a farm upgraded mid-job) and others went on with it.
    #[serde(default)]
    pub renderers: Vec<String>,
}

/// One frame of a job: its progress and what preparing its scene cost the workers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct FrameStatus {
    pub frame: u32,
    /// Animation time of the frame in seconds (frame / fps).
    pub time_s: f64,
    /// Mean samples per pixel merged in this frame.
    pub samples_done: f64,
    /// Estimated relMSE of this frame, as of the job's newest `history` row; null before any
    /// tile has two samples per pixel.
    pub noise: Option<f64>,
    /// True once every tile of the frame is complete (its EXR is final when the job is done).
    pub done: bool,
    /// Scene preparations workers reported for units of this frame: full BVH builds, refits of
    /// another frame's BVH, and their total time in milliseconds.
    pub builds: u32,
    pub refits: u32,
    pub prepare_ms: f64,
    /// The largest peak resident memory (bytes) that workers reported with this frame's results:
    /// what rendering it needed on one worker, at most (a worker's peak may date from an earlier,
    /// larger scene). Null until a worker that reports memory returns a result.
    #[serde(default)]
    pub worker_peak_rss_bytes: Option<u64>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct WorkerFailures {
    pub worker_id: String,
    pub name: String,
    pub failures: u32,
    /// True once the worker is kept off the job.
    pub blocked: bool,
}

/// A worker's share of a job: pixel-samples of its units that were merged (a unit counts once,
/// when it merges; units dropped by a noise stop or a cancel do not count).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct WorkerContribution {
    pub worker_id: String,
    pub name: String,
    pub samples: u64,
}

/// `GET /v1/jobs`: newest first.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct JobList {
    pub jobs: Vec<Job>,
    /// Pass as `?before=` to get the next page; null on the last page.
    pub next: Option<String>,
}

#[cfg(test)]
mod tests {
    use super::JobState;

    #[test]
    fn every_state_is_named_as_serde_spells_it() {
        for state in JobState::ALL {
            assert_eq!(serde_json::to_value(state).unwrap(), state.name(), "{state:?}");
            assert_eq!(serde_json::from_value::<JobState>(state.name().into()).unwrap(), state);
        }
        let mut names = JobState::ALL.map(JobState::name);
        names.sort_unstable();
        assert!(names.windows(2).all(|w| w[0] != w[1]), "ALL lists each state once: {names:?}");
    }
}
