//! The machine and build a benchmark's figures come from, printed first by every `tessera-bench`
//! study and written into the accuracy report.
//!
//! Why every run says it: the figures move with the host as much as with the code. Mitsuba's
//! LLVM backend runs its wavefronts as wide as the CPU's vectors (16 lanes with AVX-512, 8 with
//! AVX2), Tessera traces one path at a time, so the same tracer gave a time-to-quality ratio of
//! 1.7–1.8 on a Zen 4 EPYC and 0.7–0.9 on a Zen 1 (docs/dev/performance-log.md, 2026-12-04),
//! and a profile-guided build renders 9–20 % faster than a plain one. A figure is comparable
//! only with others from the same CPU and build.

/// "host: <cpu>, <n> CPUs, <vectors>, <memory>; build: <kind>".
pub fn describe() -> String {
    format!("host: {}; build: {}", machine(), build())
}

/// The CPU (model, x86 family and model), logical CPUs, widest vectors and memory.
pub fn machine() -> String {
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let cpu = std::fs::read_to_string("/proc/cpuinfo").ok().and_then(|info| cpu_name(&info));
    let mem = std::fs::read_to_string("/proc/meminfo").ok().and_then(|info| memory_gib(&info));
    let mut s = format!(
        "{}, {cpus} CPUs, {}",
        cpu.unwrap_or_else(|| std::env::consts::ARCH.to_string()),
        vectors()
    );
    if let Some(gib) = mem {
        s += &format!(", {gib:.0} GiB");
    }
    s
}

/// How this binary was built: `profile-guided` when `deploy/build-pgo.sh` built it (it sets
/// `TESSERA_BUILD`), otherwise by its profile.
pub fn build() -> &'static str {
    match option_env!("TESSERA_BUILD") {
        Some(kind) => kind,
        None if cfg!(debug_assertions) => "debug assertions on (not for timing)",
        None => "release",
    }
}

/// "model name (x86_64 family F model M)" from the first processor of /proc/cpuinfo.
fn cpu_name(cpuinfo: &str) -> Option<String> {
    let field = |key: &str| {
        let line =
            cpuinfo.lines().find(|l| l.split(':').next().is_some_and(|k| k.trim() == key))?;
        Some(line.split_once(':')?.1.trim().to_string())
    };
    let name = field("model name")?;
    Some(match (field("cpu family"), field("model")) {
        (Some(family), Some(model)) => {
            format!("{name} ({} family {family} model {model})", std::env::consts::ARCH)
        }
        _ => name,
    })
}

fn memory_gib(meminfo: &str) -> Option<f64> {
    let kib: f64 = meminfo
        .lines()
        .find(|l| l.starts_with("MemTotal:"))?
        .split_whitespace()
        .nth(1)?
        .parse()
        .ok()?;
    Some(kib / 1024.0 / 1024.0)
}

/// The widest vector instructions this CPU runs, as Mitsuba's LLVM backend would pick them.
fn vectors() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx512f") {
            "AVX-512"
        } else if std::arch::is_x86_feature_detected!("avx2") {
            "AVX2 (no AVX-512)"
        } else {
            "SSE only (no AVX2)"
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        "vectors not probed on this architecture"
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const ZEN1: &str = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 23\nmodel\t\t: 1\n\
                        model name\t: AMD EPYC\nstepping\t: 2\n\nprocessor\t: 1\ncpu family\t: 25\n\
                        model\t\t: 17\nmodel name\t: other\n";

    #[test]
    fn names_the_first_processor_with_its_family_and_model() {
        let arch = std::env::consts::ARCH;
        assert_eq!(
            cpu_name(ZEN1).as_deref(),
            Some(format!("AMD EPYC ({arch} family 23 model 1)").as_str())
        );
    }

    #[test]
    fn model_name_alone_where_family_and_model_are_missing() {
        // ARM kernels have neither "cpu family" nor "model" lines; "model name" is enough.
        assert_eq!(
            cpu_name("processor\t: 0\nmodel name\t: ARMv8 Processor\n").as_deref(),
            Some("ARMv8 Processor")
        );
        assert_eq!(cpu_name("processor\t: 0\nBogoMIPS\t: 50.00\n"), None);
    }

    #[test]
    fn memory_in_gib() {
        assert_eq!(memory_gib("MemTotal:       25165824 kB\nMemFree: 1 kB\n"), Some(24.0));
        assert_eq!(memory_gib("MemFree: 1 kB\n"), None);
    }

    #[test]
    fn describes_this_machine_and_build() {
        let d = describe();
        assert!(d.starts_with("host: ") && d.contains(" CPUs, ") && d.contains("; build: "), "{d}");
    }
}
