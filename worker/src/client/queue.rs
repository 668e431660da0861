//! Units queued on the render pool: each unit is a [`RowQueue`] worked by one job per pool
//! thread, so a unit queued while another renders starts on each thread the moment that thread
//! runs out of rows of the one before (no idle pool between units, no waiting for stragglers).
//!
//! The result comes back through a oneshot channel, sent by the job that finished the last row;
//! a panic in a row becomes an error (sent by the job that caught it) instead of taking the
//! process down. Dropping a [`Queued`] cancels its unit, so a lease given up before its unit
//! started costs the pool (almost) nothing.
use super::prepare::Prepared;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;
use tessera_render::tracer::{RowQueue, TileSums};
use tokio::sync::oneshot;

/// What a queued unit answers: its sums, None when canceled, or why it failed.
pub(super) type Rendered = Result<Option<TileSums>, String>;

/// A unit on the pool (queued or rendering).
pub(super) struct Queued {
    /// How the unit's scene was prepared (sent with the result).
    pub prepared: Prepared,
    /// Resolves once the unit is complete, canceled or failed.
    pub result: oneshot::Receiver<Rendered>,
    unit: Arc<dyn Rows>,
}

impl Queued {
    /// Ends the unit's remaining rows at once; its result is then None.
    pub fn cancel(&self) {
        self.unit.cancel();
    }
}

impl Drop for Queued {
    fn drop(&mut self) {
        // Harmless once the unit is complete: its result is already sent.
        self.cancel();
    }
}

/// What the pool's jobs need of a unit: a [`RowQueue`] (tests use stand-ins).
pub(super) trait Rows: Send + Sync + 'static {
    /// Works until nothing is left to claim; true on the call that completed the unit.
    fn work(&self) -> bool;
    /// The sums once complete; None if canceled.
    fn take(&self) -> Option<TileSums>;
    /// Ends the remaining rows at once; `take` then answers None.
    fn cancel(&self);
}

impl Rows for RowQueue {
    fn work(&self) -> bool {
        RowQueue::work(self)
    }
    fn take(&self) -> Option<TileSums> {
        RowQueue::take(self)
    }
    fn cancel(&self) {
        RowQueue::cancel(self);
    }
}

/// Queues `unit` behind whatever the pool is doing. `busy_ns` gains the time each pool
/// thread spent on the unit's rows, divided by the pool's thread count (so it stays within
/// wall time however units overlap).
pub(super) fn queue(
    pool: &rayon::ThreadPool,
    unit: impl Rows,
    prepared: Prepared,
    busy_ns: Arc<AtomicU64>,
) -> Queued {
    let (tx, result) = oneshot::channel();
    let threads = pool.current_num_threads().max(1);
    let (unit, tx) = (Arc::new(unit), Arc::new(Mutex::new(Some(tx))));
    for _ in 0..threads {
        let (unit, tx, busy_ns) = (unit.clone(), tx.clone(), busy_ns.clone());
        pool.spawn(move || {
            let started = Instant::now();
            let worked = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| unit.work()));
            let ns =
                u64::try_from(started.elapsed().as_nanos() / threads as u128).unwrap_or(u64::MAX);
            busy_ns.fetch_add(ns, Ordering::Relaxed);
            let answer = match worked {
                Ok(false) => return,
                Ok(true) => Ok(unit.take()),
                Err(panic) => {
                    unit.cancel();
                    Err(panic_message(panic.as_ref()))
                }
            };
            // The first answer wins: a panic in one row ends the unit for all.
            if let Some(tx) = tx.lock().unwrap_or_else(std::sync::PoisonError::into_inner).take() {
                let _ = tx.send(answer);
            }
        });
    }
    Queued { prepared, result, unit }
}

