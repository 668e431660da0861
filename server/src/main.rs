//! `tessera`: the render farm's one binary (coordinator, worker, client and local renderer).
mod cli;

/// The coordinator receives each unit's sums in a fresh buffer of hundreds of kilobytes; glibc's
/// malloc hands such buffers back to the kernel and faults them in again on every request
/// (about a tenth of the coordinator's time in `tessera-bench roundtrips`), mimalloc reuses them.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    cli::main()
}
