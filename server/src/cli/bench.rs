//! `tessera bench`: benchmark studies that write documents (the same code as `tessera-bench`).
use clap::{Args, Subcommand};

#[derive(Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    study: Study,
}

#[derive(Subcommand)]
enum Study {
    /// What accuracy costs in time: relMSE vs render time for every estimator × sampler ×
    /// roulette on the study's scenes, and time to a noise target vs tile and batch size through
    /// a local farm. Writes a markdown report and one SVG plot per scene.
    Accuracy(tessera_server::bench::accuracy::Options),
}

pub fn run(args: BenchArgs) -> anyhow::Result<()> {
    match args.study {
        Study::Accuracy(options) => tessera_server::bench::accuracy::run(options).map(|_| ()),
    }
}
