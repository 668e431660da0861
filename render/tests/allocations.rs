//! No allocation per sample: rendering a tile allocates the same number of times whether it
//! takes 4 or 64 samples per pixel, on every bundled scene (so for every effect kernel), through
//! `render_tile` and through a `RowQueue` (the worker's way).
//!
//! A counting global allocator sees every allocation in this test binary, which holds this one
//! test only, so nothing else allocates concurrently. Per-unit and per-row allocations (the
//! tile's sums, rayon's bookkeeping) are allowed: they do not grow with the sample count.
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::sampler::SamplerKind;
use tessera_render::tracer::{
    PathSettings, RenderSettings, RowQueue, Scene, Tile, TileSums, render_tile,
};

struct Counting;

static ALLOCATIONS: AtomicU64 = AtomicU64::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

const TILE: Tile = Tile { x0: 8, y0: 8, w: 16, h: 16 };

fn by_render_tile(scene: &Arc<Scene>, settings: &RenderSettings, spp: u32) -> TileSums {
    render_tile(scene, settings, TILE, 0..spp, &RenderOptions::default()).expect("renders")
}

fn by_row_queue(scene: &Arc<Scene>, settings: &RenderSettings, spp: u32) -> TileSums {
    let unit = RowQueue::new(scene.clone(), settings.clone(), TILE, 0..spp).expect("a valid unit");
    assert!(unit.work(), "one thread finishes the unit");
    unit.take().expect("not canceled")
}

fn allocations_for(
    render: fn(&Arc<Scene>, &RenderSettings, u32) -> TileSums,
    scene: &Arc<Scene>,
    settings: &RenderSettings,
    spp: u32,
) -> u64 {
    let before = ALLOCATIONS.load(Ordering::Relaxed);
    let sums = render(scene, settings, spp);
    let after = ALLOCATIONS.load(Ordering::Relaxed);
    assert_eq!(
        sums.pixels.iter().map(|p| p.count).sum::<u64>() + sums.dropped,
        u64::from(spp) * 256
    );
    drop(sums);
    after - before
}

#[test]
fn the_hot_loop_does_not_allocate_per_sample() {
    let scenes = concat!(env!("CARGO_MANIFEST_DIR"), "/../scenes");
    let mut names: Vec<_> = std::fs::read_dir(scenes)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "gltf"))
        .collect();
    names.sort();
    assert!(names.len() >= 9, "bundled scenes: {names:?}");
    // One thread: rayon's workers are started once, outside what is counted.
    rayon::ThreadPoolBuilder::new().num_threads(1).build_global().unwrap();
    for path in names {
        let scene = Arc::new(tessera_render::scene::load_path(&path).unwrap());
        let settings = RenderSettings {
            width: 32,
            height: 32,
            seed: 1,
            sampler: SamplerKind::Sobol,
            path: PathSettings::default(),
            background: glam::Vec3::splat(0.2),
            camera: None,
        };
        for (how, render) in
            [("render_tile", by_render_tile as fn(&_, &_, _) -> _), ("RowQueue", by_row_queue)]
        {
            allocations_for(render, &scene, &settings, 4); // warm-up: lazily initialised statics
            let few = allocations_for(render, &scene, &settings, 4);
            let many = allocations_for(render, &scene, &settings, 64);
            assert_eq!(
                many,
                few,
                "{} by {how}: {few} allocations at 4 spp but {many} at 64 spp",
                path.display()
            );
        }
    }
}
