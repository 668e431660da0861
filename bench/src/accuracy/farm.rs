//! The distributed price of accuracy: one fixed job (the Cornell box, `mis` + Sobol, stopped by a
//! noise target) through a coordinator and 1 or 3 local workers, for each tile size and batch
//! size. Smaller units mean more round trips and merges (overhead) but stop closer to the target
//! (less overshoot) and balance better across workers.
//!
//! One machine cannot host three real workers: the cores are shared, one worker gets them all and
//! each of three gets cores/3 (at least 1) threads, so the rows measure coordination overhead, not
//! scaling.
use tessera_proto::{JobRequest, JobState};

#[derive(clap::Args, Clone, Debug)]
pub struct FarmOptions {
    /// Distributed part: image width and height of the job.
    #[arg(long, default_value_t = 128)]
    pub farm_size: u32,
    /// Distributed part: the job's noise target (estimated relMSE at which each tile stops).
    #[arg(long, default_value_t = 0.01)]
    pub farm_noise: f64,
    /// Distributed part: the job's spp cap, in case the target is out of reach.
    #[arg(long, default_value_t = 4096)]
    pub farm_max_spp: u32,
    /// Distributed part: tile edges to try, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [16u32, 32, 64])]
    pub farm_tiles: Vec<u32>,
    /// Distributed part: samples per pixel per unit to try, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [1u32, 4, 16])]
    pub farm_batches: Vec<u32>,
    /// Distributed part: numbers of local workers to try, comma-separated.
    #[arg(long, value_delimiter = ',', default_values_t = [1usize, 3])]
    pub farm_workers: Vec<usize>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FarmRow {
    pub workers: usize,
    pub threads_each: usize,
    pub tile: u32,
    pub batch: u32,
    /// From submission to the last merge, by the coordinator's clock.
    pub time_s: f64,
    /// Mean samples per pixel merged when the job ended.
    pub spp: f64,
    /// The job's estimated relMSE at the end.
    pub noise: f64,
    /// Units merged (tiles × batches each, from the mean spp).
    pub units: f64,
}

pub fn run(options: &FarmOptions, seed: u64) -> anyhow::Result<Vec<FarmRow>> {
    anyhow::ensure!(
        options.farm_size > 0 && options.farm_noise > 0.0 && options.farm_max_spp > 0,
        "--farm-size, --farm-noise and --farm-max-spp must be positive"
    );
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let rt = tokio::runtime::Runtime::new()?;
    let mut rows = Vec::new();
    for &workers in &options.farm_workers {
        for &tile in &options.farm_tiles {
            for &batch in &options.farm_batches {
                anyhow::ensure!(
                    workers > 0 && tile > 0 && batch > 0,
                    "farm workers, tiles and batches must be positive"
                );
                let threads_each = (cores / workers).max(1);
                let row = one_job(&rt, options, seed, workers, threads_each, tile, batch)?;
                eprintln!(
                    "  farm {workers} worker(s) × {threads_each} thread(s), tile {tile}, batch {batch}: {:.3} s, {:.1} spp, noise {:.2e}, ~{:.0} units",
                    row.time_s, row.spp, row.noise, row.units
                );
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

fn one_job(
    rt: &tokio::runtime::Runtime,
    o: &FarmOptions,
    seed: u64,
    workers: usize,
    threads_each: usize,
    tile: u32,
    batch: u32,
) -> anyhow::Result<FarmRow> {
    let scratch = tessera_server::scratch::ScratchDir::new(&format!(
        "accuracy-farm-{workers}-{tile}-{batch}"
    ));
    let req = JobRequest {
        scene: "cornell-box".into(),
        width: o.farm_size,
        height: o.farm_size,
        spp: Some(o.farm_max_spp),
        noise_target: Some(o.farm_noise),
        seed: Some(seed),
        tile_size: Some(tile),
        batch_spp: Some(batch),
        ..JobRequest::default()
    };
    let threads = vec![threads_each; workers];
    let done = rt.block_on(tessera_server::local::with_local_workers(
        scratch.path(),
        &threads,
        |c| async move {
            let job = c.submit(&req).await?;
            c.wait(&job.id, |_| {}).await
        },
    ));
    let done = done?;
    anyhow::ensure!(
        done.state == JobState::Done,
        "farm job ended {:?}: {}",
        done.state,
        done.message.unwrap_or_default()
    );
    let tiles = (o.farm_size.div_ceil(tile) as f64).powi(2);
    Ok(FarmRow {
        workers,
        threads_each,
        tile,
        batch,
        time_s: done.elapsed_s,
        spp: done.progress.samples_done,
        noise: done.noise.unwrap_or(f64::NAN),
        units: tiles * (done.progress.samples_done / batch as f64).ceil(),
    })
}
