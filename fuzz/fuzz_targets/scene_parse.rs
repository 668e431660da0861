//! Any bytes → the scene loader: a clean Ok or Err, never a panic — not even one the loader's
//! own `catch_unwind` would turn into "the glTF reader failed" (a missing bounds check).
#![no_main]

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    // Panics the loader catches on purpose (gltf-crate validator bugs) must not abort the run;
    // an uncaught panic still does (libfuzzer-sys aborts after catch_unwind).
    static QUIET: std::sync::Once = std::sync::Once::new();
    QUIET.call_once(|| std::panic::set_hook(Box::new(|_| {})));
    // Parsing only (fast); BVH builds are covered by the corpus replay in `cargo test`.
    if let Err(e) = tessera_render::scene::parse_limited(data, None, 100_000) {
        assert!(!e.0.contains("the glTF reader failed") && !e.0.is_empty(), "{e}");
    }
});
