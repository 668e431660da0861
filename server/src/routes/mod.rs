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
#[cfg(test)]
mod tests_auth;
#[cfg(test)]
mod tests_bad_input;
#[cfg(test)]
mod tests_bad_input_cases;
#[cfg(test)]
mod tests_durability;
#[cfg(test)]
mod tests_ended;
#[cfg(test)]
mod tests_dashboard;
#[cfg(test)]
mod tests_frames;
#[cfg(test)]
mod tests_frame_release;
#[cfg(test)]
mod tests_images;
#[cfg(test)]
mod tests_jobs;
#[cfg(test)]
mod tests_numerics;
#[cfg(test)]
mod tests_scenes;
#[cfg(test)]
mod tests_service;
#[cfg(test)]
mod tests_workers;
#[cfg(test)]
mod tests_carried;
