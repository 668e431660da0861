//! What the worker keeps of a scene file: an animated file's parsed sequence stays for its next
//! frames; a still file's is dropped once its one scene is made (its buffers are dead weight
//! from then on), and later leases find that scene without the file.
use super::*;
use crate::client::prepare::How;
use std::sync::Mutex;
use tessera_render::scene::Preparation;

fn lease(id: &str, scene_id: &str, frame: u32) -> Lease {
    let Step::Lease(mut l) = small(id, 0, [0, 2]) else { unreachable!() };
    l.scene_id = scene_id.into();
    l.frame = frame;
    *l
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_still_files_buffers_are_dropped_once_its_scene_is_made() {
    let mock = Mock::new(3000, vec![]);
    let base = start(&mock).await;
    let worker = Worker::new(&config(&base)).unwrap();
    let held = |id: &str| {
        let mut cache = worker.scenes.lock().unwrap();
        (
            cache.sequences.get(&id.to_owned()).is_some(),
            cache.animations.get(&id.to_owned()).map(|a| a.len()),
        )
    };

    let (still, prepared) = worker.frame_scene(&lease("a", SCENE_ID, 0)).await.unwrap();
    assert_eq!(prepared.how, How::Build);
    assert_eq!(
        held(SCENE_ID),
        (false, Some(0)),
        "the still file's sequence is dropped, its (empty) animation list kept"
    );
    let (again, prepared) = worker.frame_scene(&lease("b", SCENE_ID, 0)).await.unwrap();
    assert_eq!(prepared.how, How::Cached);
    assert!(Arc::ptr_eq(&still, &again));

    worker.frame_scene(&lease("c", ANIMATED_ID, 0)).await.unwrap();
    assert_eq!(
        held(ANIMATED_ID),
        (true, Some(1)),
        "an animated file's sequence stays for its next frames"
    );
    let (_, prepared) = worker.frame_scene(&lease("d", ANIMATED_ID, 1)).await.unwrap();
    assert_eq!(prepared.how, How::Refit);
    assert_eq!(mock.log().scene_downloads, 2, "each file once");

    // A still scene pushed out of the frame cache is made again from a new download.
    for n in 2..2 + cache::FRAMES_KEPT as u32 {
        worker.frame_scene(&lease("e", ANIMATED_ID, n)).await.unwrap();
    }
    let (_, prepared) = worker.frame_scene(&lease("f", SCENE_ID, 0)).await.unwrap();
    assert_eq!(prepared.how, How::Build);
    assert_eq!(mock.log().scene_downloads, 3);
}

static HEARD: Mutex<Vec<Preparation>> = Mutex::new(Vec::new());

fn hear(what: Preparation) {
    HEARD.lock().unwrap().push(what);
}

/// The process's allocator hook (`memory::on_prepare`) hears of a build before a file is parsed
/// and before a still or a first frame is built, of a refit before a later frame, and nothing
/// for a frame already made.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_prepare_hook_hears_builds_and_refits_before_they_start() {
    let mock = Mock::new(3000, vec![]);
    let base = start(&mock).await;
    let mut worker = Worker::new(&config(&base)).unwrap();
    worker.prepare_hook = hear;
    let mut heard = Vec::new();
    for (id, scene, frame, how) in [
        ("a", ANIMATED_ID, 0, How::Build),
        ("b", ANIMATED_ID, 2, How::Refit),
        ("c", ANIMATED_ID, 2, How::Cached),
        ("d", SCENE_ID, 0, How::Build),
    ] {
        let (_, prepared) = worker.frame_scene(&lease(id, scene, frame)).await.unwrap();
        assert_eq!(prepared.how, how);
        heard.push(std::mem::take(&mut *HEARD.lock().unwrap()));
    }
    use Preparation::{Build, Refit};
    assert_eq!(heard, [vec![Build, Build], vec![Refit], vec![], vec![Build, Build]]);
}
