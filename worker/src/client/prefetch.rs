//! Lease prefetch: the next lease is requested while a unit renders, and its unit queued on the
//! pool behind the one rendering, so the pool goes straight from one unit to the next instead
//! of idling for a lease round trip and a hand-over in between.
//!
//! A [`Prefetch`] is a background task that takes the lease the previous unit's result answer
//! carried or, without one, asks for one lease (polling again after 204 while the unit in hand
//! renders), prepares its scene and queues its unit (`Worker::queue_unit`),
//! then holds the lease under heartbeats until the loop takes it. A held lease that is lost (409
//! on heartbeat, deadline passed) is dropped, its unit canceled, and another one asked for. On
//! shutdown a held lease is given back (`DELETE`) and its unit canceled. There is never more than
//! one: the loop starts the next prefetch only after taking this one.
use super::api::LeaseAnswer;
use super::queue::Queued;
use super::retry::{Retried, Stop, until_done};
use super::{IDLE, LEASE_DRAIN, Worker, from_upload_answer, keep_alive, release};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tessera_proto::Lease;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;
use tracing::{debug, info};

/// What the task ends with: the answer for the loop (None: nothing fetched, ask as usual) with
/// the lease's unit if it could be queued, and how many held leases it dropped or gave back on
/// the way.
struct Fetched {
    answer: Option<(Retried<LeaseAnswer>, Option<Queued>)>,
    dropped: u64,
}

/// The next lease, being fetched or held in the background.
pub(super) struct Prefetch {
    take: oneshot::Sender<()>,
    task: JoinHandle<Fetched>,
}

impl Prefetch {
    /// Starts fetching a lease for `worker_id`; a held lease is heartbeated every `every`.
    /// Its unit's scene is prepared only once `after` resolves (or its sender is dropped). With
    /// `from_upload`, the lease the previous unit's result answer carries is taken first, and
    /// only without one is a lease requested.
    pub(super) fn start(
        worker: Arc<Worker>,
        worker_id: String,
        every: Duration,
        stop: Stop,
        after: oneshot::Receiver<()>,
        from_upload: Option<oneshot::Receiver<Box<Lease>>>,
    ) -> Prefetch {
        let (take, taken) = oneshot::channel();
        let task = tokio::spawn(fetch(worker, worker_id, every, stop, taken, after, from_upload));
        Prefetch { take, task }
    }

