//! Unit tests of `tessera-bench mitsuba` (beside the code, in their own file for length).
use super::*;

fn bench(python: &str, cache: &Path) -> MitsubaBench {
    MitsubaBench {
        size: 8,
        spp: vec![1, 4],
        repeats: 2,
        reference_spp: 16,
        samplers: vec!["independent".into()],
        variant: "scalar_rgb".into(),
        python: python.into(),
        cache: cache.to_path_buf(),
        skip_mitsuba: false,
        roulette_depth: vec![3],
        scene: vec!["cornell-box".into()],
    }
}

#[test]
fn the_reference_noise_is_subtracted_exactly() {
    let reference = Reference {
        means: vec![[0.5, 0.09, 0.0]; 4],
        variance: vec![[1e-4, 4e-6, 0.0]; 4],
        description: "test".into(),
    };
    let floor = reference.noise_floor();
    let same = rel_mse_above_reference(reference.means.clone().into_iter(), &reference);
    assert!(
        (same + floor).abs() < 1e-15,
        "an image equal to the reference scores −floor: {same} vs {floor}"
    );
    // Off by 0.01 in every channel: each term adds 0.01² / (ref + 0.01)².
    let off =
        rel_mse_above_reference(reference.means.iter().map(|m| m.map(|v| v + 0.01)), &reference);
    let expected =
        (1e-4 / 0.51f64.powi(2) + 1e-4 / 0.1f64.powi(2) + 1e-4 / 0.01f64.powi(2)) / 3.0 - floor;
    assert!((off - expected).abs() < 1e-12, "{off} vs {expected}");
}

#[test]
fn without_mitsuba_tessera_is_measured_and_the_run_still_succeeds() {
    let cache =
        std::env::temp_dir().join(format!("tessera-mitsuba-bench-test-{}", std::process::id()));
    let rows = run(&bench("/nonexistent/python3", &cache)).expect("runs without Mitsuba");
    let _ = std::fs::remove_dir_all(&cache);
    assert_eq!(rows.len(), 4, "two samplers × two spp, Tessera only");
    for r in &rows {
        assert_eq!(r.renderer, "tessera");
        assert!(r.seconds > 0.0 && r.rel_mse.is_finite(), "{r:?}");
        assert!(r.rays_per_s.is_some_and(|v| v > 0.0), "rays are counted: {r:?}");
    }
}

#[test]
fn a_scene_mitsuba_cannot_render_is_measured_on_tessera_alone() {
    use std::os::unix::fs::PermissionsExt;
    let dir =
        std::env::temp_dir().join(format!("tessera-mitsuba-bench-refuse-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // Stands in for python3 running the script on a scene it cannot translate.
    let fake = dir.join("python3");
    std::fs::write(
        &fake,
        "#!/bin/sh\necho 'Mitsuba cannot render textured as Tessera does: textures' >&2\nexit 2\n",
    )
    .unwrap();
    std::fs::set_permissions(&fake, std::fs::Permissions::from_mode(0o755)).unwrap();
    let err = mitsuba_rows(
        "cornell-box",
        &Reference { means: vec![], variance: vec![], description: String::new() },
        &bench(fake.to_str().unwrap(), &dir),
        1,
    )
    .expect_err("the script refused");
    assert!(err.is::<Untranslatable>(), "{err:#}");
    assert_eq!(err.to_string(), "Mitsuba cannot render textured as Tessera does: textures");
    let rows = run(&bench(fake.to_str().unwrap(), &dir)).expect("Tessera's side still runs");
    let _ = std::fs::remove_dir_all(&dir);
    assert_eq!(rows.len(), 4, "two samplers × two spp, Tessera only");
    assert!(rows.iter().all(|r| r.renderer == "tessera"));
}
