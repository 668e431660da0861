//! The noise a job reports must be honest: its estimated relMSE (from the merged per-pixel
//! variance) against the true relMSE of its image measured against Mitsuba 3's 131,072-spp
//! reference of the same Cornell box (tests/reference/). With independent samples the estimate
//! must agree within 25 %; with Sobol (whose error is below what the sample variance suggests) it
//! must not understate the error.
use crate::harness::{repo_root, temp_dir};
use tessera_proto::JobRequest;
use tessera_server::output::decode_exr;

/// Mean over pixels and channels of (ours − reference)² / (reference + 0.01)², the definition the
/// estimate uses with Var(mean) in place of the squared error.
fn true_rel_mse(ours: &[[f32; 3]], reference: &[[f32; 3]]) -> f64 {
    let mut acc = 0.0;
    for (o, r) in ours.iter().zip(reference) {
        for c in 0..3 {
            let d = (r[c] as f64) + 0.01;
            acc += ((o[c] - r[c]) as f64).powi(2) / (d * d);
        }
    }
    acc / (3 * ours.len()) as f64
}

#[test]
fn estimated_noise_agrees_with_the_true_error_within_25_percent() {
    let (reference, _) = decode_exr(
        &std::fs::read(repo_root().join("tests/reference/cornell-box-mitsuba.exr")).unwrap(),
    )
    .unwrap();
    let (w, h) = (reference.width as u32, reference.height as u32);
    let rt = tokio::runtime::Builder::new_multi_thread().enable_all().build().unwrap();
    for (sampler, spp) in [
        ("independent", 16),
        ("independent", 64),
        ("independent", 256),
        ("sobol", 16),
        ("sobol", 64),
        ("sobol", 256),
    ] {
        let req = JobRequest {
            scene: "cornell-box".into(),
            width: w,
            height: h,
            spp: Some(spp),
            sampler: Some(sampler.into()),
            seed: Some(11),
            ..JobRequest::default()
        };
        let (estimate, exr) = rt
            .block_on(tessera_server::local::with_local_farm(
                &temp_dir(&format!("accuracy-{sampler}-{spp}")),
                0,
                |c| async move {
                    let job = c.submit(&req).await?;
                    let done = c.wait(&job.id, |_| {}).await?;
                    let exr = c.bytes(&format!("/v1/jobs/{}/image.exr", job.id)).await?;
                    Ok((done.noise.expect("noise"), exr))
                },
            ))
            .unwrap();
        let (ours, _) = decode_exr(&exr).unwrap();
        let truth = true_rel_mse(&ours.rgb, &reference.rgb);
        let ratio = estimate / truth;
        eprintln!(
            "{sampler:>11} {spp:>4} spp: estimated relMSE {estimate:.4e}, true {truth:.4e}, ratio {ratio:.3}"
        );
        if sampler == "independent" {
            assert!(
                (ratio - 1.0).abs() <= 0.25,
                "{spp} spp: estimate {estimate:.4e} vs true {truth:.4e} (ratio {ratio:.3})"
            );
        } else {
            // The variance of the mean from sample variance assumes independent samples; Sobol's
            // stratification makes the true error smaller, so the estimate is an upper bound.
            assert!(
                ratio >= 0.75,
                "sobol {spp} spp: the estimate must not understate the error: ratio {ratio:.3}"
            );
        }
    }
}
