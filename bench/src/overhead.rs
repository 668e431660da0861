//! `tessera-bench overhead`: the same job rendered by the tracer alone and through a coordinator
//! and 1 worker over loopback HTTP (target ≤ 3 %). Both deliver the same thing: the
//! tracer alone renders the same units (all queued on its pool at once, each worked by every
//! thread as the worker does, so it has no gaps between units), merges them into a frame and
//! encodes the EXR too, so what differs is what distribution adds (HTTP, leases, merging on the
//! coordinator, start and stop).
//!
//! A 2-core VM shared with other work drifts by ±10 % from run to run, more than the overhead
//! itself, so the two paths run in pairs (alone then farm, farm then alone, alternating), and the
//! report gives the fastest of each, the median of each and the median of the per-pair ratios
//! with a distribution-free confidence interval. Within each farm run two things are measured
//! directly, which no drift between runs can blur: the worker's idle time (the job's wall time on
//! the coordinator's clock minus the time the worker's pool spent rendering, its report's
//! `busy`), and each thread's CPU time (the render threads against all the others).
use super::cpu::{cpu_seconds, cpu_since, threads_cpu};
use super::median;
use std::sync::Arc;
use std::time::Instant;
use tessera_proto::JobRequest;
use tessera_render::tracer::{PixelSums, RenderSettings, RowQueue, Scene, Tile};
use tessera_server::bundled;
use tessera_server::image;
use tessera_server::local::{LocalFarm, with_farm_reports};
use tessera_server::output::encode_exr;
use tessera_worker::client::render_settings;

#[derive(Clone, Debug, clap::Args)]
pub struct OverheadBench {
    #[arg(long, default_value = "cornell-box")]
    pub scene: String,
    /// Frame width and height in pixels.
    #[arg(long, default_value_t = 256)]
    pub size: u32,
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
    /// Pairs of runs (tracer alone + farm, which goes first alternating).
    #[arg(long, default_value_t = 5)]
    pub repeats: u32,
    /// Samples per pixel in one unit (the tracer-alone run renders the same units).
    #[arg(long, default_value_t = 16)]
    pub batch_spp: u32,
}

const TILE: u32 = 64;

/// One farm run's phases, in seconds from the start of the run.
#[derive(Clone, Copy, Debug)]
struct FarmRun {
    /// Coordinator and worker started.
    up: f64,
    /// Submit to done, on the coordinator's clock.
    job: f64,
    /// The client saw the job done.
    seen: f64,
    /// EXR downloaded.
    exr: f64,
    /// Farm stopped: the whole run.
    total: f64,
    /// The worker's pool rendering (its report).
    busy: f64,
    /// Units the worker took on (merged, stale or canceled), and those its prefetch had queued
    /// on the pool in advance.
    units: u64,
    queued_ahead: u64,
    /// CPU seconds of the whole process (every thread: coordinator, worker, client).
    cpu: f64,
    /// CPU seconds of the worker's render threads, and of the process's other live threads,
    /// from submit to the EXR downloaded (per-thread schedstat; NaN where unreadable).
    render_cpu: f64,
    other_cpu: f64,
}

