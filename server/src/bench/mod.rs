//! Benchmark studies whose code is shared by `tessera-bench`, `tessera bench` and the tests that
//! keep them working. Figures are printed and written as documents; nothing here asserts speed.
pub mod accuracy;
pub mod bvh;
pub mod cpu;
pub mod frames;
pub mod mitsuba;
pub mod overhead;
pub mod same_rays;
pub mod stock;
