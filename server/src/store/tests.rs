//! The checkpoint protocol against crashes at each step.
use super::*;
use crate::scheduler::{JobConfig, TileCheckpoint};
use tessera_proto::{JobRequest, JobState, RenderParams};
use tessera_render::tracer::PixelSums;

fn dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("tessera-store-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

fn record(upto: u32) -> JobRecord {
    JobRecord {
        cfg: JobConfig {
            id: "j1".into(),
            scene_id: "s".into(),
            params: RenderParams {
                width: 2,
                height: 1,
                seed: 1,
                estimator: "mis".into(),
                sampler: "sobol".into(),
                camera: None,
                max_depth: 8,
                roulette_depth: None,
                light_sampler: None,
                background: [0.0; 3],
                animation: None,
                fps: tessera_proto::job::DEFAULT_FPS,
            },
            spp: 8,
            spp_given: true,
            noise_target: None,
            time_limit_ms: None,
            tile_size: 2,
            batch_spp: 4,
            priority: 0,
            effects: vec![],
            request: JobRequest::default(),
            created_unix_ms: 0,
            frames: vec![0],
        },
        seq: 1,
        state: JobState::Running,
        elapsed_ms: 5,
        history: vec![[0.1, 4.0, 0.5]],
        message: None,
        tiles: vec![TileMark { upto, stop_at: None, released: None }],
        contributions: Default::default(),
        renderers: vec!["tessera 0.1.0 src:aaaaaaaaaaaa libm:00000000".into()],
        ended_unix_ms: None,
    }
}

fn tile(upto: u32, previous_upto: u32, v: f64) -> TileCheckpoint {
    let p =
        PixelSums { sum: [v; 3], sum_sq: [v * v; 3], sum_lum_sq: v * v, count: 4 * upto as u64 };
    TileCheckpoint { tile: 0, upto, previous_upto, sums: vec![p; 2], dropped: 0, max_weight: v }
}

#[test]
fn a_crash_between_files_and_commit_keeps_the_old_checkpoint() {
    let d = dir("crash-before-commit");
    {
        let store = Store::open(&d).unwrap();
        store.write_tiles("j1", &[tile(1, 0, 1.0)]).unwrap();
        store.commit(&[&record(1)]).unwrap();
        // The next checkpoint writes its file, then the process dies before the commit.
        store.write_tiles("j1", &[tile(2, 1, 2.0)]).unwrap();
        std::fs::write(d.join("jobs/j1/.t0-b3.sums.tmp"), b"half a file").unwrap();
    }
    let store = Store::open(&d).unwrap();
    let jobs = store.load_jobs().unwrap();
    assert_eq!(jobs.len(), 1);
    assert_eq!(jobs[0].tiles[0].upto, 1, "the record still names the old file");
    store.remove_orphans("j1", &jobs[0].tiles);
    let left: Vec<String> = std::fs::read_dir(d.join("jobs/j1"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert_eq!(left, ["t0-b1.sums"], "the uncommitted file and the temp file are gone");
    let t = store.read_tile("j1", 0, jobs[0].tiles[0], 2).unwrap();
    assert_eq!(t.sums[0].sum, [1.0; 3]);
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_committed_checkpoint_supersedes_the_old_file() {
    let d = dir("commit");
    let store = Store::open(&d).unwrap();
    store.write_tiles("j1", &[tile(1, 0, 1.0)]).unwrap();
    store.commit(&[&record(1)]).unwrap();
    let next = tile(2, 1, 2.0);
    store.write_tiles("j1", std::slice::from_ref(&next)).unwrap();
    store.commit(&[&record(2)]).unwrap();
    store.remove_superseded("j1", &[next]);
    assert!(!d.join("jobs/j1/t0-b1.sums").exists());
    let mark = store.load_jobs().unwrap()[0].tiles[0];
    assert_eq!(store.read_tile("j1", 0, mark, 2).unwrap().sums[0].sum, [2.0; 3]);
    assert!(store.read_tile("j1", 0, mark, 3).is_err(), "a file for another tile size is refused");
    assert_eq!(store.next_boot().unwrap(), 1);
    assert_eq!(store.next_boot().unwrap(), 2, "boots are counted");
    let _ = std::fs::remove_dir_all(&d);
}

#[test]
fn a_record_stored_before_renderers_were_kept_loads_without_any() {
    let mut stored = serde_json::to_value(record(1)).unwrap();
    stored.as_object_mut().unwrap().remove("renderers");
    let r: JobRecord = serde_json::from_value(stored).expect("older records load");
    assert!(r.renderers.is_empty());
}