pub fn run(b: &OverheadBench) -> anyhow::Result<()> {
    let scene = Arc::new(bundled::load(&b.scene)?);
    let settings = settings(b.size)?;
    let rt = tokio::runtime::Runtime::new()?;
    let (mut alone, mut encodes, mut alone_cpu, mut farm) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for r in 0..b.repeats.max(1) {
        let farm_first = r % 2 == 1;
        if farm_first {
            farm.push(farm_run(&rt, b, r)?);
        }
        let cpu = cpu_seconds();
        let (total, encode) = alone_run(&scene, &settings, b)?;
        alone_cpu.push(cpu_seconds() - cpu);
        alone.push(total);
        encodes.push(encode);
        if !farm_first {
            farm.push(farm_run(&rt, b, r)?);
        }
        let f = farm[farm.len() - 1];
        eprintln!(
            "  pair {r} ({}): alone {:.3} s | farm up {:.3}, job {:.3} (coordinator), done seen {:.3}, EXR {:.3}, stopped {:.3} s; worker busy {:.3} s, idle in job {:.3} s; {} of {} units queued behind the one before",
            if farm_first { "farm first" } else { "alone first" },
            alone[alone.len() - 1],
            f.up,
            f.job,
            f.seen,
            f.exr,
            f.total,
            f.busy,
            f.job - f.busy,
            f.queued_ahead,
            f.units
        );
    }
    report(b, &alone, &farm);
    // The same pairs against the tracer alone stopping before the EXR (the farm still encodes it).
    let bare: Vec<f64> = alone.iter().zip(&encodes).map(|(a, e)| a - e).collect();
    let ratios: Vec<f64> = bare.iter().zip(&farm).map(|(a, f)| f.total / a).collect();
    crate::say!(
        "  against the tracer alone stopping before its EXR encode (a median {:.3} s): median per-pair overhead {:+.2} %",
        median(&encodes),
        (median(&ratios) - 1.0) * 100.0
    );
    // CPU time does not count the time a VM's other tenants take, which blurs wall times.
    let farm_cpu: Vec<f64> = farm.iter().map(|f| f.cpu).collect();
    let ratios: Vec<f64> = alone_cpu.iter().zip(&farm_cpu).map(|(a, f)| f / a).collect();
    crate::say!(
        "  CPU time of all threads (user + system), medians: alone {:.3} s, farm {:.3} s; median per-pair extra CPU {:+.2} %",
        median(&alone_cpu),
        median(&farm_cpu),
        (median(&ratios) - 1.0) * 100.0
    );
    // Both shares come from one run, so the VM's drift between runs cancels out of their ratio.
    let shares: Vec<f64> = farm.iter().map(|f| f.other_cpu / f.render_cpu).collect();
    crate::say!(
        "  within each farm run (per-thread CPU, medians): render threads {:.3} s, every other thread (coordinator, HTTP, the worker's async side, the final EXR) {:.3} s = {:.2} % of the render's CPU",
        median(&farm.iter().map(|f| f.render_cpu).collect::<Vec<_>>()),
        median(&farm.iter().map(|f| f.other_cpu).collect::<Vec<_>>()),
        median(&shares) * 100.0
    );
    let render_vs_alone: Vec<f64> =
        farm.iter().zip(&alone_cpu).map(|(f, a)| f.render_cpu / a).collect();
    crate::say!(
        "  the farm's render threads against the whole tracer-alone run, CPU: median per-pair ratio {:+.2} % (the same work; what differs is the threads' surroundings)",
        (median(&render_vs_alone) - 1.0) * 100.0
    );
    Ok(())
}

