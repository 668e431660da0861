//! `GET /v1/jobs/{id}/events`: Server-Sent Events, one `progress` event per change, then `end`.
use super::jobs::status_of;
use crate::error::AppError;
use crate::state::AppState;
use axum::extract::{Path, State};
use axum::response::sse::{Event, KeepAlive, Sse};
use futures_util::Stream;
use std::convert::Infallible;
use std::time::Duration;
use tokio::time::Instant;

/// Least time between two progress events of a running job.
pub(crate) const COALESCE: Duration = Duration::from_millis(100);

/// Progress events (`event: progress`, data: the job JSON), ending with `event: end`.
#[utoipa::path(get, path = "/v1/jobs/{id}/events", tag = "jobs", params(("id" = String, Path)),
    responses((status = 200, content_type = "text/event-stream"), (status = 404, body = tessera_proto::Problem)))]
pub async fn events(
    State(st): State<AppState>,
    Path(id): Path<String>,
) -> Result<Sse<impl Stream<Item = Result<Event, Infallible>>>, AppError> {
    let first = status_of(&st, &id)?;
    let mut rx = st.events.subscribe();
    let stream = async_stream(move |tx| async move {
        let mut last = first;
        let _ = tx.send(event(&last)).await;
        let mut sent_at = Instant::now();
        while !last.state.is_final() {
            // Wake on a change to this job, or every second to refresh elapsed time and ETA.
            let _ = tokio::time::timeout(Duration::from_secs(1), changed(&mut rx, &id)).await;
            // Coalesce bursts of merges into at most ~10 events a second; the end goes out at once.
            // Between events only the job's state is looked at: a status is built to be sent.
            let due = sent_at + COALESCE;
            while Instant::now() < due && !ended(&st, &id) {
                let _ = tokio::time::timeout_at(due, changed(&mut rx, &id)).await;
            }
            let Ok(now) = status_of(&st, &id) else { return };
            last = now;
            if tx.send(event(&last)).await.is_err() {
                return;
            }
            sent_at = Instant::now();
        }
        let _ = tx.send(Ok(Event::default().event("end").data(last.id.clone()))).await;
    });
    Ok(Sse::new(stream).keep_alive(KeepAlive::default()))
}

/// Whether job `id` has ended (or is gone).
fn ended(st: &AppState, id: &str) -> bool {
    st.scheduler.lock().expect("lock").job(id).is_none_or(|j| j.state().is_final())
}

/// Returns when job `id` changes (or the channel lagged or closed, so a change may be missed).
async fn changed(rx: &mut tokio::sync::broadcast::Receiver<String>, id: &str) {
    loop {
        match rx.recv().await {
            Ok(changed) if changed == id => return,
            Ok(_) => continue,
            Err(_) => return,
        }
    }
}

fn event(job: &tessera_proto::Job) -> Result<Event, Infallible> {
    Ok(Event::default().event("progress").data(serde_json::to_string(job).expect("job serializes")))
}

/// A stream fed by a task through a small channel.
fn async_stream<F, Fut>(f: F) -> impl Stream<Item = Result<Event, Infallible>>
where
    F: FnOnce(tokio::sync::mpsc::Sender<Result<Event, Infallible>>) -> Fut,
    Fut: std::future::Future<Output = ()> + Send + 'static,
{
    let (tx, rx) = tokio::sync::mpsc::channel(16);
    tokio::spawn(f(tx));
    tokio_stream::wrappers::ReceiverStream::new(rx)
}
