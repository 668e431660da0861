//! Tessera's coordinator side and the `tessera` command.
//!
//! # Layout
//! - [`bundled`]: the scenes shipped in `scenes/`, compiled into the binary and available by name.
//! - [`output`]: OpenEXR and PNG encoding of merged partial sums.
//! - [`image`]: partial sums → image layers (mean, variance of the mean, sample counts).
//! - [`local`]: a coordinator and a worker in one process (`tessera render`, benchmarks).
//! - [`client`]: a small client of the coordinator's API.
//! - [`scheduler`]: the clock-free state machine of jobs, units, leases and workers.
//! - [`store`], [`persist`]: durable job state (redb + checkpoint files) and resuming from it.
//! - `ended`: what becomes of a job's pixels when its frames or the job end (images written,
//!   sums dropped), and deleting jobs on request or by age.
//! - [`scratch`]: temporary directories of commands that run their own coordinator, removed
//!   on drop and before a benchmark exits early.
//! - [`purge`]: how soon the allocator gives freed memory back, for processes that build scenes.
//! - [`dashboard`]: the web dashboard at `/` (static files compiled in).
//! - [`app`], [`routes`], [`state`], [`status`], [`error`], [`scenes`]: the axum coordinator —
//!   `app(state) -> Router`, handlers grouped by resource, problem+json errors, the scene store.
pub mod app;
pub mod auth;
pub mod bundled;
pub mod client;
pub mod dashboard;
mod ended;
pub mod error;
pub mod image;
pub mod local;
pub mod output;
pub mod persist;
pub mod purge;
pub mod routes;
pub mod scenes;
pub mod scheduler;
pub mod scratch;
pub mod state;
pub mod status;
pub mod store;
