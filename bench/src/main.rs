//! Benchmarks of the distributed path (figures, not tests).
//!
//! `tessera-bench overhead`   — the same job rendered by the tracer alone and through a
//!                              coordinator + 1 worker over loopback HTTP, in interleaved pairs;
//!                              prints fastest and median of each, the median per-pair ratio
//!                              with its confidence interval, the worker's idle time and the
//!                              threads' CPU split (tessera_bench::overhead).
//! `tessera-bench roundtrips` — a coordinator on one core fed by fake workers that return
//!                              results instantly, each answer carrying the next lease as for real
//!                              workers (`--separate-leases`: a lease request per unit;
//!                              `--watchers N`: N clients follow the job's events); prints unit
//!                              round trips per second and merge cost.
//! `tessera-bench effects`    — the tracer alone on one scene with the gated kernel, the matte
//!                              kernel (Lambert + lights only) and every effect forced on.
//! `tessera-bench accuracy`   — the accuracy study: relMSE vs time per scene, estimator,
//!                              sampler and roulette, plus tile/batch sizes through a local farm;
//!                              writes docs/accuracy/ (tessera_bench::accuracy).
//! `tessera-bench bvh`        — a generated ~1M-triangle scene (or `--scene NAME`): build time,
//!                              incoherent rays per second (one core, all cores; obvhs's stock
//!                              traversal on the same rays), a path-traced render's rays per second
//!                              against both, the heap the mesh and the scene hold and the
//!                              build's peak, peak resident memory (tessera_bench::bvh).
//! `tessera-bench field`      — writes that generated field as binary glTF, to render it as a job
//!                              (tessera_bench::field).
//! `tessera-bench frames`     — an animation job on local workers with frame affinity on and off:
//!                              time per frame and the scene builds/refits workers reported.
//! `tessera-bench mitsuba`    — time to quality (relMSE × seconds) on the Cornell box against
//!                              Mitsuba 3 in the same run, and the floor under that ratio
//!                              were every ray traced at Embree's rate and nothing else timed
//!                              (tessera_bench::mitsuba, speed_floor).
use clap::{Parser, Subcommand};
use std::time::{Duration, Instant};
use tessera_proto::{JobRequest, PartialSums, TileRect, WirePixel};
use tessera_render::tracer::RenderOptions;
use tessera_render::tracer::{KernelBits, render_tile};
use tessera_server::bundled;

#[derive(Parser)]
#[command(about = "Tessera benchmarks: print figures, assert nothing")]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Tracer alone vs coordinator + 1 worker on the same job, in interleaved pairs: fastest and
    /// median of each, median of the per-pair ratios with its confidence interval, the worker's
    /// idle time within the job, and each farm run's CPU split between render and other threads.
    Overhead(tessera_bench::overhead::OverheadBench),
    /// Effect gating: gated vs matte-only vs all-effects kernels on the same frame.
    Effects {
        #[arg(long, default_value = "cornell-box")]
        scene: String,
        #[arg(long, default_value_t = 256)]
        size: u32,
        #[arg(long, default_value_t = 16)]
        spp: u32,
        /// Rounds of the three kernels, interleaved; the fastest of each is reported.
        #[arg(long, default_value_t = 7)]
        repeats: u32,
    },
    /// The accuracy study: relMSE vs render time for every estimator × sampler × roulette on the
    /// study's scenes, and time to a noise target vs tile and batch size through a local farm.
    /// Writes a markdown report and one SVG plot per scene.
    Accuracy(tessera_bench::accuracy::Options),
    /// A generated ~1M-triangle scene (or a bundled one): build time, incoherent rays/s (ours and
    /// obvhs's stock traversal on the same rays), a path-traced render's rays/s against both,
    /// peak memory; then the render's own rays, logged, traced alone through both BVHs, with our
    /// walk's node and packet tests per ray; last, an animation frame's BVH refitted against one
    /// built, the scene deformed by waves of three sizes.
    Bvh(tessera_bench::bvh::BvhBench),
    /// Writes the generated field `bvh` studies as binary glTF (positions only: 36 bytes a
    /// triangle), so it can be rendered as a job: `tessera render field.glb` then reports the
    /// workers' scene load + BVH build time and peak memory.
    Field {
        /// Triangles to generate (rounded to whole spheres).
        #[arg(long, default_value_t = 1_000_000)]
        triangles: usize,
        /// Where to write the .glb.
        #[arg(short, long, default_value = "field.glb")]
        output: std::path::PathBuf,
        /// Each row of spheres its own node, sliding to and fro along x in a 2-second
        /// animation (`slide`): rows move against each other, so an animation job's frames
        /// refit each other's BVH (`tessera-bench frames --scene FILE`).
        #[arg(long)]
        sliding: bool,
    },
    /// An animation job (frames 0..N−1) on local workers with frame affinity on and off.
    Frames(tessera_bench::frames::FramesBench),
    /// Time to quality (relMSE × seconds) on the Cornell box, Tessera vs Mitsuba 3 in one run;
    /// each scene ends with the floor speed alone sets (every ray at Embree's rate, nothing else timed).
    Mitsuba(tessera_bench::mitsuba::MitsubaBench),
    /// Unit round trips per second through a one-core coordinator, fed by fake workers whose
    /// results ask for the next lease as real workers' do.
    Roundtrips {
        #[arg(long, default_value_t = 5.0)]
        seconds: f64,
        /// Concurrent fake workers.
        #[arg(long, default_value_t = 8)]
        workers: usize,
        #[arg(long, default_value_t = 64)]
        tile: u32,
        /// Ask for each lease with its own request, as workers did before results could carry
        /// the next lease (two requests per unit instead of one).
        #[arg(long)]
        separate_leases: bool,
        /// Clients following the job's event stream meanwhile, as dashboards and `tessera render`
        /// do (each gets a status, with the job's noise, up to ten times a second).
        #[arg(long, default_value_t = 0)]
        watchers: usize,
    },
}

