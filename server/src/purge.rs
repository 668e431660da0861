//! How soon the allocator gives freed memory back, for the processes that build scenes.
//!
//! mimalloc 3 keeps freed pages resident for a second (its `purge_delay`, 1000 ms; mimalloc 2's
//! was 10 ms) and reuses them meanwhile. A BVH build frees and allocates hundreds of MiB within
//! that second, and not all of it is reused: a worker rendering a million triangles as a job
//! peaked at 500 MiB resident with the default, 336–344 with 10 ms and 332 with 0
//! (docs/performance.md, session 30). `tessera work`, `tessera render` and `tessera-bench bvh`
//! therefore take 10 ms. `tessera serve` keeps the default: a coordinator cycles its unit
//! buffers through exactly that reuse (its round trips fell by half with a delay of 0).
//! `MIMALLOC_PURGE_DELAY` in the environment overrides both.

/// mimalloc's `mi_option_purge_delay` (its index in `mi_option_e`, the same in mimalloc 2 and 3;
/// the test below checks it against the documented default).
const PURGE_DELAY: libmimalloc_sys::mi_option_t = 15;

/// The delay for processes that build scenes, in milliseconds.
const SCENE_BUILDER_PURGE_MS: std::ffi::c_long = 10;

/// Sets the purge delay to [`SCENE_BUILDER_PURGE_MS`] unless the environment sets it.
pub fn for_scene_builders() {
    if std::env::var_os("MIMALLOC_PURGE_DELAY").is_none() {
        // SAFETY: sets an integer option, which mimalloc reads at each use; then collects, as
        // any thread may at any time.
        unsafe {
            libmimalloc_sys::mi_option_set(PURGE_DELAY, SCENE_BUILDER_PURGE_MS);
            // A purge already scheduled keeps its expiry, and later frees join it rather than
            // set their own: without this, memory freed before the call (by the start-up of
            // `tessera-bench bvh`, for one) held every purge back for the old delay's 10 s.
            libmimalloc_sys::mi_collect(true);
        }
    }
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
        assert_eq!(get(), 1000, "option {PURGE_DELAY} is not mimalloc 3's purge_delay (documented default 1000 ms)");
        for_scene_builders();
        assert_eq!(get(), SCENE_BUILDER_PURGE_MS);
    }
}
