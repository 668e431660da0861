//! What the worker process holds in memory, as the kernel counts it: the resident set now and
//! its high-water mark (VmRSS and VmHWM of /proc/self/status). Reported with each result, so the
//! coordinator can say what a scene costs a worker; None where /proc is not there (not Linux).
//!
//! Also a hook ([`on_prepare`]) through which the process that links the worker learns what kind
//! of frame scene it is about to prepare: the allocator is the binary's choice, not this crate's,
//! and how long freed pages should stay resident depends on what comes next (`tessera_server::purge`).
use std::sync::OnceLock;
use tessera_render::scene::Preparation;

/// Resident memory of this process, in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ProcessMemory {
    /// Resident now.
    pub rss_bytes: u64,
    /// The most it has been resident since it started.
    pub peak_rss_bytes: u64,
}

/// This process's resident memory now and at its peak; None off Linux.
pub fn process_memory() -> Option<ProcessMemory> {
    parse_status(&std::fs::read_to_string("/proc/self/status").ok()?)
}

/// VmRSS and VmHWM of a /proc/<pid>/status text (given in kB, which the kernel means as KiB).
fn parse_status(status: &str) -> Option<ProcessMemory> {
    let kib = |key: &str| -> Option<u64> {
        status.lines().find_map(|l| {
            l.strip_prefix(key)?.trim().strip_suffix("kB")?.trim().parse::<u64>().ok()
        })
    };
    Some(ProcessMemory { rss_bytes: kib("VmRSS:")? << 10, peak_rss_bytes: kib("VmHWM:")? << 10 })
}

static PREPARE_HOOK: OnceLock<fn(Preparation)> = OnceLock::new();

/// Has `hook` called whenever a worker started after this call parses a scene file or begins
/// preparing a frame's scene, on the thread that does it, with what comes:
/// [`Preparation::Build`] for a file (its first frame is built next), a still or an animation's
/// first frame; [`Preparation::Refit`] for a later frame, which allocates what the frame before
/// it allocated, in the same sizes (and builds instead when that frame's tree is worn). One hook
/// per process (the allocator is the process's): later calls are ignored.
pub fn on_prepare(hook: fn(Preparation)) {
    let _ = PREPARE_HOOK.set(hook);
}

/// The process's hook, or one that does nothing; each worker takes it when it starts.
pub(crate) fn prepare_hook() -> fn(Preparation) {
    PREPARE_HOOK.get().copied().unwrap_or(|_| {})
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_resident_and_peak_from_a_status_text() {
        let status = "Name:\ttessera\nVmPeak:\t 9000 kB\nVmHWM:\t    2048 kB\nVmRSS:\t    1024 kB\nThreads:\t3\n";
        assert_eq!(
            parse_status(status),
            Some(ProcessMemory { rss_bytes: 1 << 20, peak_rss_bytes: 2 << 20 })
        );
    }

    #[test]
    fn a_status_without_the_counts_gives_none() {
        assert_eq!(parse_status("Name:\ttessera\nVmRSS:\t1024 kB\n"), None);
        assert_eq!(parse_status("VmHWM:\tlots kB\nVmRSS:\t1 kB\n"), None);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn this_process_is_resident_and_its_peak_is_at_least_that() {
        let m = process_memory().expect("/proc/self/status on Linux");
        assert!(m.rss_bytes > 0 && m.peak_rss_bytes >= m.rss_bytes, "{m:?}");
    }
}
