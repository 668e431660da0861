//! Tessera's worker process: leases units from a coordinator and renders them with
//! [`tessera_render`].
//!
//! # Layout
//! - [`client`]: registers with a coordinator, leases units, renders them on a dedicated thread
//!   pool with heartbeats, and uploads the partial sums (tokio + reqwest).
//! - [`memory`]: the process's resident memory (now and peak), which the worker reports with
//!   each result.
pub mod client;
pub mod memory;
