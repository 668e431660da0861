//! `tessera`: the render farm's one binary (coordinator, worker, client and local renderer).
mod cli;

fn main() -> std::process::ExitCode {
    cli::main()
}
