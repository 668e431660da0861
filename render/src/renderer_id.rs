//! Which renderer a worker is: `tessera 0.1.0 src:1a2b3c4d5e6f libm:0123abcd`.
//!
//! A farm's promise is that an image's bits do not depend on who rendered what. That holds
//! between workers that compute the same thing, and two builds of different source, or the
//! same build on a libm that rounds differently (another glibc version, another architecture),
//! may not. So every worker names its renderer when it registers, and the coordinator keeps a
//! job on workers of one renderer (`server/src/scheduler/renderers.rs`).
//!
//! - `src:` is a SHA-256 of the source that decides pixels (this crate, `proto`, `Cargo.lock`;
//!   see `build.rs`), so two builds of the same commit agree wherever they were compiled, and
//!   static and dynamic builds too.
//! - `libm:` hashes the results of the f32 libm functions the tracer and the scene loader call
//!   (they call no f64 ones outside tests), on a fixed grid of arguments, computed when the
//!   process starts. It tells apart libms that round differently on those arguments; it is a
//!   sample, not a proof that they agree everywhere. glibc's FMA and SSE2 variants agree on it,
//!   as they do on the images (`docs/numerics.md`; `tests/tests/render_cli.rs` checks both give
//!   the same id). They do not agree on f64 `sin`, `exp`, `ln`, `powf` or `atan2`: a tracer
//!   that starts calling those must be checked again, or this id would split such CPUs apart.
use sha2::{Digest, Sha256};
use std::sync::OnceLock;

/// Arguments per function in the libm probe.
const PROBE_POINTS: u32 = 4096;

/// This process's renderer id (computed once).
pub fn renderer_id() -> &'static str {
    static ID: OnceLock<String> = OnceLock::new();
    ID.get_or_init(|| {
        format!(
            "tessera {} src:{} libm:{}",
            env!("CARGO_PKG_VERSION"),
            env!("TESSERA_SOURCE_HASH"),
            libm_probe()
        )
    })
}

/// Eight hex digits of a hash over the probed functions' results, bit for bit.
fn libm_probe() -> String {
    let mut hash = Sha256::new();
    for i in 0..PROBE_POINTS {
        // u in (0, 1), away from both ends; x spans the magnitudes the tracer feeds these.
        let u = (i as f32 + 0.5) / PROBE_POINTS as f32;
        let x = 1e-3 * 1e6f32.powf(u);
        let angle = std::f32::consts::TAU * u;
        let (s, c) = angle.sin_cos();
        let results = [
            s,
            c,
            angle.sin(),
            angle.cos(),
            (1.5 * u).tan(),
            (-x).exp(),
            (-u).exp_m1(),
            u.ln(),
            (-u).ln_1p(),
            ((u + 0.055) / 1.055).powf(2.4),
            (2.0 * u - 1.0).acos(),
        ];
        for v in results {
            hash.update(v.to_bits().to_le_bytes());
        }
    }
    hash.finalize().iter().take(4).map(|b| format!("{b:02x}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_id_names_the_version_the_source_and_the_libm() {
        let id = renderer_id();
        let parts: Vec<&str> = id.split(' ').collect();
        assert_eq!(parts.len(), 4, "{id}");
        assert_eq!(parts[..2], ["tessera", env!("CARGO_PKG_VERSION")]);
        let hex = |s: &str, prefix: &str, n: usize| {
            s.strip_prefix(prefix)
                .is_some_and(|h| h.len() == n && h.bytes().all(|b| b.is_ascii_hexdigit()))
        };
        assert!(hex(parts[2], "src:", 12), "{id}");
        assert!(hex(parts[3], "libm:", 8), "{id}");
    }

    #[test]
    fn the_probe_is_a_pure_function_of_the_libm() {
        assert_eq!(libm_probe(), libm_probe());
        assert_eq!(renderer_id(), renderer_id());
    }
}
