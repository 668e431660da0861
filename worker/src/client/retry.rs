//! Waiting: exponential backoff with jitter, the shutdown signal, and retry-until-done.
use super::api::CallError;
use std::future::Future;
use std::hash::{BuildHasher, Hasher};
use std::time::Duration;
use tokio::sync::watch;

/// Exponential backoff: `first`, doubling up to `cap`; each delay is jittered to [½, 1]× so
/// that many workers retrying against a restarted coordinator spread out.
#[derive(Clone, Debug)]
pub(crate) struct Backoff {
    first: Duration,
    cap: Duration,
    next: Duration,
}

impl Backoff {
    pub(crate) const fn new(first: Duration, cap: Duration) -> Backoff {
        Backoff { first, cap, next: first }
    }

    pub(crate) fn next_delay(&mut self) -> Duration {
        let d = self.next;
        self.next = (self.next * 2).min(self.cap);
        d.mul_f64(0.5 + 0.5 * unit_random())
    }

    pub(crate) fn reset(&mut self) {
        self.next = self.first;
    }
}

/// A number in [0, 1) that differs from call to call (each `RandomState` has fresh keys);
/// good enough for jitter, and no extra dependency.
fn unit_random() -> f64 {
    let bits = std::collections::hash_map::RandomState::new().build_hasher().finish();
    (bits >> 11) as f64 / (1u64 << 53) as f64
}

/// The shutdown request, as a cheap clonable handle.
#[derive(Clone, Debug)]
pub(crate) struct Stop(watch::Receiver<bool>);

impl Stop {
    pub(crate) fn new() -> (watch::Sender<bool>, Stop) {
        let (tx, rx) = watch::channel(false);
        (tx, Stop(rx))
    }

    pub(crate) fn is_set(&self) -> bool {
        *self.0.borrow()
    }

    /// Resolves once shutdown is requested (at once if it already was).
    pub(crate) async fn wait(&self) {
        let mut rx = self.0.clone();
        // An error means the sender is gone, which only happens when `run` itself ends.
        let _ = rx.wait_for(|stop| *stop).await;
    }

    /// Sleeps for `d`; false if shutdown came first.
    pub(crate) async fn sleep(&self, d: Duration) -> bool {
        tokio::select! {
            _ = tokio::time::sleep(d) => true,
            _ = self.wait() => false,
        }
    }
}

pub(crate) enum Retried<T> {
    Done(T),
    /// A failure retrying cannot fix (a 4xx other than those the protocol defines).
    Fatal(String),
    /// Shutdown was requested. Holds the answer of a call that was in flight then and still
    /// finished within the drain time (so that, e.g., a lease granted meanwhile can be returned).
    Stopped(Option<T>),
}

/// Connection errors and 5xx: from 100 ms, doubling up to 5 s.
pub(crate) const RETRY: Backoff = Backoff::new(Duration::from_millis(100), Duration::from_secs(5));

/// Calls `call` until it succeeds or fails for good, backing off after transient failures,
/// with no limit on attempts; gives up only on shutdown. A call in flight when shutdown comes
/// gets `drain` more time to finish.
pub(crate) async fn until_done<T, F, Fut>(
    what: &str,
    stop: &Stop,
    drain: Duration,
    mut call: F,
) -> Retried<T>
where
    F: FnMut() -> Fut,
    Fut: Future<Output = Result<T, CallError>>,
{
    let mut backoff = RETRY;
    let mut failures = 0u32;
    loop {
        if stop.is_set() {
            return Retried::Stopped(None);
        }
        let attempt = call();
        tokio::pin!(attempt);
        let result = tokio::select! {
            r = &mut attempt => r,
            _ = stop.wait() => {
                let late = tokio::time::timeout(drain, attempt).await;
                return Retried::Stopped(late.ok().and_then(Result::ok));
            }
        };
        match result {
            Ok(v) => {
                if failures > 0 {
                    tracing::info!("{what}: succeeded after {failures} failed attempts");
                }
                return Retried::Done(v);
            }
            Err(CallError::Fatal(e)) => return Retried::Fatal(e),
            Err(CallError::Transient(e)) => {
                failures += 1;
                let delay = backoff.next_delay();
                tracing::warn!(
                    attempt = failures,
                    retry_in_ms = delay.as_millis() as u64,
                    "{what} failed: {e}"
                );
                if !stop.sleep(delay).await {
                    return Retried::Stopped(None);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn backoff_doubles_to_its_cap_with_jitter_and_resets() {
        let mut b = Backoff::new(Duration::from_millis(100), Duration::from_secs(5));
        let nominal = [100, 200, 400, 800, 1600, 3200, 5000, 5000];
        for n in nominal {
            let d = b.next_delay().as_secs_f64() * 1000.0;
            assert!(d >= n as f64 * 0.5 - 1e-6 && d <= n as f64 + 1e-6, "{d} ms for nominal {n}");
        }
        b.reset();
        assert!(b.next_delay() <= Duration::from_millis(100));
    }
}
