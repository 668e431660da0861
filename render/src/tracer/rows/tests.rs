//! A unit worked through its row queue, by any number of threads, equals `render_tile`'s bits.
use super::*;
use crate::scene::load_path;
use crate::tracer::RenderOptions;
use crate::tracer::render_tile;
use crate::tracer::sampler::SamplerKind;
use std::path::Path;

fn cornell() -> (Arc<Scene>, RenderSettings) {
    let scene =
        load_path(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box.gltf"))
            .expect("bundled scene");
    let mut settings = crate::tracer::integrator::tests::settings(
        crate::tracer::Estimator::Mis,
        Default::default(),
        40,
        glam::Vec3::ZERO,
    );
    settings.sampler = SamplerKind::Sobol;
    (Arc::new(scene), settings)
}

const TILE: Tile = Tile { x0: 8, y0: 4, w: 24, h: 20 };

fn queue(scene: &Arc<Scene>, settings: &RenderSettings) -> RowQueue {
    RowQueue::new(scene.clone(), settings.clone(), TILE, 3..7).expect("valid unit")
}

#[test]
fn one_thread_finishes_the_unit_and_its_sums_are_render_tiles() {
    let (scene, settings) = cornell();
    let q = queue(&scene, &settings);
    assert!(q.work(), "the only worker finishes the last row");
    assert!(!q.work(), "nothing left to finish");
    let expected = render_tile(&scene, &settings, TILE, 3..7, &RenderOptions::default()).unwrap();
    assert!(expected.rays > 0);
    assert_eq!(q.take(), Some(expected));
}

#[test]
fn many_threads_give_the_same_bits_and_exactly_one_finishes() {
    let (scene, settings) = cornell();
    let expected = render_tile(&scene, &settings, TILE, 3..7, &RenderOptions::default()).unwrap();
    for threads in [2, 3, 7] {
        let q = queue(&scene, &settings);
        let finishers: usize = std::thread::scope(|s| {
            let handles: Vec<_> = (0..threads).map(|_| s.spawn(|| q.work())).collect();
            handles.into_iter().map(|h| usize::from(h.join().unwrap())).sum()
        });
        assert_eq!(finishers, 1, "{threads} threads");
        assert_eq!(q.take().as_ref(), Some(&expected), "{threads} threads");
    }
}

#[test]
fn a_canceled_unit_still_finishes_and_yields_nothing() {
    let (scene, settings) = cornell();
    let q = queue(&scene, &settings);
    q.cancel();
    assert!(q.work(), "the remaining rows end at once, and the last one reports the end");
    assert_eq!(q.take(), None);
}

#[test]
fn a_row_that_panics_still_counts_as_finished() {
    let rows_left = AtomicU32::new(2);
    let panicked = std::panic::catch_unwind(|| {
        let _row = RowFinishing(&rows_left);
        panic!("row failed");
    });
    assert!(panicked.is_err());
    assert_eq!(rows_left.load(Ordering::Relaxed), 1);
    assert!(RowFinishing(&rows_left).finish(), "the other row is the last");
}

#[test]
fn a_tile_outside_the_image_is_refused() {
    let (scene, settings) = cornell();
    let tile = Tile { x0: 30, y0: 0, w: 20, h: 4 };
    let err = RowQueue::new(scene, settings, tile, 0..1).err().expect("refused");
    assert!(err.to_string().contains("exceeds the 40×40 image"), "{err}");
}
