//! The worker protocol. Workers pull; the coordinator never needs their addresses.
//!
//! 1. `POST /v1/workers` with [`WorkerHello`] → [`Registration`] (a worker id).
//! 2. `POST /v1/leases` with [`LeaseRequest`] → `200` [`Lease`], or `204` when there is no work.
//! 3. While rendering, `POST /v1/leases/{id}/heartbeat` → `200` [`Heartbeat`] (new deadline), or
//!    `409` when the lease is gone (expired, job canceled): stop and drop the unit.
//! 4. `PUT /v1/leases/{id}/result` with the binary [`crate::sums`] body → `204` merged,
//!    `409` stale (late or duplicate: ignored, never counted twice), `422` malformed.
//! 5. Scenes are fetched once per worker by hash: `GET /v1/scenes/{id}/data`.
use crate::job::RenderParams;
use crate::sums::TileRect;
use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

/// The version of the worker protocol this build speaks. A coordinator registers only workers
/// of a version it speaks ([`SUPPORTED_PROTOCOLS`]) and says so in its refusal, so a mismatch is
/// one clear error at registration instead of misread leases later. Raise it with any change a
/// worker or coordinator of the previous version would misread.
pub const PROTOCOL_VERSION: u32 = 1;

/// The worker protocol versions a coordinator of this build registers.
pub const SUPPORTED_PROTOCOLS: std::ops::RangeInclusive<u32> = 1..=PROTOCOL_VERSION;

fn first_protocol() -> u32 {
    1
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct WorkerHello {
    /// The worker protocol version the worker speaks ([`PROTOCOL_VERSION`]); absent from workers
    /// built before versions were sent, which speak version 1.
    #[serde(default = "first_protocol")]
    #[schema(minimum = 1)]
    pub protocol: u32,
    /// A human-readable name (host name by default).
    pub name: String,
    pub threads: u32,
    /// Which renderer the worker runs: `tessera <version> src:<hash> libm:<hash>` (its build's
    /// source hash and a probe of its libm). A job's units go to workers of one renderer while
    /// one is live, so its bits do not depend on who rendered what. Absent (empty) from workers
    /// built before renderer ids: they count as one renderer.
    #[serde(default)]
    pub renderer: String,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct Registration {
    /// The worker protocol version the coordinator speaks with this worker.
    #[serde(default = "first_protocol")]
    pub protocol: u32,
    pub worker_id: String,
    /// Heartbeat at least this often while holding a lease.
    pub heartbeat_ms: u64,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
#[serde(deny_unknown_fields)]
pub struct LeaseRequest {
    pub worker_id: String,
}

/// One unit of work: a tile of one frame of a job over a range of sample indices.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct Lease {
    pub lease_id: String,
    pub job_id: String,
    /// sha256 of the scene bytes; fetch with `GET /v1/scenes/{scene_id}/data` if not cached.
    pub scene_id: String,
    pub params: RenderParams,
    /// The animation frame (0 for a still); render the scene at time frame / params.fps.
    #[serde(default)]
    pub frame: u32,
    pub tile: TileRect,
    /// Sample indices [start, end) of every pixel in the tile.
    pub samples: [u32; 2],
    /// Milliseconds from now until the lease expires unless a heartbeat extends it.
    pub deadline_ms: u64,
}

#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize, ToSchema)]
pub struct Heartbeat {
    pub deadline_ms: u64,
}

/// `GET /v1/workers`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, ToSchema)]
pub struct WorkerInfo {
    pub id: String,
    pub name: String,
    pub threads: u32,
    /// The lease it holds now, as "job/tile/batch".
    pub current: Option<String>,
    pub units_done: u64,
    pub failures: u64,
    pub last_seen_ms_ago: u64,
    /// Its renderer id (see [`WorkerHello::renderer`]).
    #[serde(default)]
    pub renderer: String,
    /// Why it holds no unit while jobs with units left refuse it (they are kept on another
    /// renderer, or their blocklist keeps it off); absent when it is busy or there is no work.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub idle_reason: Option<String>,
    /// Bytes its process held resident when it last returned a result; absent until one
    /// arrives, or from workers that do not report it (not on Linux, or older than the field).
    /// In `tessera render` (coordinator and workers in one process) it is the whole process's.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rss_bytes: Option<u64>,
    /// The most its process has held resident since it started (the kernel's high-water mark),
    /// as of its last result; absent like `rss_bytes`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peak_rss_bytes: Option<u64>,
}