fn panic_message(panic: &(dyn std::any::Any + Send)) -> String {
    match (panic.downcast_ref::<&str>(), panic.downcast_ref::<String>()) {
        (Some(m), _) => format!("it panicked: {m}"),
        (_, Some(m)) => format!("it panicked: {m}"),
        _ => "it panicked".to_owned(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::prepare::How;
    use super::*;
    use std::sync::atomic::{AtomicBool, AtomicU32};
    use std::time::Duration;
    use tessera_render::tracer::Tile;

    const CACHED: Prepared = Prepared { how: How::Cached, ms: 0.0 };

    /// `rows` rows of `ms` each; remembers which pool threads worked on it.
    struct StandIn {
        rows: u32,
        next: AtomicU32,
        left: AtomicU32,
        ms: u64,
        panic_on: Option<u32>,
        threads: Mutex<Vec<usize>>,
        canceled: AtomicBool,
    }

    impl StandIn {
        fn new(rows: u32, ms: u64, panic_on: Option<u32>) -> Arc<StandIn> {
            Arc::new(StandIn {
                rows,
                next: AtomicU32::new(0),
                left: AtomicU32::new(rows),
                ms,
                panic_on,
                threads: Mutex::default(),
                canceled: AtomicBool::new(false),
            })
        }
    }

    impl Rows for Arc<StandIn> {
        fn work(&self) -> bool {
            self.threads.lock().unwrap().extend(rayon::current_thread_index());
            let mut last = false;
            loop {
                let row = self.next.fetch_add(1, Ordering::Relaxed);
                if row >= self.rows {
                    return last;
                }
                std::thread::sleep(Duration::from_millis(self.ms));
                assert!(self.panic_on != Some(row), "a broken row");
                last = self.left.fetch_sub(1, Ordering::AcqRel) == 1;
            }
        }
        fn take(&self) -> Option<TileSums> {
            Some(TileSums::new(Tile { x0: 0, y0: 0, w: 1, h: 1 }))
        }
        fn cancel(&self) {
            self.canceled.store(true, Ordering::Relaxed);
        }
    }

    #[tokio::test]
    async fn every_pool_thread_works_on_a_unit_and_one_sends_its_sums() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let busy = Arc::new(AtomicU64::new(0));
        let unit = StandIn::new(10, 30, None);
        let mut queued = queue(&pool, unit.clone(), CACHED, busy.clone());
        let answer = (&mut queued.result).await.unwrap();
        assert_eq!(answer.unwrap().map(|s| s.pixels.len()), Some(1));
        let mut threads = unit.threads.lock().unwrap().clone();
        threads.sort();
        assert_eq!(threads, [0, 1], "both pool threads took a share");
        // 10 rows of 30 ms on 2 threads: at least 150 ms of each thread's time, on average.
        let busy = Duration::from_nanos(busy.load(Ordering::Relaxed));
        assert!(busy >= Duration::from_millis(150), "{busy:?}");
    }

    #[tokio::test]
    async fn a_panic_becomes_the_units_error_and_the_pool_goes_on() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let unit = StandIn::new(4, 1, Some(1));
        let mut failed = queue(&pool, unit.clone(), CACHED, Arc::default());
        assert_eq!(
            (&mut failed.result).await.unwrap(),
            Err("it panicked: a broken row".to_owned())
        );
        assert!(unit.canceled.load(Ordering::Relaxed), "the unit's other rows are canceled");
        let mut next = queue(&pool, StandIn::new(4, 1, None), CACHED, Arc::default());
        assert!(
            matches!((&mut next.result).await.unwrap(), Ok(Some(_))),
            "the pool takes the next unit"
        );
    }

    #[tokio::test]
    async fn a_unit_queued_behind_another_starts_before_the_first_one_ends() {
        // One slow row keeps a thread on the first unit; the other thread, out of rows, must
        // take the second unit's rows meanwhile instead of waiting for the first to end.
        let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
        let mut first = queue(&pool, StandIn::new(1, 300, None), CACHED, Arc::default());
        let mut second = queue(&pool, StandIn::new(4, 1, None), CACHED, Arc::default());
        tokio::select! {
            done = &mut second.result => assert!(matches!(done.unwrap(), Ok(Some(_)))),
            _ = &mut first.result => panic!("the second unit waited for the first"),
        }
        assert!(matches!((&mut first.result).await.unwrap(), Ok(Some(_))));
    }

    #[test]
    fn dropping_a_queued_unit_cancels_it() {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let unit = StandIn::new(1, 0, None);
        drop(queue(&pool, unit.clone(), CACHED, Arc::default()));
        assert!(unit.canceled.load(Ordering::Relaxed));
    }
}
