//! What every lease held needs, in hand or prefetched: heartbeats that keep it alive, and
//! giving it back.
use super::api::{Api, CallError, HeartbeatAnswer};
use super::retry::RETRY;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use tessera_proto::Registration;
use tracing::{debug, warn};

/// Attempts to give a lease back before leaving it to expire.
const RELEASE_ATTEMPTS: u32 = 3;

/// Heartbeats the lease every `every` and returns once it is lost, saying why. Transient
/// failures are retried at the same pace until the lease's deadline passes.
pub(super) async fn keep_alive(
    api: &Api,
    id: &str,
    every: Duration,
    deadline: &Mutex<Instant>,
) -> String {
    let expired = || "its deadline passed without a successful heartbeat".to_owned();
    loop {
        // Normally `every`; sooner if the lease was granted with a shorter deadline.
        let due = *deadline.lock().expect("deadline lock");
        let pause = every
            .min(due.saturating_duration_since(Instant::now()) / 2)
            .max(Duration::from_millis(10));
        tokio::time::sleep(pause).await;
        let due = *deadline.lock().expect("deadline lock");
        let Some(left) = due.checked_duration_since(Instant::now()).filter(|d| !d.is_zero()) else {
            return expired();
        };
        match tokio::time::timeout(left, api.heartbeat(id)).await {
            Ok(Ok(HeartbeatAnswer::Extended(d))) => {
                *deadline.lock().expect("deadline lock") = Instant::now() + d
            }
            Ok(Ok(HeartbeatAnswer::Gone)) => {
                return "the coordinator has dropped it (expired or job canceled)".to_owned();
            }
            Ok(Err(e)) => warn!(lease = id, "heartbeat failed (will retry): {e}"),
            Err(_) => return expired(),
        }
    }
}

/// Gives a lease back (a few attempts; if they all fail the lease simply expires).
pub(super) async fn release(api: &Api, id: &str) {
    let mut backoff = RETRY;
    for attempt in 1..=RELEASE_ATTEMPTS {
        match api.release(id).await {
            Ok(()) => {
                debug!(lease = id, "lease given back");
                return;
            }
            Err(CallError::Transient(e)) if attempt < RELEASE_ATTEMPTS => {
                warn!(lease = id, attempt, "{e}");
                tokio::time::sleep(backoff.next_delay()).await;
            }
            Err(e) => {
                warn!(lease = id, "cannot give the lease back ({e}); it will expire");
                return;
            }
        }
    }
}

/// A third of the coordinator's heartbeat period, and at least every second.
pub(super) fn heartbeat_every(reg: &Registration) -> Duration {
    Duration::from_millis((reg.heartbeat_ms / 3).clamp(10, 1000))
}
