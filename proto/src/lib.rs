//! Wire types shared by the coordinator, its workers and its clients.
//!
//! Everything that crosses the network is defined here and only here, so that the tracer
//! (`tessera_worker::tracer`) stays free of serde and the HTTP layer.
//!
//! # Layout
//! - [`job`]: what clients send (`JobRequest`) and read back (`Job`).
//! - [`scene`]: the answer to a scene upload.
//! - [`lease`]: the worker protocol (register, lease, heartbeat, result).
//! - [`sums`]: the compact binary form of a unit's partial sums.
//! - [`problem`]: RFC 9457 problem details for every error.
pub mod job;
pub mod lease;
pub mod problem;
pub mod scene;
pub mod sums;
#[cfg(test)]
mod sums_fuzz;

pub use job::{
    FrameRange, FrameStatus, Job, JobList, JobRequest, JobState, Progress, RenderParams,
    WorkerContribution, WorkerFailures,
};
pub use lease::{
    Heartbeat, Lease, LeaseRequest, PROTOCOL_VERSION, Registration, SUPPORTED_PROTOCOLS,
    WorkerHello, WorkerInfo,
};
pub use problem::Problem;
pub use scene::{SceneAnimation, SceneInfo};
pub use sums::{PartialSums, SumsError, TileRect, WirePixel};
