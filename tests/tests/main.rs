//! End-to-end tests: one binary, one module per capability.
mod compose;
mod compose_farm;
mod estimators;
mod farm;
mod harness;
mod mitsuba;
mod render_cli;