fn report(b: &OverheadBench, alone: &[f64], farm: &[FarmRun]) {
    let n = alone.len();
    let totals: Vec<f64> = farm.iter().map(|f| f.total).collect();
    let ratios: Vec<f64> = alone.iter().zip(&totals).map(|(a, f)| f / a).collect();
    let pct = |r: f64| (r - 1.0) * 100.0;
    let (fast_a, fast_f) = (min(alone), min(&totals));
    let (med_a, med_f) = (median(alone), median(&totals));
    let samples = f64::from(b.size) * f64::from(b.size) * f64::from(b.spp);
    crate::say!(
        "overhead: {} {}x{} {} spp, units {TILE}x{TILE}x{}, {n} pairs (alone/farm interleaved)",
        b.scene,
        b.size,
        b.size,
        b.spp,
        b.batch_spp
    );
    crate::say!("                          fastest     median");
    crate::say!(
        "  tracer alone           {fast_a:8.3} s {med_a:8.3} s  {:>10.0} samples/s (fastest; incl. merging the units and the EXR encode)",
        samples / fast_a
    );
    crate::say!(
        "  coordinator + 1 worker {fast_f:8.3} s {med_f:8.3} s  {:>10.0} samples/s (fastest; incl. scene load, EXR encode and download)",
        samples / fast_f
    );
    crate::say!(
        "  overhead               {:+7.2} %  {:+7.2} %",
        pct(fast_f / fast_a),
        pct(med_f / med_a)
    );
    crate::say!(
        "  overhead, median of the per-pair ratios {:+6.2} %  (pairs: {})",
        pct(median(&ratios)),
        list(&ratios, |r| format!("{:+.1}", pct(r)))
    );
    match median_interval(&ratios) {
        Some((lo, hi, level)) => crate::say!(
            "  the median's {:.0} % confidence interval (order statistics, no assumption on the noise): {:+.2} % … {:+.2} %",
            level * 100.0,
            pct(lo),
            pct(hi)
        ),
        None => crate::say!("  (6 or more pairs give a confidence interval for the median)"),
    }
    // Within-run accounting, medians over the farm runs.
    let med = |f: fn(&FarmRun) -> f64| median(&farm.iter().map(f).collect::<Vec<_>>());
    let idle = med(|f| f.job - f.busy);
    let fixed = med(|f| f.total - f.job);
    crate::say!(
        "  farm run breakdown (medians): worker idle in the job {:.3} s = {:.2} % of the job; fixed costs (start, EXR, stop) {fixed:.3} s = {:.2} % of the run; render busy {:.3} s vs alone {med_a:.3} s, its EXR included ({:+.2} %)",
        idle,
        med(|f| (f.job - f.busy) / f.job) * 100.0,
        med(|f| (f.total - f.job) / f.total) * 100.0,
        med(|f| f.busy),
        pct(med(|f| f.busy) / med_a)
    );
}

/// A distribution-free interval for the median of `v`: the k-th smallest and k-th largest
/// values, with the largest k whose coverage (from the binomial distribution, p = ½) is still
/// ≥ 95 %. Returns (low, high, coverage); None when even the extremes cover less.
fn median_interval(v: &[f64]) -> Option<(f64, f64, f64)> {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    // P(X < k) for X ~ Binomial(n, ½): the chance that fewer than k values fall below the median.
    let below = |k: usize| (0..k).map(|i| binomial(n, i)).sum::<f64>() / 2f64.powi(n as i32);
    let coverage = |k: usize| 1.0 - 2.0 * below(k);
    let k = (1..=n / 2).take_while(|&k| coverage(k) >= 0.95).last()?;
    Some((s[k - 1], s[n - k], coverage(k)))
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |c, i| c * (n - i) as f64 / (i + 1) as f64)
}

fn list(v: &[f64], f: impl Fn(f64) -> String) -> String {
    v.iter().map(|&x| f(x)).collect::<Vec<_>>().join(" ")
}

fn min(v: &[f64]) -> f64 {
    v.iter().copied().fold(f64::INFINITY, f64::min)
}

/// The settings both paths render with: a square frame, `mis` + Sobol, seed 0.
pub fn settings(size: u32) -> anyhow::Result<RenderSettings> {
    let params = tessera_proto::RenderParams {
        width: size,
        height: size,
        seed: 0,
        estimator: "mis".into(),
        sampler: "sobol".into(),
        camera: None,
        max_depth: 1024,
        roulette_depth: None,
        light_sampler: None,
        background: [0.0; 3],
        animation: None,
        fps: tessera_proto::job::DEFAULT_FPS,
    };
    render_settings(&params).map_err(anyhow::Error::msg)
}

