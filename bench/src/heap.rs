//! Heap bytes held and their peak, for benchmarks that report what a scene costs in memory.
//!
//! The process's peak resident set (VmHWM) mixes everything a benchmark ever held — its own rays,
//! the generated mesh, freed pages the allocator kept — into one number. [`Counting`] wraps the
//! global allocator and keeps two counters, so a study can say what one phase added and how high
//! the heap went during it (`tessera-bench bvh`: the mesh, the scene built from it, the build's
//! transient peak). Two relaxed atomic operations per allocation; the tracer's hot loop
//! allocates nothing (`worker/tests/allocations.rs`), so renders do not pay for them.
//!
//! Only `tessera-bench` installs it; elsewhere the counters stay at zero and [`counting`] says so.
use std::alloc::{GlobalAlloc, Layout};
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering::Relaxed};

/// A global allocator that counts the bytes `A` has handed out and not yet been given back.
pub struct Counting<A>(pub A);

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);
static INSTALLED: AtomicBool = AtomicBool::new(false);

fn added(bytes: usize) {
    let live = LIVE.fetch_add(bytes, Relaxed) + bytes;
    PEAK.fetch_max(live, Relaxed);
}

fn removed(bytes: usize) {
    LIVE.fetch_sub(bytes, Relaxed);
}

// SAFETY: every call is forwarded to `A` unchanged; only counters are updated besides.
unsafe impl<A: GlobalAlloc> GlobalAlloc for Counting<A> {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { self.0.alloc(layout) };
        if !p.is_null() {
            added(layout.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        let p = unsafe { self.0.alloc_zeroed(layout) };
        if !p.is_null() {
            added(layout.size());
        }
        p
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { self.0.dealloc(ptr, layout) };
        removed(layout.size());
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let p = unsafe { self.0.realloc(ptr, layout, new_size) };
        if !p.is_null() {
            removed(layout.size());
            added(new_size);
        }
        p
    }
}

/// Marks the allocator as the process's, so the counters mean something. Call it first thing in
/// `main` of the binary that installs [`Counting`].
pub fn installed() {
    INSTALLED.store(true, Relaxed);
}

/// Whether this process counts its heap.
pub fn counting() -> bool {
    INSTALLED.load(Relaxed)
}

/// Bytes allocated and not yet freed.
pub fn live() -> usize {
    LIVE.load(Relaxed)
}

/// Starts a new peak: from now on [`peak`] is the most the heap held since this call.
pub fn reset_peak() {
    PEAK.store(LIVE.load(Relaxed), Relaxed);
}

/// The most bytes held at once since the last [`reset_peak`].
pub fn peak() -> usize {
    PEAK.load(Relaxed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::alloc::System;

    #[test]
    fn counts_what_is_held_and_the_peak() {
        // The test binary's allocator is not `Counting`: drive one by hand. Other tests in the
        // binary do not touch these counters (only `Counting` does).
        let a = Counting(System);
        reset_peak();
        let (before, big, small) = (
            live(),
            Layout::from_size_align(1 << 20, 8).unwrap(),
            Layout::from_size_align(1000, 8).unwrap(),
        );
        unsafe {
            let p = a.alloc(big);
            let q = a.alloc_zeroed(small);
            assert_eq!(live() - before, (1 << 20) + 1000);
            let p = a.realloc(p, big, 1 << 10);
            assert_eq!(live() - before, (1 << 10) + 1000);
            a.dealloc(p, Layout::from_size_align(1 << 10, 8).unwrap());
            a.dealloc(q, small);
        }
        assert_eq!(live(), before);
        assert_eq!(peak() - before, (1 << 20) + 1000);
        reset_peak();
        assert_eq!(peak(), before);
    }
}
