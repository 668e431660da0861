//! Results that also take the worker's next unit (`PUT /v1/leases/{id}/result?next=true`).
use super::super::tests::{Api, lease, register, sums_for, tiled_job};
use axum::http::{Method, StatusCode};
use std::collections::HashSet;
use tessera_proto::Lease;
use tessera_proto::sums::CONTENT_TYPE;

async fn put_result_next(api: &Api, l: &Lease) -> super::super::tests::Resp {
    api.request(
        Method::PUT,
        &format!("/v1/leases/{}/result?next=true", l.lease_id),
        Some(CONTENT_TYPE),
        sums_for(l, 0.5).encode(),
    )
    .await
}

/// One lease request, then every result's answer carries the next unit until none is left
/// (204); the job is done and every unit was leased exactly once.
#[tokio::test]
async fn each_result_brings_the_next_unit_until_the_job_is_done() {
    let api = Api::new("carried-all");
    let w = register(&api).await;
    let job = api.submit(&tiled_job()).await;
    let mut held = lease(&api, &w).await;
    let mut units = HashSet::from([(held.tile.x0, held.tile.y0, held.samples[0])]);
    loop {
        let r = put_result_next(&api, &held).await;
        if r.status == StatusCode::NO_CONTENT {
            break;
        }
        r.expect(StatusCode::OK);
        held = serde_json::from_slice(&r.body).expect("the next lease");
        assert!(
            units.insert((held.tile.x0, held.tile.y0, held.samples[0])),
            "unit {held:?} leased twice"
        );
    }
    assert_eq!(units.len(), 12, "6 tiles × 2 batches");
    assert_eq!(api.job(job["id"].as_str().unwrap()).await["state"], "done");
    assert_eq!(api.metric("tessera_leases_granted_total").await, "12");
    assert_eq!(api.metric("tessera_units_merged_total").await, "12");
}

/// A result that is not merged (stale, or refused as malformed) takes no lease with it; without
/// `next` the answer stays 204.
#[tokio::test]
async fn only_a_merged_result_that_asks_takes_a_lease() {
    let api = Api::new("carried-only");
    let w = register(&api).await;
    api.submit(&tiled_job()).await;
    let first = lease(&api, &w).await;
    let plain = api
        .request(
            Method::PUT,
            &format!("/v1/leases/{}/result", first.lease_id),
            Some(CONTENT_TYPE),
            sums_for(&first, 0.5).encode(),
        )
        .await;
    plain.expect(StatusCode::NO_CONTENT);
    put_result_next(&api, &first).await.problem(StatusCode::CONFLICT);
    let second = lease(&api, &w).await;
    let mut wrong = sums_for(&second, 0.5);
    wrong.samples = [wrong.samples[0], wrong.samples[1] + 1];
    for p in &mut wrong.pixels {
        p.count += 1;
    }
    let r = api
        .request(
            Method::PUT,
            &format!("/v1/leases/{}/result?next=true", second.lease_id),
            Some(CONTENT_TYPE),
            wrong.encode(),
        )
        .await;
    r.problem(StatusCode::UNPROCESSABLE_ENTITY);
    assert_eq!(
        api.metric("tessera_leases_granted_total").await,
        "2",
        "the two lease requests only"
    );
}
