//! HTTP handlers grouped by resource, assembled into the coordinator's router.
pub mod events;
pub mod health;
pub mod images;
pub mod jobs;
pub mod leases;
pub mod scenes;
pub mod validate;

#[cfg(test)]
mod tests;
