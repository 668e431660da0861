//! End-to-end tests: one binary, one module per capability.
mod accuracy;
mod cluster;
mod browser;
mod dashboard;
mod compose;
mod compose_farm;
mod estimators;
mod farm;
mod faults;
mod frames;
mod harness;
mod mitsuba;
mod render_cli;
