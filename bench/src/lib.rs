//! Benchmark studies of the `tessera-bench` command, and the tests that
//! keep them working. Figures are printed and written as documents; nothing here asserts speed.
pub mod accuracy;
pub mod bvh;
pub mod cpu;
pub mod embree;
pub mod field;
pub mod frames;
pub mod heap;
pub mod host;
pub mod mitsuba;
pub mod mitsuba_suite;
pub mod overhead;
pub mod refit;
pub mod same_rays;
pub mod speed_floor;
pub mod stock;

/// `println!` for a benchmark's figures. A reader that has gone (`tessera-bench … | head -3`)
/// took what it wanted and the figures still to come have nowhere to go, so the benchmark ends
/// there, with success, instead of panicking in the middle of a study.
#[macro_export]
macro_rules! say {
    ($($arg:tt)*) => { $crate::say_line(format_args!($($arg)*)) };
}

/// The median of `v` (the mean of the middle two for an even count); NaN for none.
pub(crate) fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    match s.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => s[n / 2],
        n => (s[n / 2 - 1] + s[n / 2]) / 2.0,
    }
}

#[doc(hidden)]
pub fn say_line(line: std::fmt::Arguments) {
    use std::io::Write;
    match writeln!(std::io::stdout().lock(), "{line}") {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {
            // `exit` runs no destructors: the study's scratch directories go first.
            tessera_server::scratch::remove_all();
            std::process::exit(0)
        }
        Err(e) => panic!("failed printing to stdout: {e}"),
    }
}
