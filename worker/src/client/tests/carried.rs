//! Leases carried by results' answers (`PUT /v1/leases/{id}/result?next=true`).
use super::*;

/// After the first two units (a lease request, then the prefetch's), each unit comes in the
/// answer to the result of the unit two before it: no lease request for it.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn results_carry_the_next_lease() {
    let mock = Mock::new(
        3000,
        vec![
            small("a", 0, [0, 4]),
            small("b", 8, [0, 4]),
            small("c", 0, [4, 8]),
            small("d", 8, [4, 8]),
        ],
    );
    mock.log().leases_with_results = true;
    // a's and b's leases come from lease requests (the loop's, then the prefetch's sent while a
    // renders); a's result must not be answered before b's request took b.
    mock.log().carry_after_lease_requests = 2;
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    wait_until("four results arrive", Duration::from_secs(30), || mock.log().results.len() == 4)
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    let log = mock.log();
    let ids: Vec<&str> = log.results.iter().map(|r| r.0.as_str()).collect();
    assert_eq!(ids, ["a", "b", "c", "d"]);
    assert_eq!(log.carried, ["c", "d"], "a's result brings c, b's brings d");
    assert_eq!(report.leases_with_results, 2);
    assert_eq!((report.units_done, report.units_canceled), (4, 0));
    // Lease requests: a and b, then only polls once the script is empty (after d was carried).
    let d_carried = log.results[1].3;
    assert_eq!(
        log.lease_requests.iter().filter(|(t, _)| *t < d_carried).count(),
        2,
        "{:?}",
        log.lease_requests
    );
    for (_, _, body, _) in &log.results {
        assert_bit_exact(body, &params(16, 8));
    }
    assert!(log.released.is_empty(), "{:?}", log.released);
}

/// A lease that arrives in a result's answer after shutdown began is given back at once.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lease_carried_into_a_shutdown_is_given_back() {
    let mock =
        Mock::new(3000, vec![small("a", 0, [0, 4]), small("b", 8, [0, 4]), small("c", 0, [4, 8])]);
    mock.log().leases_with_results = true;
    mock.log().slow_results.insert("a".into());
    mock.log().carry_after_lease_requests = 2;
    let base = start(&mock).await;
    let worker = spawn_worker(&base);
    // a's result is on its way and will be answered, with c, half a second later.
    wait_until("a's result arrives", Duration::from_secs(30), || !mock.log().results.is_empty())
        .await;
    let (report, _) = worker.stop(Duration::from_secs(10)).await;

    let log = mock.log();
    assert_eq!(log.carried, ["c"]);
    assert!(log.released.contains(&"c".to_owned()), "c is given back: {:?}", log.released);
    assert_eq!(report.leases_with_results, 1);
    assert_eq!(
        report.units_done + report.units_canceled + report.units_stale,
        2,
        "a and b: {report:?}"
    );
}
