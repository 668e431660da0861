//! `tessera render`, as a user runs it: a real process writing real files.
use crate::harness::{temp_dir, tessera_bin};
use std::process::Command;
use tessera_server::output::{MetaValue, decode_exr};

#[test]
fn render_writes_an_exr_with_every_layer_and_a_preview() {
    let dir = temp_dir("render");
    let (exr, png) = (dir.join("cb.exr"), dir.join("cb.png"));
    let out = Command::new(tessera_bin())
        .args([
            "render",
            "cornell-box",
            "--spp",
            "8",
            "--width",
            "48",
            "--height",
            "32",
            "--seed",
            "3",
            "-o",
        ])
        .arg(&exr)
        .arg("--preview")
        .arg(&png)
        .output()
        .expect("run tessera");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("samples/s"), "prints throughput: {stdout}");
    assert!(
        stdout.contains("scene load + BVH build"),
        "prints what preparing the scene cost: {stdout}"
    );
    let (img, meta) = decode_exr(&std::fs::read(&exr).unwrap()).unwrap();
    let digest = tessera_server::output::files_digest(std::slice::from_ref(&exr)).unwrap();
    assert_eq!(
        stdout.lines().last(),
        Some(format!("pixels sha256: {digest}").as_str()),
        "ends with the pixels' digest"
    );
    assert_eq!((img.width, img.height), (48, 32));
    assert!(img.samples.iter().all(|&s| s == 8.0));
    assert!(img.rgb.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
    assert!(img.rgb.iter().map(|p| p[0]).sum::<f32>() > 0.0, "the box is lit");
    assert!(img.variance.iter().flatten().any(|&v| v > 0.0));
    let get = |k: &str| meta.iter().find(|(n, _)| n == k).map(|(_, v)| v.clone());
    assert_eq!(get("tessera.spp"), Some(MetaValue::Double(8.0)));
    assert!(matches!(get("tessera.estimator"), Some(MetaValue::Text(ref s)) if s == "mis"));
    // `auto`, settled when the job was accepted: the Cornell box's one quad is chosen by power.
    assert!(matches!(get("tessera.light_sampler"), Some(MetaValue::Text(ref s)) if s == "power"));
    assert!(get("tessera.render_time_s").is_some());
    assert_eq!(
        get("tessera.renderers"),
        Some(MetaValue::Text(renderer_id(None))),
        "the one renderer, as `--version` names it"
    );
    let preview = image::open(&png).expect("preview decodes");
    assert_eq!((preview.width(), preview.height()), (48, 32));
}

#[test]
fn render_refuses_bad_arguments_with_a_clear_message() {
    let cases: [(&[&str], &str); 5] = [
        (&["render", "no-such-scene"], "neither a file nor a bundled scene"),
        (&["render", "cornell-box", "--estimator", "magic"], "unknown estimator"),
        (&["render", "cornell-box", "--light-sampler", "bvh"], "unknown light sampler"),
        (&["render", "cornell-box", "--spp", "0"], "spp must be in 1..="),
        (&["render", "cornell-box", "--camera", "Nope"], "no camera named"),
    ];
    for (args, expect) in cases {
        let out = Command::new(tessera_bin()).args(args).output().expect("run tessera");
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(expect), "{args:?}: {err}");
    }
}

/// A worker on a CPU without AVX2 or FMA renders the same bits as one with them. glibc picks its
/// libm variants (`sincosf`, `expf`, `logf`, `powf`, …) by CPU at run time, and its FMA variants
/// may round differently (its `powf` does, in 3 of 67 M arguments here); were the tracer's results
/// to depend on that choice, a farm of mixed machines would merge images that depend on who
/// rendered what. `GLIBC_TUNABLES` hides AVX2 and FMA from this process's glibc, which then takes
/// its SSE2 variants (names for glibc ≥ 2.33 and before; a glibc that knows neither takes the same
/// variants twice, and the test checks nothing new there).
const WITHOUT_FMA: &str = "glibc.cpu.hwcaps=-AVX2_Usable,-FMA_Usable,-FMA4_Usable,-AVX2,-FMA,-FMA4";

