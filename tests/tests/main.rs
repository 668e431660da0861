//! End-to-end tests: one binary, one module per capability.
mod accuracy;
mod browser;
mod cluster;
mod compose;
mod compose_farm;
mod dashboard;
mod estimators;
mod farm;
mod faults;
mod frames;
mod harness;
mod mitsuba;
mod render_cli;
