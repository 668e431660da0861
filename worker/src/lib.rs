//! Tessera's worker: the path tracer and (later) the process that leases units from a coordinator.
//!
//! # Layout
//! - [`tracer`]: the pure renderer. Geometry, BVH, sampling, BSDFs, lights, integrators and the
//!   per-unit partial sums. It does no I/O, spawns no async tasks and knows nothing of the wire
//!   format, so it is deterministic and testable on its own.
//! - [`scene`]: glTF 2.0 → [`tracer::Scene`]. The only place that parses files; it validates
//!   everything it reads and reports errors that name the offending mesh, primitive or material.
//! - [`client`]: the worker process: registers with a coordinator, leases units, renders them on a
//!   dedicated thread pool with heartbeats, and uploads the partial sums (tokio + reqwest).
//! - [`memory`]: the process's resident memory (now and peak), which the worker reports with
//!   each result.
//! - [`renderer_id`]: the name a worker gives its renderer (source hash and libm probe), so a
//!   coordinator keeps each job on workers that compute the same bits.
//!
//! # Invariants
//! - Every random number is a pure function of (seed, pixel, sample index, dimension), see
//!   [`tracer::sampler`]. A unit rendered twice, on any machine or thread count, gives the same bits.
//! - A unit returns partial sums (f64), never averages, so merging units is exact addition.
// `!(x > 0.0)` is deliberate throughout the tracer: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]
pub mod client;
pub mod memory;
mod renderer_id;
pub mod scene;
pub mod tracer;

pub use renderer_id::renderer_id;