/// The coordinator receives each unit's sums in a fresh buffer of hundreds of kilobytes; glibc's
/// malloc hands such buffers back to the kernel and faults them in again on every request
/// (about a tenth of the coordinator's time in `tessera-bench roundtrips`), mimalloc reuses them.
/// Built without its transparent-huge-page advice (`no_thp`): with it, the memory those buffers
/// cycle through was faulted back in 2 MiB at a time, and zeroing those pages took 3.4 % of a farm
/// render's CPU (perf, `tessera render cornell-box`); with 4 KiB pages it is ≈ 0.1 %.
/// Wrapped in a counter of the bytes held (`bench::heap`), for the memory `tessera-bench bvh`
/// reports per phase.
#[global_allocator]
static ALLOCATOR: tessera_bench::heap::Counting<mimalloc::MiMalloc> =
    tessera_bench::heap::Counting(mimalloc::MiMalloc);

fn main() -> anyhow::Result<()> {
    tessera_bench::heap::installed();
    let cmd = Cli::parse().cmd;
    tessera_bench::say!("{}", tessera_bench::host::describe());
    match cmd {
        Cmd::Overhead(b) => tessera_bench::overhead::run(&b),
        Cmd::Roundtrips { seconds, workers, tile, separate_leases, watchers } => {
            roundtrips(seconds, workers, tile, !separate_leases, watchers)
        }
        Cmd::Effects { scene, size, spp, repeats } => effects(&scene, size, spp, repeats),
        Cmd::Accuracy(options) => tessera_bench::accuracy::run(options).map(|_| ()),
        Cmd::Field { triangles, output, sliding } => write_field(triangles, &output, sliding),
        Cmd::Frames(b) => tessera_bench::frames::run(&b),
        Cmd::Bvh(b) => tessera_bench::bvh::run(&b),
        Cmd::Mitsuba(b) => tessera_bench::mitsuba::run(&b).map(|_| ()),
    }
}

