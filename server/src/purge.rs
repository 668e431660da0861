//! How soon the allocator gives freed memory back, for the processes that build scenes.
//!
//! mimalloc 3 keeps freed pages resident for a second (its `purge_delay`, 1000 ms; mimalloc 2's
//! was 10 ms) and reuses them meanwhile. A BVH build frees and allocates hundreds of MiB within
//! that second, and not all of it is reused: a worker rendering a million triangles as a job
//! peaked at 500 MiB resident with the default, 336–344 with 10 ms and 332 with 0
//! (docs/dev/performance-log.md, 2026-12-06). `tessera work`, `tessera render` and `tessera-bench bvh`
//! therefore take 10 ms while they build. An animation's later frames are the opposite case: a
//! refit allocates what the frame before it freed, in the same sizes, so with 10 ms each frame
//! faulted its pages in again (a refitted frame of the 1M-triangle field took 0.17–0.18 s on 2
//! threads instead of 0.09–0.11; measured 2026-12-06). Workers say which they are about to do
//! ([`tessera_worker::memory::on_prepare`]), and a refit restores the default for the frames
//! that follow. `tessera serve` keeps the default: a coordinator cycles its unit buffers through
//! exactly that reuse (its round trips fell by half with a delay of 0).
//! `MIMALLOC_PURGE_DELAY` in the environment overrides all of this.
use tessera_render::scene::Preparation;

/// mimalloc's `mi_option_purge_delay` (its index in `mi_option_e`, the same in mimalloc 2 and 3;
/// the test below checks it against the documented default).
const PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// The delay while a process builds scenes, in milliseconds.
const SCENE_BUILDER_PURGE_MS: std::ffi::c_long = 10;
/// The delay once a worker refits an animation's frames: mimalloc 3's default.
const REFIT_PURGE_MS: std::ffi::c_long = 1000;

/// Sets the purge delay to [`SCENE_BUILDER_PURGE_MS`], and has this process's workers set it
/// for each frame they prepare ([`for_preparation`]), unless the environment sets it.
pub fn for_scene_builders() {
    if std::env::var_os("MIMALLOC_PURGE_DELAY").is_none() {
        set_purge_delay(SCENE_BUILDER_PURGE_MS);
        // A purge already scheduled keeps its expiry, and later frees join it rather than set
        // their own: without this, memory freed before the call (by the start-up of
        // `tessera-bench bvh`, for one) held every purge back for the old delay's 10 s.
        // SAFETY: a collection, as mimalloc runs on its own at any time.
        unsafe { libmimalloc_sys::mi_collect(true) };
        tessera_worker::memory::on_prepare(for_preparation);
    }
}

/// Sets the purge delay for what a worker is about to prepare. Process-wide, as the allocator
/// is: with several workers in one process, the last to start preparing sets it.
fn for_preparation(what: Preparation) {
    set_purge_delay(delay_for(what));
}

fn delay_for(what: Preparation) -> std::ffi::c_long {
    match what {
        Preparation::Build => SCENE_BUILDER_PURGE_MS,
        Preparation::Refit => REFIT_PURGE_MS,
    }
}

fn set_purge_delay(ms: std::ffi::c_long) {
    // SAFETY: sets an integer option, which mimalloc reads at each use.
    unsafe { libmimalloc_sys::mi_option_set(PURGE_DELAY, ms) };
}

/// Returns the calling thread's freed pages to the system now, whatever the purge delay: for a
/// thread that has just freed an image it will not reuse soon (`Shared::finalize`), which would
/// otherwise hold it until the thread allocates again.
pub fn return_freed_pages() {
    // SAFETY: a collection of the calling thread's heap, as mimalloc runs on its own at any time.
    unsafe { libmimalloc_sys::mi_collect(true) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_mimallocs_purge_delay_unless_the_environment_does() {
        if std::env::var_os("MIMALLOC_PURGE_DELAY").is_some() {
            return; // the option then holds the user's value
        }
        // SAFETY: reads an integer option.
        let get = || unsafe { libmimalloc_sys::mi_option_get(PURGE_DELAY) };
        assert_eq!(
            get(),
            REFIT_PURGE_MS,
            "option {PURGE_DELAY} is not mimalloc 3's purge_delay (documented default 1000 ms)"
        );
        for_scene_builders();
        assert_eq!(get(), SCENE_BUILDER_PURGE_MS);
        // Not set and read back here: local workers of other tests in this process set it too.
        assert_eq!(
            (delay_for(Preparation::Build), delay_for(Preparation::Refit)),
            (SCENE_BUILDER_PURGE_MS, REFIT_PURGE_MS)
        );
    }
}
