//! `/healthz` and `/metrics` (Prometheus text format).
use crate::state::AppState;
use axum::extract::State;
use axum::http::header;
use axum::response::IntoResponse;
use std::fmt::Write;
use std::sync::atomic::Ordering;
use tessera_proto::JobState;

/// Liveness: answers 200 while the coordinator runs — "ok", or "ok; checkpoints failing: …" when
/// job state cannot be written (the coordinator still serves; jobs stay in memory meanwhile).
#[utoipa::path(get, path = "/healthz", tag = "health", responses((status = 200, description = "alive")))]
pub async fn healthz(State(st): State<AppState>) -> String {
    match st.durable.last_error() {
        Some(e) => format!("ok; checkpoints failing: {e}"),
        None => "ok".into(),
    }
}

/// A Prometheus label value: backslash, double quote and line feed escaped (workers choose it).
fn label_value(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"").replace('\n', "\\n")
}

/// Counters and gauges in Prometheus text format.
#[utoipa::path(get, path = "/metrics", tag = "health", responses((status = 200, content_type = "text/plain")))]
pub async fn metrics(State(st): State<AppState>) -> impl IntoResponse {
    let mut out = String::new();
    let c = &st.counters;
    let counters = [
        ("tessera_units_merged_total", "Results merged", c.units_merged.load(Ordering::Relaxed)),
        (
            "tessera_results_stale_total",
            "Late or duplicate results ignored",
            c.results_stale.load(Ordering::Relaxed),
        ),
        (
            "tessera_results_malformed_total",
            "Results refused as malformed",
            c.results_malformed.load(Ordering::Relaxed),
        ),
        (
            "tessera_leases_granted_total",
            "Units leased to workers",
            c.leases_granted.load(Ordering::Relaxed),
        ),
        (
            "tessera_checkpoint_failures_total",
            "Checkpoints of job state that failed",
            st.durable.failures(),
        ),
    ];
    for (name, help, v) in counters {
        let _ = writeln!(out, "# HELP {name} {help}\n# TYPE {name} counter\n{name} {v}");
    }
    let merge_s = c.merge_nanos.load(Ordering::Relaxed) as f64 / 1e9;
    let _ = writeln!(
        out,
        "# HELP tessera_merge_seconds_total Time spent merging results\n# TYPE tessera_merge_seconds_total counter\ntessera_merge_seconds_total {merge_s}"
    );
    let sched = st.scheduler.lock().expect("lock");
    let _ = writeln!(out, "# HELP tessera_jobs Jobs by state\n# TYPE tessera_jobs gauge");
    for state in JobState::ALL {
        let n = sched.jobs_newest_first().filter(|j| j.state() == state).count();
        let _ = writeln!(out, "tessera_jobs{{state=\"{}\"}} {n}", state.name());
    }
    let _ = writeln!(
        out,
        "# HELP tessera_workers Registered workers\n# TYPE tessera_workers gauge\ntessera_workers {}",
        sched.workers().count()
    );
    // Several renderer ids at once is a farm mid-upgrade (or a mixed one): its jobs are split.
    let mut by_renderer = std::collections::BTreeMap::<&str, u32>::new();
    for (_, w) in sched.workers() {
        *by_renderer.entry(&w.renderer).or_default() += 1;
    }
    let _ = writeln!(
        out,
        "# HELP tessera_workers_by_renderer Registered workers by renderer id\n# TYPE tessera_workers_by_renderer gauge"
    );
    for (renderer, n) in by_renderer {
        let _ = writeln!(
            out,
            "tessera_workers_by_renderer{{renderer=\"{}\"}} {n}",
            label_value(renderer)
        );
    }
    ([(header::CONTENT_TYPE, "text/plain; version=0.0.4")], out)
}