fn effects(scene_name: &str, size: u32, spp: u32, repeats: u32) -> anyhow::Result<()> {
    let scene = bundled::load(scene_name)?;
    let settings = tessera_bench::overhead::settings(size)?;
    let gated_bits = scene
        .effects_for(scene.camera(None).map_err(anyhow::Error::msg)?, settings.background)
        .kernel();
    let kernels = [
        ("gated", None),
        ("matte only", Some(KernelBits::MATTE)),
        ("all effects on", Some(KernelBits::ALL)),
    ];
    let mut best = [f64::INFINITY; 3];
    for _ in 0..repeats {
        // Interleaved so that machine load drifts hit all three alike.
        for (k, (_, bits)) in kernels.iter().enumerate() {
            let t = Instant::now();
            render_tile(
                &scene,
                &settings,
                settings.full_frame(),
                0..spp,
                &RenderOptions { kernel: *bits, ..RenderOptions::default() },
            )
            .map_err(anyhow::Error::msg)?;
            best[k] = best[k].min(t.elapsed().as_secs_f64());
        }
    }
    let samples = size as f64 * size as f64 * spp as f64;
    tessera_bench::say!(
        "effects: {scene_name} {size}x{size} {spp} spp, effects {:?}, gated kernel bits {:#06b}, fastest of {repeats}",
        scene.effects.names(),
        gated_bits.0
    );
    for (k, (name, _)) in kernels.iter().enumerate() {
        tessera_bench::say!(
            "  {name:<15} {:8.3} s  {:>10.0} samples/s  {:+6.2} % vs matte",
            best[k],
            samples / best[k],
            (best[k] / best[1] - 1.0) * 100.0
        );
    }
    Ok(())
}

fn roundtrips(
    seconds: f64,
    workers: usize,
    tile: u32,
    next_with_result: bool,
    watchers: usize,
) -> anyhow::Result<()> {
    let scratch = tessera_server::scratch::ScratchDir::new("bench-rt");
    let state = tessera_server::state::AppState::new(tessera_server::state::Config::new(
        scratch.path().to_path_buf(),
    ))?;
    let std_listener = std::net::TcpListener::bind("127.0.0.1:0")?;
    std_listener.set_nonblocking(true)?;
    let url = format!("http://{}", std_listener.local_addr()?);
    let server_state = state.clone();
    // The coordinator gets one core: a current-thread runtime on its own OS thread, named so a
    // profile (`perf report --comm coordinator`) can tell it from the fake workers.
    std::thread::Builder::new().name("coordinator".into()).spawn(move || {
        let rt =
            tokio::runtime::Builder::new_current_thread().enable_all().build().expect("runtime");
        rt.block_on(async move {
            let listener = tokio::net::TcpListener::from_std(std_listener).expect("listener");
            let _ = tessera_server::app::run(listener, server_state, std::future::pending()).await;
        });
    })?;
    let rt = tokio::runtime::Runtime::new()?;
    let (units, elapsed, events) = rt.block_on(async {
        let http = reqwest::Client::new();
        let size = tile * 16;
        let req = JobRequest {
            scene: "furnace".into(),
            width: size,
            height: size,
            spp: Some(1 << 20),
            tile_size: Some(tile),
            batch_spp: Some(1),
            ..JobRequest::default()
        };
        let job: tessera_proto::Job = http
            .post(format!("{url}/v1/jobs"))
            .json(&req)
            .send()
            .await?
            .error_for_status()?
            .json()
            .await?;
        let template = PartialSums {
            tile: TileRect { x0: 0, y0: 0, w: tile, h: tile },
            samples: [0, 1],
            dropped: 0,
            max_weight: 1.0,
            pixels: vec![
                WirePixel { sum: [0.5; 3], sum_sq: [0.25; 3], sum_lum_sq: 0.25, count: 1 };
                (tile * tile) as usize
            ],
        }
        .encode();
        let deadline = Instant::now() + Duration::from_secs_f64(seconds);
        let start = Instant::now();
        let tasks: Vec<_> = (0..workers)
            .map(|i| {
                let (http, url, template) = (http.clone(), url.clone(), template.clone());
                tokio::spawn(async move {
                    fake_worker(i, http, url, template, deadline, next_with_result).await
                })
            })
            .collect();
        let watching: Vec<_> = (0..watchers)
            .map(|_| tokio::spawn(watch(url.clone(), job.id.clone(), deadline)))
            .collect();
        let mut total = 0u64;
        for t in tasks {
            total += t.await??;
        }
        let elapsed = start.elapsed().as_secs_f64();
        let mut events = 0u64;
        for t in watching {
            events += t.await??;
        }
        anyhow::Ok((total, elapsed, events))
    })?;
    let merge_ns = state.counters.merge_nanos.load(std::sync::atomic::Ordering::Relaxed) as f64;
    let leases = if next_with_result {
        "the next lease in each result's answer"
    } else {
        "a lease request per unit"
    };
    tessera_bench::say!(
        "roundtrips: {workers} fake workers, {tile}x{tile} tiles, 1 spp units, {leases}, coordinator on one core"
    );
    tessera_bench::say!(
        "  {units} units in {elapsed:.2} s = {:.0} unit round trips/s",
        units as f64 / elapsed
    );
    tessera_bench::say!(
        "  merge cost {:.1} µs per unit (decode excluded)",
        merge_ns / units.max(1) as f64 / 1000.0
    );
    if watchers > 0 {
        tessera_bench::say!(
            "  {watchers} clients followed the job's events: {events} statuses received in all"
        );
    }
    Ok(())
}

