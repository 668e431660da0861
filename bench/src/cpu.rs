//! CPU time of the benchmark's own process: all threads (getrusage), and thread by thread
//! (schedstat), so that a benchmark can split one run's CPU between kinds of threads.

/// Each live thread of this process: (id, whether it is a worker's render thread, CPU seconds
/// so far). From `/proc/self/task/*/schedstat` (nanoseconds; the tick-based counters of `stat`
/// are too coarse for a few milliseconds of async work per unit). Empty where unreadable.
pub fn threads_cpu() -> Vec<(u64, bool, f64)> {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else { return Vec::new() };
    tasks
        .flatten()
        .filter_map(|t| {
            let tid = t.file_name().to_str()?.parse().ok()?;
            let name = std::fs::read_to_string(t.path().join("comm")).ok()?;
            let ns: f64 = std::fs::read_to_string(t.path().join("schedstat"))
                .ok()?
                .split_whitespace()
                .next()?
                .parse()
                .ok()?;
            Some((tid, name.starts_with("tessera-render"), ns * 1e-9))
        })
        .collect()
}

/// CPU seconds (render threads, other threads) run between two [`threads_cpu`] readings by the
/// threads alive at the second; threads that ended in between are not counted.
pub fn cpu_since(before: &[(u64, bool, f64)], after: &[(u64, bool, f64)]) -> (f64, f64) {
    if after.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    let (mut render, mut other) = (0.0, 0.0);
    for &(tid, is_render, now) in after {
        let then = before.iter().find(|b| b.0 == tid).map_or(0.0, |b| b.2);
        *(if is_render { &mut render } else { &mut other }) += now - then;
    }
    (render, other)
}

/// User + system CPU seconds of this process so far, every thread included.
pub fn cpu_seconds() -> f64 {
    // SAFETY: getrusage only writes the struct it is given.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    if unsafe { libc::getrusage(libc::RUSAGE_SELF, &mut usage) } != 0 {
        return f64::NAN;
    }
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    secs(usage.ru_utime) + secs(usage.ru_stime)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_since_counts_new_threads_from_zero_and_splits_render_threads() {
        let before = [(1, false, 2.0), (2, true, 5.0), (3, false, 9.0)];
        // Thread 3 ended (not counted), 4 (render) and 5 started in between.
        let after = [(1, false, 2.5), (2, true, 6.0), (4, true, 0.25), (5, false, 0.125)];
        assert_eq!(cpu_since(&before, &after), (1.25, 0.625));
        assert!(cpu_since(&before, &[]).0.is_nan());
    }

    #[test]
    fn this_process_has_threads_with_cpu_time() {
        if !std::path::Path::new("/proc/self/task").exists() {
            return;
        }
        let threads = threads_cpu();
        assert!(!threads.is_empty());
        assert!(threads.iter().all(|t| t.2 >= 0.0 && t.2.is_finite()));
        assert!(threads.iter().any(|t| t.2 > 0.0), "the test thread itself has run");
    }
}
