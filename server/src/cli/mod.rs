//! Command-line interface: one file per subcommand.
mod args;
mod healthcheck;
mod job;
mod render;
mod serve;
mod submit;
mod work;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "tessera",
    version,
    about = "Tessera: a distributed render farm for physically based images",
    long_about = "Tessera path-traces glTF 2.0 scenes. `render` renders on this machine (a coordinator and a worker in one process); `serve` runs a coordinator; `work` runs a worker that pulls units from a coordinator; `submit` sends a job to a coordinator; `job` reads, pauses, resumes or cancels one; `healthcheck` probes a coordinator (for containers). Benchmarks are a separate command, `tessera-bench`.\n\nLogs go to stderr; set RUST_LOG (e.g. RUST_LOG=debug) to change their level."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene on this machine and write an OpenEXR image.
    Render(render::RenderArgs),
    /// Run a coordinator: accepts jobs over HTTP and leases units to workers.
    Serve(serve::ServeArgs),
    /// Run a worker: pulls units from a coordinator, renders them on all cores, returns sums.
    #[command(
        after_help = "On SIGTERM or Ctrl-C the worker takes no new unit, gives back the one it prefetched, lets the unit in hand finish within 2 s (and uploads it) or gives it back, then deregisters from the coordinator and exits 0.\n\nThe allocator gives freed memory back to the system after 10 ms (MIMALLOC_PURGE_DELAY, in milliseconds, overrides it), which keeps a BVH build's peak low."
    )]
    Work(work::WorkArgs),
    /// Submit a job to a coordinator, optionally wait for it and download the image.
    Submit(submit::SubmitArgs),
    /// Read, pause, resume, cancel or delete a job on a coordinator; prints its state after.
    Job(job::JobCmdArgs),
    /// Check that a coordinator answers on /healthz (exit code 0) or not (1); for container probes.
    Healthcheck(healthcheck::HealthcheckArgs),
}

/// `--version`: the release, and the renderer id workers register with (workers of different
/// ids never share a job while one of each is live).
fn long_version() -> &'static str {
    static TEXT: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    TEXT.get_or_init(|| {
        format!("{}\nrenderer: {}", env!("CARGO_PKG_VERSION"), tessera_render::renderer_id())
    })
}

/// The command line, parsed. The renderer id's libm probe (about a millisecond, half of a
/// `tessera healthcheck`'s start) is only run when `--version` asks for it.
fn parse() -> Cli {
    let mut command = Cli::command();
    if std::env::args_os().skip(1).any(|a| a == "--version") {
        command = command.long_version(long_version());
    }
    Cli::from_arg_matches(&command.get_matches()).unwrap_or_else(|e| e.exit())
}

/// Prints one line of a command's result. A reader that has gone (`tessera render … | head -1`)
/// is not an error: it took what it wanted, and the rest has nowhere to go.
fn say(line: std::fmt::Arguments) -> std::io::Result<()> {
    use std::io::Write;
    match writeln!(std::io::stdout().lock(), "{line}") {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        other => other,
    }
}

pub fn main() -> ExitCode {
    let cli = parse();
    let default_level = if matches!(
        cli.command,
        Command::Render(_) | Command::Submit(_) | Command::Job(_) | Command::Healthcheck(_)
    ) {
        "warn"
    } else {
        "info"
    };
    tracing_subscriber::fmt()
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_default_env()
                .unwrap_or_else(|_| default_level.into()),
        )
        .with_writer(std::io::stderr)
        .init();
    let result = match cli.command {
        Command::Render(a) => render::run(a),
        Command::Serve(a) => serve::run(a),
        Command::Work(a) => work::run(a),
        Command::Submit(a) => submit::run(a),
        Command::Job(a) => job::run(a),
        Command::Healthcheck(a) => healthcheck::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// Resolves on Ctrl-C or SIGTERM.
pub async fn shutdown_signal() {
    let ctrl_c = async {
        let _ = tokio::signal::ctrl_c().await;
    };
    #[cfg(unix)]
    let term = async {
        match tokio::signal::unix::signal(tokio::signal::unix::SignalKind::terminate()) {
            Ok(mut s) => {
                s.recv().await;
            }
            Err(_) => std::future::pending::<()>().await,
        }
    };
    #[cfg(not(unix))]
    let term = std::future::pending::<()>();
    tokio::select! {
        () = ctrl_c => {},
        () = term => {},
    }
}