/// The renderer id `tessera --version` prints, with the given `GLIBC_TUNABLES` (None: unset).
fn renderer_id(tunables: Option<&str>) -> String {
    let mut command = Command::new(tessera_bin());
    command.arg("--version");
    match tunables {
        Some(t) => command.env("GLIBC_TUNABLES", t),
        None => command.env_remove("GLIBC_TUNABLES"),
    };
    let out = command.output().expect("run tessera --version");
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let id = text
        .lines()
        .find_map(|l| l.strip_prefix("renderer: "))
        .unwrap_or_else(|| panic!("no renderer line in {text:?}"));
    id.to_string()
}

/// Workers register with a renderer id whose `libm:` part probes their libm, and the coordinator
/// keeps a job on one id: CPUs whose libm variants give the same images must get the same id, or
/// a mixed farm would be split for nothing.
#[test]
fn a_cpu_without_avx2_or_fma_has_the_same_renderer_id() {
    let native = renderer_id(None);
    assert!(native.contains(" libm:"), "{native}");
    assert_eq!(native, renderer_id(Some(WITHOUT_FMA)));
}

#[test]
fn a_cpu_without_avx2_or_fma_renders_the_same_bits() {
    let dir = temp_dir("cpu-variants");
    // Sine and cosine (diffuse and GGX warps, the lens), exp (absorption), log and exp (the Phong
    // lobe), pow (sRGB textures, decoded at load).
    for scene in ["cornell-box", "glossy", "absorption", "phong", "textured", "depth-of-field"] {
        let render = |tunables: Option<&str>| {
            let exr = dir.join(format!(
                "{scene}-{}.exr",
                if tunables.is_some() { "sse2" } else { "native" }
            ));
            let mut command = Command::new(tessera_bin());
            command
                .args(["render", scene, "--spp", "4", "--width", "64", "--height", "64", "-o"])
                .arg(&exr);
            match tunables {
                Some(t) => command.env("GLIBC_TUNABLES", t),
                None => command.env_remove("GLIBC_TUNABLES"),
            };
            let out = command.output().expect("run tessera");
            assert!(out.status.success(), "{scene}: {}", String::from_utf8_lossy(&out.stderr));
            let (img, _) = decode_exr(&std::fs::read(&exr).unwrap()).unwrap();
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<u32>>();
            (bits(img.rgb.as_flattened()), bits(img.variance.as_flattened()), bits(&img.samples))
        };
        assert!(
            render(None) == render(Some(WITHOUT_FMA)),
            "{scene}: the image depends on the CPU's libm variants"
        );
    }
}

/// Runs `command` with its standard output a pipe whose reader is already gone, as in
/// `tessera render … | head -0`: every line it prints meets a broken pipe.
fn with_stdout_closed(mut command: Command) -> std::process::Output {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    command.stdout(writer).output().expect("run")
}

#[test]
fn a_reader_that_has_gone_ends_render_and_bench_without_a_panic() {
    let dir = temp_dir("closed-stdout");
    let mut render = Command::new(tessera_bin());
    render
        .args(["render", "cornell-box", "--spp", "1", "--width", "16", "--height", "16", "-o"])
        .arg(dir.join("cb.exr"));
    let mut bench = Command::new(crate::harness::tessera_bench_bin());
    bench.args(["effects", "--size", "8", "--spp", "1", "--repeats", "1"]);
    for (name, command) in [("tessera render", render), ("tessera-bench effects", bench)] {
        let out = with_stdout_closed(command);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success() && !err.contains("panicked"),
            "{name}: {:?}\n{err}",
            out.status
        );
    }
    assert!(dir.join("cb.exr").exists(), "the render's file is written before its result lines");
}

#[test]
fn a_bench_whose_reader_goes_mid_study_leaves_no_scratch_dir() {
    use std::io::BufRead;
    let mut child = Command::new(crate::harness::tessera_bench_bin())
        .args(["roundtrips", "--seconds", "0.5", "--workers", "2"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("run tessera-bench");
    // The host line comes before the study's coordinator (and its data directory) starts; the
    // reader goes after it, as `| head -1` would, so the study's first figure meets a closed pipe.
    let mut first = String::new();
    std::io::BufReader::new(child.stdout.take().unwrap())
        .read_line(&mut first)
        .expect("first line");
    assert!(first.starts_with("host: "), "{first}");
    let scratch = std::env::temp_dir().join(format!("tessera-bench-rt-{}", child.id()));
    let out = child.wait_with_output().expect("wait");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success() && !err.contains("panicked"), "{:?}\n{err}", out.status);
    assert!(!scratch.exists(), "{} left behind", scratch.display());
}
