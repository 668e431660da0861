//! Tessera's coordinator side and the `tessera` command.
//!
//! # Layout
//! - [`bundled`]: the scenes shipped in `scenes/`, compiled into the binary and available by name.
//! - [`output`]: OpenEXR and PNG encoding of merged partial sums.
//! - [`image`]: partial sums → image layers (mean, variance of the mean, sample counts).
//! - [`local`]: rendering a job on this machine with the tracer directly.
pub mod bundled;
pub mod image;
pub mod local;
pub mod output;
pub mod scheduler;
