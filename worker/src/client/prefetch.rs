//! Lease prefetch: the next lease is requested while a unit renders, so the pool goes straight
//! from one unit to the next instead of idling for a lease round trip in between.
//!
//! A [`Prefetch`] is a background task that asks for one lease (polling again after 204 while
//! the unit in hand renders), then holds it under heartbeats until the loop takes it. A held lease
//! that is lost (409 on heartbeat, deadline passed) is dropped and another one asked for. On
//! shutdown a held lease is given back (`DELETE`). There is never more than one: the loop
//! starts the next prefetch only after taking this one.
use super::api::{Api, LeaseAnswer};
use super::retry::{Retried, Stop, until_done};
use super::{IDLE, LEASE_DRAIN, keep_alive, release};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tessera_proto::Lease;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;
use tracing::{debug, info};

/// What the task ends with: the answer for the loop (None: nothing fetched, ask as usual) and
/// how many held leases it dropped or gave back on the way.
struct Fetched {
    answer: Option<Retried<LeaseAnswer>>,
    dropped: u64,
}

/// The next lease, being fetched or held in the background.
pub(super) struct Prefetch {
    take: oneshot::Sender<()>,
    task: JoinHandle<Fetched>,
}

impl Prefetch {
    /// Starts fetching a lease for `worker_id`; a held lease is heartbeated every `every`.
    pub(super) fn start(api: Arc<Api>, worker_id: String, every: Duration, stop: Stop) -> Prefetch {
        let (take, taken) = oneshot::channel();
        let task = tokio::spawn(fetch(api, worker_id, every, stop, taken));
        Prefetch { take, task }
    }

    /// Ends the prefetch and returns what it got, as the loop's own lease request would: the
    /// held lease (its `deadline_ms` counted from now), the answer of a request still in flight
    /// (waited for), or None when there is nothing (the loop then asks itself). `dropped` counts
    /// held leases lost or given back meanwhile.
    pub(super) async fn take(self, dropped: &mut u64) -> Option<Retried<LeaseAnswer>> {
        let _ = self.take.send(());
        match self.task.await {
            Ok(f) => {
                *dropped += f.dropped;
                f.answer
            }
            Err(e) => {
                tracing::error!("the lease prefetch task failed: {e}");
                None
            }
        }
    }
}

async fn fetch(api: Arc<Api>, worker_id: String, every: Duration, stop: Stop, mut taken: oneshot::Receiver<()>) -> Fetched {
    let mut idle = IDLE;
    let mut dropped = 0;
    loop {
        let answer = until_done("lease request (prefetch)", &stop, LEASE_DRAIN, || api.lease(&worker_id)).await;
        let lease = match answer {
            Retried::Done(LeaseAnswer::Lease(lease)) => lease,
            Retried::Done(LeaseAnswer::NoWork) => {
                // Poll again while the unit in hand renders; once taken, the loop polls itself.
                tokio::select! {
                    () = tokio::time::sleep(idle.next_delay()) => continue,
                    _ = &mut taken => return Fetched { answer: None, dropped },
                    () = stop.wait() => return Fetched { answer: Some(Retried::Stopped(None)), dropped },
                }
            }
            Retried::Stopped(Some(LeaseAnswer::Lease(late))) => {
                release(&api, &late.lease_id).await;
                return Fetched { answer: Some(Retried::Stopped(None)), dropped: dropped + 1 };
            }
            other => return Fetched { answer: Some(other), dropped },
        };
        idle.reset();
        match hold(&api, lease, every, &stop, &mut taken).await {
            Held::Taken(lease) => return Fetched { answer: Some(Retried::Done(LeaseAnswer::Lease(lease))), dropped },
            Held::Lost => dropped += 1,
            Held::GivenBack => return Fetched { answer: Some(Retried::Stopped(None)), dropped: dropped + 1 },
        }
    }
}

enum Held {
    /// Taken by the loop; `deadline_ms` now counts from the moment it was taken.
    Taken(Box<Lease>),
    /// Lost while waiting: dropped.
    Lost,
    /// Shutdown: given back.
    GivenBack,
}

/// Keeps a prefetched lease alive until the loop takes it, it is lost, or shutdown comes.
async fn hold(api: &Api, mut lease: Box<Lease>, every: Duration, stop: &Stop, taken: &mut oneshot::Receiver<()>) -> Held {
    let id = lease.lease_id.clone();
    debug!(lease = %id, job = %lease.job_id, tile = ?lease.tile, samples = ?lease.samples, "prefetched a unit");
    let deadline = Mutex::new(Instant::now() + Duration::from_millis(lease.deadline_ms));
    tokio::select! {
        _ = taken => {
            let left = deadline.lock().expect("deadline lock").saturating_duration_since(Instant::now());
            lease.deadline_ms = u64::try_from(left.as_millis()).unwrap_or(u64::MAX);
            Held::Taken(lease)
        }
        why = keep_alive(api, &id, every, &deadline) => {
            info!(lease = %id, job = %lease.job_id, "prefetched lease lost while waiting: {why}; dropped");
            Held::Lost
        }
        () = stop.wait() => {
            debug!(lease = %id, "shutdown: giving the prefetched lease back");
            release(api, &id).await;
            Held::GivenBack
        }
    }
}
