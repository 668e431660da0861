//! End-to-end tests: one binary, one module per capability.
mod browser;
mod dashboard;
mod estimators;
mod farm;
mod harness;
mod mitsuba;
mod render_cli;
