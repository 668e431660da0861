//! Result uploads, in the background (at most one in flight), and the lease their answers
//! carry: an upload asks for the worker's next unit (`?next=true`) and hands it over through a
//! oneshot channel to the next prefetch (or the loop); a lease nobody waits for any more
//! (shutdown) is given back.
use super::api::{Api, CallError, UploadAnswer};
use super::prepare::Prepared;
use super::retry::{RETRY, Retried, Stop};
use super::{WorkerReport, release};
use std::sync::Arc;
use std::time::{Duration, Instant};
use tessera_proto::Lease;
use tokio::sync::oneshot;
use tokio::task::JoinHandle;
use tracing::{debug, error, info, warn};

/// How long a result upload still in flight at shutdown may take.
const SHUTDOWN_UPLOAD_WAIT: Duration = Duration::from_secs(5);

/// How an upload ended.
pub(super) enum Uploaded {
    /// Merged; `with_lease`: its answer carried the worker's next lease.
    Merged {
        with_lease: bool,
    },
    Stale,
    /// Refused as malformed or for another reason retrying cannot fix (logged as an error).
    Refused,
}

/// The lease an upload's answer carried, once the upload has ended (None: it carried none);
/// Stopped on shutdown, with the lease given back whether it has come or is still to come.
pub(super) async fn from_upload_answer(
    api: &Api,
    mut answer: oneshot::Receiver<Box<Lease>>,
    stop: &Stop,
) -> Retried<Option<Box<Lease>>> {
    tokio::select! {
        biased;
        () = stop.wait() => {
            give_back_carried(api, answer).await;
            Retried::Stopped(None)
        }
        got = &mut answer => Retried::Done(got.ok()),
    }
}

/// Gives back the lease an upload's answer carried, if it has come; one still to come the
/// upload gives back itself (its hand-over fails).
pub(super) async fn give_back_carried(api: &Api, mut answer: oneshot::Receiver<Box<Lease>>) {
    answer.close();
    if let Ok(lease) = answer.try_recv() {
        release(api, &lease.lease_id).await;
    }
}

/// Uploads one unit's sums, retrying transient failures until the lease's deadline passes (by
/// then the coordinator has re-issued the unit, and a late result would be stale anyway). The
/// upload asks for the worker's next lease too, and hands it to `next`; a lease nobody is
/// waiting for any more (shutdown) is given back.
pub(super) async fn upload(
    api: Arc<Api>,
    lease_id: String,
    body: bytes::Bytes,
    prepared: Prepared,
    deadline: Instant,
    next: oneshot::Sender<Box<Lease>>,
) -> Uploaded {
    let id = lease_id.as_str();
    let mut backoff = RETRY;
    let mut failures = 0u32;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let error = match tokio::time::timeout(
            left,
            api.upload(id, body.clone(), prepared, !next.is_closed()),
        )
        .await
        {
            Ok(Ok(UploadAnswer::Merged(lease))) => {
                debug!(lease = id, bytes = body.len(), next = ?lease.as_ref().map(|l| &l.lease_id), "result merged");
                let with_lease = lease.is_some();
                if let Some(lease) = lease
                    && let Err(unwanted) = next.send(lease)
                {
                    release(&api, &unwanted.lease_id).await;
                }
                return Uploaded::Merged { with_lease };
            }
            Ok(Ok(UploadAnswer::Stale)) => {
                info!(lease = id, "result was stale (the coordinator had given the unit up)");
                return Uploaded::Stale;
            }
            Ok(Ok(UploadAnswer::Malformed(detail))) => {
                error!(lease = id, "the coordinator refused the result as malformed: {detail}");
                return Uploaded::Refused;
            }
            Ok(Err(CallError::Fatal(e))) => {
                error!(lease = id, "{e}");
                return Uploaded::Refused;
            }
            Ok(Err(CallError::Transient(e))) => e,
            Err(_) => "no answer".to_owned(),
        };
        failures += 1;
        let now = Instant::now();
        if now >= deadline {
            warn!(
                lease = id,
                attempts = failures,
                "result upload failed ({error}) and the lease's deadline has passed: giving up"
            );
            return Uploaded::Stale;
        }
        let delay = backoff.next_delay().min(deadline - now);
        warn!(lease = id, attempt = failures, retry_in_ms = delay.as_millis() as u64, "{error}");
        tokio::time::sleep(delay).await;
    }
}

/// Waits for an upload and counts its outcome. Once shutdown is requested it gets at most
/// [`SHUTDOWN_UPLOAD_WAIT`] more, then is abandoned.
pub(super) async fn finish_upload(
    mut handle: JoinHandle<Uploaded>,
    stop: &Stop,
    report: &mut WorkerReport,
) {
    let joined = tokio::select! {
        joined = &mut handle => joined,
        () = stop.wait() => match tokio::time::timeout(SHUTDOWN_UPLOAD_WAIT, &mut handle).await {
            Ok(joined) => joined,
            Err(_) => {
                handle.abort();
                warn!("a result upload was still unfinished at shutdown: abandoned");
                report.units_stale += 1;
                return;
            }
        },
    };
    match joined {
        Ok(Uploaded::Merged { with_lease }) => {
            report.units_done += 1;
            report.leases_with_results += u64::from(with_lease);
        }
        Ok(Uploaded::Stale) => report.units_stale += 1,
        Ok(Uploaded::Refused) => {}
        Err(e) => error!("the upload task failed: {e}"),
    }
}