/// The tracer alone, unit by unit in the farm's order (batches outer, tiles inner), merged into
/// a frame and encoded as the same EXR layers the farm delivers; seconds in all and of the encode.
fn alone_run(
    scene: &Arc<Scene>,
    settings: &RenderSettings,
    b: &OverheadBench,
) -> anyhow::Result<(f64, f64)> {
    let (size, spp, batch) = (b.size, b.spp, b.batch_spp);
    let t = Instant::now();
    let mut units = Vec::new();
    for k in 0..spp.div_ceil(batch) {
        for y0 in (0..size).step_by(TILE as usize) {
            for x0 in (0..size).step_by(TILE as usize) {
                let tile = Tile { x0, y0, w: TILE.min(size - x0), h: TILE.min(size - y0) };
                let samples = k * batch..((k + 1) * batch).min(spp);
                units.push(
                    RowQueue::new(scene.clone(), settings.clone(), tile, samples)
                        .map_err(anyhow::Error::msg)?,
                );
            }
        }
    }
    // Every unit queued at once, each worked by every thread, as the worker's pool does: the
    // tracer at its best on these units (no gap between them, no thread waiting for another).
    let threads = rayon::current_num_threads();
    rayon::scope_fifo(|s| {
        for unit in &units {
            for _ in 0..threads {
                s.spawn_fifo(|_| {
                    unit.work();
                });
            }
        }
    });
    let mut frame = vec![PixelSums::default(); (size * size) as usize];
    for unit in &units {
        unit.take().expect("never canceled").add_into_frame(&mut frame, size);
    }
    let encode = Instant::now();
    encode_exr(&image::layers(size, size, &frame), &[])?;
    Ok((t.elapsed().as_secs_f64(), encode.elapsed().as_secs_f64()))
}

/// The same job through a local coordinator + 1 worker (all cores), EXR downloaded.
fn farm_run(rt: &tokio::runtime::Runtime, b: &OverheadBench, r: u32) -> anyhow::Result<FarmRun> {
    let scratch = tessera_server::scratch::ScratchDir::new(&format!("bench-{r}"));
    let req = JobRequest {
        scene: b.scene.clone(),
        width: b.size,
        height: b.size,
        spp: Some(b.spp),
        tile_size: Some(TILE),
        batch_spp: Some(b.batch_spp),
        ..JobRequest::default()
    };
    let (t, cpu) = (Instant::now(), cpu_seconds());
    let (phases, reports) =
        rt.block_on(with_farm_reports(scratch.path(), LocalFarm::default(), |c| async move {
            let up = t.elapsed().as_secs_f64();
            let before = threads_cpu();
            let j = c.submit(&req).await?;
            let done = c.wait(&j.id, |_| {}).await?;
            let seen = t.elapsed().as_secs_f64();
            c.bytes(&format!("/v1/jobs/{}/image.exr", j.id)).await?;
            let threads = cpu_since(&before, &threads_cpu());
            anyhow::Ok((up, done.elapsed_s, seen, t.elapsed().as_secs_f64(), threads))
        }))?;
    let total = t.elapsed().as_secs_f64();
    let cpu = cpu_seconds() - cpu;
    let report = reports.first().copied().flatten();
    let busy = report.map_or(f64::NAN, |w| w.busy.as_secs_f64());
    let (units, queued_ahead) = report.map_or((0, 0), |w| {
        (w.units_done + w.units_stale + w.units_canceled, w.units_queued_ahead)
    });
    let (up, job, seen, exr, (render_cpu, other_cpu)) = phases;
    Ok(FarmRun { up, job, seen, exr, total, busy, units, queued_ahead, cpu, render_cpu, other_cpu })
}

#[cfg(test)]
mod tests {
    use super::median_interval;

    #[test]
    fn the_median_interval_has_the_binomial_coverage() {
        // n = 15: P(X ≤ 3) = 576/32768, so the 4th smallest and 4th largest cover 96.5 %.
        let v: Vec<f64> = (1..=15).rev().map(f64::from).collect();
        let (lo, hi, level) = median_interval(&v).unwrap();
        assert_eq!((lo, hi), (4.0, 12.0));
        assert!((level - (1.0 - 2.0 * 576.0 / 32768.0)).abs() < 1e-12);
        // Five values: even the extremes cover only 1 − 2/32 = 93.75 %.
        assert!(median_interval(&[1.0, 2.0, 3.0, 4.0, 5.0]).is_none());
        assert_eq!(
            median_interval(&[6.0, 1.0, 5.0, 2.0, 4.0, 3.0]).map(|(l, h, _)| (l, h)),
            Some((1.0, 6.0))
        );
    }
}
