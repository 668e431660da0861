//! The path tracer: pure functions from a [`Scene`] and a unit of work to partial sums.
//!
//! One file per family, as in pbrt-v4: closed sets of types are enums dispatched by one `match`
//! ([`bsdf::Bsdf`], [`light::Light`]). The tracer never touches files, sockets or clocks.
pub mod accel;
pub mod bsdf;
pub mod camera;
pub mod effects;
pub mod film;
pub mod integrator;
pub mod kernel;
pub mod light;
pub mod material;
pub mod mesh;
pub mod normal_map;
pub mod ray;
#[cfg(feature = "bench")]
pub mod ray_log;
pub mod render;
pub mod roulette;
pub mod rows;
pub mod sampler;
pub mod sampling;
pub mod scene;
mod surface;
pub mod texture;

#[cfg(test)]
mod chi2;
#[cfg(test)]
mod numerics;

pub use effects::Effects;
pub use film::{PixelSums, Tile, TileSums};
pub use integrator::{Estimator, PathSettings, Roulette};
pub use kernel::KernelBits;
pub use light::LightSampler;
pub use render::{RenderError, RenderOptions, RenderSettings, render_tile};
pub use rows::RowQueue;
pub use scene::Scene;