    /// Ends the prefetch and returns what it got, as the loop's own lease request would: the
    /// held lease (its `deadline_ms` counted from now) with its queued unit (None if it could
    /// not be queued: the loop tries again and reports why), the answer of a request still in
    /// flight (waited for), or None when there is nothing (the loop then asks itself).
    /// `dropped` counts held leases lost or given back meanwhile.
    pub(super) async fn take(
        self,
        dropped: &mut u64,
    ) -> Option<(Retried<LeaseAnswer>, Option<Queued>)> {
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

async fn fetch(
    worker: Arc<Worker>,
    worker_id: String,
    every: Duration,
    stop: Stop,
    mut taken: oneshot::Receiver<()>,
    after: oneshot::Receiver<()>,
    from_upload: Option<oneshot::Receiver<Box<Lease>>>,
) -> Fetched {
    let mut after = Some(after);
    let mut idle = IDLE;
    let mut dropped = 0;
    let api = &worker.api;
    let mut carried = match from_upload {
        Some(answer) => match from_upload_answer(api, answer, &stop).await {
            Retried::Done(lease) => lease,
            _ => return Fetched { answer: Some((Retried::Stopped(None), None)), dropped },
        },
        None => None,
    };
    loop {
        let answer = match carried.take() {
            Some(lease) => Retried::Done(LeaseAnswer::Lease(lease)),
            None => {
                until_done("lease request (prefetch)", &stop, LEASE_DRAIN, || api.lease(&worker_id))
                    .await
            }
        };
        let lease = match answer {
            Retried::Done(LeaseAnswer::Lease(lease)) => lease,
            Retried::Done(LeaseAnswer::NoWork) => {
                // Poll again while the unit in hand renders; once taken, the loop polls itself.
                tokio::select! {
                    () = tokio::time::sleep(idle.next_delay()) => continue,
                    _ = &mut taken => return Fetched { answer: None, dropped },
                    () = stop.wait() => return Fetched { answer: Some((Retried::Stopped(None), None)), dropped },
                }
            }
            Retried::Stopped(Some(LeaseAnswer::Lease(late))) => {
                release(api, &late.lease_id).await;
                return Fetched {
                    answer: Some((Retried::Stopped(None), None)),
                    dropped: dropped + 1,
                };
            }
            other => return Fetched { answer: Some((other, None)), dropped },
        };
        idle.reset();
        match hold(&worker, lease, every, &stop, &mut taken, &mut after).await {
            Held::Taken(lease, queued) => {
                return Fetched {
                    answer: Some((Retried::Done(LeaseAnswer::Lease(lease)), queued)),
                    dropped,
                };
            }
            Held::Lost => dropped += 1,
            Held::GivenBack => {
                return Fetched {
                    answer: Some((Retried::Stopped(None), None)),
                    dropped: dropped + 1,
                };
            }
        }
    }
}

enum Held {
    /// Taken by the loop; `deadline_ms` now counts from the moment it was taken. With its unit
    /// queued on the pool, unless that failed.
    Taken(Box<Lease>, Option<Queued>),
    /// Lost while waiting: dropped (its unit canceled).
    Lost,
    /// Shutdown: given back (its unit canceled).
    GivenBack,
}

/// Queues the prefetched lease's unit once `after` resolves, then keeps the lease alive until the loop takes it, it is
/// lost, or shutdown comes. The loop taking it while the unit is still being queued (its scene
/// building) waits for that to end, so a scene is never prepared twice.
async fn hold(
    worker: &Worker,
    mut lease: Box<Lease>,
    every: Duration,
    stop: &Stop,
    taken: &mut oneshot::Receiver<()>,
    after: &mut Option<oneshot::Receiver<()>>,
) -> Held {
    let id = lease.lease_id.clone();
    debug!(lease = %id, job = %lease.job_id, tile = ?lease.tile, samples = ?lease.samples, "prefetched a unit");
    let deadline = Mutex::new(Instant::now() + Duration::from_millis(lease.deadline_ms));
    let queued = {
        let keep_alive = keep_alive(&worker.api, &id, every, &deadline);
        let queueing = async {
            if let Some(ready) = after.as_mut() {
                let _ = ready.await;
                *after = None;
            }
            worker.queue_unit(&lease).await
        };
        tokio::pin!(keep_alive, queueing);
        let (mut queued, mut wanted) = (None, false);
        loop {
            tokio::select! {
                q = &mut queueing, if queued.is_none() => {
                    // A unit that cannot be queued is left to the loop, which says why and gives it back.
                    queued = Some(q.map_err(|e| debug!(lease = %id, "prefetched unit not queued: {e}")).ok());
                }
                _ = &mut *taken, if !wanted => wanted = true,
                why = &mut keep_alive => {
                    info!(lease = %id, job = %lease.job_id, "prefetched lease lost while waiting: {why}; dropped");
                    return Held::Lost;
                }
                () = stop.wait() => {
                    debug!(lease = %id, "shutdown: giving the prefetched lease back");
                    release(&worker.api, &id).await;
                    return Held::GivenBack;
                }
            }
            if wanted && let Some(queued) = queued.take() {
                break queued;
            }
        }
    };
    let left = deadline.lock().expect("deadline lock").saturating_duration_since(Instant::now());
    lease.deadline_ms = u64::try_from(left.as_millis()).unwrap_or(u64::MAX);
    Held::Taken(lease, queued)
}