/// Follows job `id` as `tessera render` does (its event stream, through the CLI's own client)
/// until `deadline`; returns the statuses received.
async fn watch(url: String, id: String, deadline: Instant) -> anyhow::Result<u64> {
    let coordinator = tessera_server::client::Coordinator::new(&url, None);
    let mut events = 0;
    let until = tokio::time::Instant::from_std(deadline);
    if let Ok(ended) = tokio::time::timeout_at(until, coordinator.wait(&id, |_| events += 1)).await
    {
        ended?;
    }
    Ok(events)
}

/// Leases units and returns ready-made results for them until the deadline; returns units merged.
/// With `next_with_result`, each result asks for the next lease, as workers do.
async fn fake_worker(
    i: usize,
    http: reqwest::Client,
    url: String,
    template: Vec<u8>,
    deadline: Instant,
    next_with_result: bool,
) -> anyhow::Result<u64> {
    let reg: tessera_proto::Registration = http
        .post(format!("{url}/v1/workers"))
        .json(&tessera_proto::WorkerHello {
            protocol: tessera_proto::PROTOCOL_VERSION,
            name: format!("fake{i}"),
            threads: 1,
            renderer: tessera_render::renderer_id().to_owned(),
        })
        .send()
        .await?
        .json()
        .await?;
    let mut done = 0;
    let mut next: Option<tessera_proto::Lease> = None;
    while Instant::now() < deadline {
        let lease = match next.take() {
            Some(l) => l,
            None => {
                let resp = http
                    .post(format!("{url}/v1/leases"))
                    .json(&tessera_proto::LeaseRequest { worker_id: reg.worker_id.clone() })
                    .send()
                    .await?;
                if resp.status() == reqwest::StatusCode::NO_CONTENT {
                    continue;
                }
                resp.json().await?
            }
        };
        let mut body = template.clone();
        body[8..12].copy_from_slice(&lease.tile.x0.to_le_bytes());
        body[12..16].copy_from_slice(&lease.tile.y0.to_le_bytes());
        body[24..28].copy_from_slice(&lease.samples[0].to_le_bytes());
        body[28..32].copy_from_slice(&lease.samples[1].to_le_bytes());
        let query = if next_with_result { "?next=true" } else { "" };
        let r = http
            .put(format!("{url}/v1/leases/{}/result{query}", lease.lease_id))
            .header("content-type", tessera_proto::sums::CONTENT_TYPE)
            .body(body)
            .send()
            .await?;
        match r.status() {
            reqwest::StatusCode::NO_CONTENT => {}
            reqwest::StatusCode::OK => next = Some(r.json().await?),
            _ => anyhow::bail!("result refused: {}", r.text().await?),
        }
        done += 1;
    }
    Ok(done)
}

fn write_field(triangles: usize, output: &std::path::Path, sliding: bool) -> anyhow::Result<()> {
    use tessera_bench::field;
    let spheres = field::sphere_field(triangles);
    let glb = if sliding { field::sliding_field_glb(&spheres) } else { field::field_glb(&spheres) };
    std::fs::write(output, &glb)
        .map_err(|e| anyhow::anyhow!("writing {}: {e}", output.display()))?;
    tessera_bench::say!(
        "{}: {} triangles (the spheres, a ground and a light), {:.1} MiB",
        output.display(),
        spheres.len() + 4,
        glb.len() as f64 / f64::from(1 << 20)
    );
    Ok(())
}
