//! Tessera's renderer: the path tracer and the glTF loading that feeds it.
//!
//! This crate is pure by construction: it depends on no async runtime, no HTTP and no wire
//! format, and it reads no file it is not handed as bytes. The worker process
//! (`tessera-worker`) and the coordinator (`tessera-server`) wrap it.
//!
//! # Layout
//! - [`tracer`]: the renderer. Geometry, BVH, sampling, BSDFs, lights, integrators and the
//!   per-unit partial sums. It does no I/O and spawns no tasks, so it is deterministic and
//!   testable on its own.
//! - [`scene`]: glTF 2.0 → [`tracer::Scene`]. It validates everything it reads and reports
//!   errors that name the offending mesh, primitive or material.
//! - [`renderer_id`]: the name a worker gives its renderer (source hash and libm probe), so a
//!   coordinator keeps each job on workers that compute the same bits.
//!
//! # Invariants
//! - Every random number is a pure function of (seed, pixel, sample index, dimension), see
//!   [`tracer::sampler`]. A unit rendered twice, on any machine or thread count, gives the same bits.
//! - A unit returns partial sums (f64), never averages, so merging units is exact addition.
// `!(x > 0.0)` is deliberate throughout the tracer: it is also true for NaN.
#![allow(clippy::neg_cmp_op_on_partial_ord, clippy::needless_range_loop)]
mod renderer_id;
pub mod scene;
pub mod tracer;

pub use renderer_id::renderer_id;
