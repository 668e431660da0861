//! Frame ranges end to end: an animated scene rendered as 8 frames by 3 worker processes, each
//! frame bit-identical to rendering that frame alone with `tessera render --frames n..n`.
use crate::cluster::Farm;
use crate::harness::{temp_dir, tessera_bin};
use std::process::Command;
use tessera_proto::{FrameRange, JobRequest, JobState};
use tessera_server::output::decode_exr;

const SCENE: &str = "cornell-animated";
const SIZE: (u32, u32) = (40, 32);
const SPP: u32 = 16;

fn request() -> JobRequest {
    JobRequest {
        scene: SCENE.into(),
        width: SIZE.0,
        height: SIZE.1,
        spp: Some(SPP),
        seed: Some(7),
        tile_size: Some(16),
        batch_spp: Some(8),
        frames: Some(FrameRange { start: 0, end: 7, step: None, fps: None }),
        ..JobRequest::default()
    }
}

fn pixels(exr: &[u8]) -> (Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<f32>) {
    let (img, _) = decode_exr(exr).unwrap();
    (img.rgb, img.variance, img.samples)
}

#[test]
fn eight_frames_on_three_workers_match_each_frame_rendered_alone() {
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap();
    let farm = Farm::start("frames", 3);
    let (job, farm_frames) = rt.block_on(async {
        let c = farm.client();
        let job = c.submit(&request()).await.expect("submit");
        let job = c.wait(&job.id, |_| {}).await.unwrap();
        assert_eq!(job.state, JobState::Done, "{job:?}");
        let mut frames = Vec::new();
        for n in 0..8 {
            frames
                .push(c.bytes(&format!("/v1/jobs/{}/frames/{n}/image.exr", job.id)).await.unwrap());
        }
        (job, frames)
    });
    assert_eq!(job.frames.len(), 8);
    assert!(job.frames.iter().all(|f| f.done && f.samples_done == f64::from(SPP)));
    // Every frame's scene was prepared (built or refitted) somewhere, and affinity kept the
    // preparations near one per frame: frame-major order without it costs one per frame and
    // worker (24 here).
    let prepared: u32 = job.frames.iter().map(|f| f.builds + f.refits).sum();
    assert!((8..=16).contains(&prepared), "scene preparations: {prepared} ({:?})", job.frames);

    let dir = temp_dir("frames-alone");
    let _ = std::fs::create_dir_all(&dir);
    for n in 0..8u32 {
        let out = Command::new(tessera_bin())
            .args([
                "render",
                SCENE,
                "--spp",
                &SPP.to_string(),
                "--width",
                &SIZE.0.to_string(),
                "--height",
                &SIZE.1.to_string(),
            ])
            .args([
                "--seed",
                "7",
                "--tile-size",
                "16",
                "--batch-spp",
                "8",
                "--threads",
                "1",
                "--frames",
                &format!("{n}..{n}"),
                "-o",
            ])
            .arg(dir.join("alone.exr"))
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let alone =
            std::fs::read(dir.join(format!("alone_{n:04}.exr"))).expect("numbered output file");
        assert!(
            pixels(&alone) == pixels(&farm_frames[n as usize]),
            "frame {n}: farm vs rendered alone"
        );
    }
    // The animation moves something: the first and last frames differ.
    assert!(
        pixels(&farm_frames[0]).0 != pixels(&farm_frames[7]).0,
        "frames 0 and 7 are the same image"
    );
}
