//! `tessera`: the render farm's one binary (coordinator, worker, client and local renderer).
mod cli;

/// The coordinator receives each unit's sums in a fresh buffer of hundreds of kilobytes; glibc's
/// malloc hands such buffers back to the kernel and faults them in again on every request
/// (about a tenth of the coordinator's time in `tessera-bench roundtrips`), mimalloc reuses them.
/// Built without its transparent-huge-page advice (`no_thp`): with it, the memory those buffers
/// cycle through was faulted back in 2 MiB at a time, and zeroing those pages took 3.4 % of a farm
/// render's CPU (perf, `tessera render cornell-box`); with 4 KiB pages it is ≈ 0.1 %.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn main() -> std::process::ExitCode {
    cli::main()
}
