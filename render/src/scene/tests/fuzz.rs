//! Fuzzing the scene loader with proptest: valid `.gltf` and `.glb` files mutated (bit flips,
//! truncation, splices, random insertions, and numbers in the JSON swapped for edge values such
//! as 4294967295 or -1 so counts, offsets and indices go out of range). Every mutant must load
//! or give a clean error — no panic, and no panic swallowed by the loader's `catch_unwind`
//! either (that message means a bounds check is missing). Bounded: a fixed number of cases
//! from a fixed seed, a few seconds in total. Crashers found are kept in `render/tests/corpus/`
//! and replayed by `the_crash_corpus_loads_or_fails_cleanly`.
use super::super::tests::triangle_gltf;
use super::super::*;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};

/// Where crashers are kept (the directory is replayed by a normal test).
fn corpus_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/corpus")
}

#[derive(Clone, Debug)]
enum Mutation {
    Flip(Index, u8),
    Truncate(Index),
    Splice { from: Index, to: Index, len: usize },
    Insert(Index, Vec<u8>),
    Number(Index, &'static str),
}

/// Values that break counts, offsets, strides, indices and enums when written over a number.
const EDGE_NUMBERS: &[&str] = &[
    "0",
    "-1",
    "1",
    "3",
    "4",
    "5",
    "255",
    "65535",
    "2147483648",
    "4294967295",
    "4294967296",
    "18446744073709551615",
    "1e39",
    "-0",
    "0.5",
    "5126",
    "34962",
    "99999999",
];

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<Index>(), 0u8..8).prop_map(|(i, b)| Mutation::Flip(i, b)),
        any::<Index>().prop_map(Mutation::Truncate),
        (any::<Index>(), any::<Index>(), 1usize..64).prop_map(|(from, to, len)| Mutation::Splice {
            from,
            to,
            len
        }),
        (any::<Index>(), prop::collection::vec(any::<u8>(), 1..16))
            .prop_map(|(i, b)| Mutation::Insert(i, b)),
        (any::<Index>(), prop::sample::select(EDGE_NUMBERS))
            .prop_map(|(i, n)| Mutation::Number(i, n)),
        (any::<Index>(), prop::sample::select(EDGE_NUMBERS))
            .prop_map(|(i, n)| Mutation::Number(i, n)),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    if bytes.is_empty() {
        return;
    }
    let n = bytes.len();
    match m {
        Mutation::Flip(i, bit) => bytes[i.index(n)] ^= 1 << bit,
        Mutation::Truncate(i) => bytes.truncate(i.index(n)),
        Mutation::Splice { from, to, len } => {
            let (from, to) = (from.index(n), to.index(n));
            let chunk: Vec<u8> = bytes[from..(from + len).min(n)].to_vec();
            let end = (to + chunk.len()).min(n);
            bytes[to..end].copy_from_slice(&chunk[..end - to]);
        }
        Mutation::Insert(i, extra) => {
            let at = i.index(n);
            bytes.splice(at..at, extra.iter().copied());
        }
        Mutation::Number(i, value) => {
            // The run of digits at or after the chosen position becomes `value`.
            let Some(start) = (i.index(n)..n).find(|&k| bytes[k].is_ascii_digit()) else { return };
            let end = (start..n).find(|&k| !bytes[k].is_ascii_digit()).unwrap_or(n);
            bytes.splice(start..end, value.bytes());
        }
    }
}

/// Loads `bytes` and judges the outcome: Ok(loaded or not), Err(description) when the loader
/// misbehaved.
pub(super) fn judge(bytes: &[u8]) -> Result<bool, String> {
    let outcome = std::panic::catch_unwind(|| load_bytes(bytes, None));
    match outcome {
        Err(_) => Err("the loader panicked".into()),
        Ok(Err(e)) if e.0.contains("the glTF reader failed") => {
            Err(format!("a panic was caught inside the loader: {e}"))
        }
        Ok(Err(e)) if e.0.is_empty() => Err("an empty error message".into()),
        Ok(Err(_)) => Ok(false),
        Ok(Ok(scene)) if scene.mesh.positions.iter().flatten().all(|p| p.is_finite()) => Ok(true),
        Ok(Ok(_)) => Err("a scene with non-finite vertices was accepted".into()),
    }
}

/// Wraps a glTF JSON whose single buffer is a data URI into a `.glb` with a binary chunk.
pub(super) fn to_glb(json: &str) -> Vec<u8> {
    use base64::Engine;
    let start = json.find("\"uri\":\"data:").expect("a data URI");
    let payload_at = start + json[start..].find(',').expect("comma") + 1;
    let payload_end = payload_at + json[payload_at..].find('"').expect("closing quote");
    let bin = base64::engine::general_purpose::STANDARD
        .decode(&json[payload_at..payload_end])
        .expect("base64");
    let json = format!("{}{}", &json[..start].trim_end_matches(','), &json[payload_end + 1..]);
    super::super::pack_glb(&json, &bin)
}

fn seeds() -> Vec<(&'static str, Vec<u8>)> {
    let cornell =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box.gltf"))
            .expect("bundled scene");
    let triangle = triangle_gltf(true, "");
    vec![
        ("triangle.gltf", triangle.clone().into_bytes()),
        ("triangle.glb", to_glb(&triangle)),
        ("cornell-box.gltf", cornell),
    ]
}

/// A stable name for a crasher file (SipHash with fixed keys).
fn digest(bytes: &[u8]) -> String {
    use std::hash::{Hash, Hasher};
    let mut h = std::hash::DefaultHasher::new();
    bytes.hash(&mut h);
    format!("{:016x}", h.finish())
}

/// Runs `cases` mutants of `seed`; on a failure the mutant is written to the corpus directory.
/// Returns how many mutants still loaded, and the time taken.
fn fuzz(name: &str, seed: &[u8], cases: u32) -> (u32, std::time::Duration) {
    assert_eq!(judge(seed), Ok(true), "{name}: the seed itself must load");
    let loaded = std::cell::Cell::new(0);
    let config =
        Config { cases, failure_persistence: None, max_shrink_iters: 256, ..Config::default() };
    let mut runner =
        TestRunner::new_with_rng(config, TestRng::deterministic_rng(RngAlgorithm::ChaCha));
    let t0 = std::time::Instant::now();
    let result = runner.run(&prop::collection::vec(mutation(), 1..4), |muts| {
        let mut bytes = seed.to_vec();
        muts.iter().for_each(|m| apply(&mut bytes, m));
        let verdict = judge(&bytes);
        loaded.set(loaded.get() + u32::from(verdict == Ok(true)));
        if let Err(why) = verdict {
            let path = corpus_dir().join(format!("{name}-{}.bin", digest(&bytes)));
            let _ =
                std::fs::create_dir_all(corpus_dir()).and_then(|_| std::fs::write(&path, &bytes));
            return Err(TestCaseError::fail(format!("{why}; kept as {}", path.display())));
        }
        Ok(())
    });
    if let Err(e) = result {
        panic!("{name}: {e}");
    }
    (loaded.get(), t0.elapsed())
}

#[test]
fn mutated_scenes_load_or_fail_cleanly() {
    // 15–70 µs per case in a test build: about 2 s over the three seeds.
    const CASES: u32 = 20_000;
    for (name, seed) in seeds() {
        let (loaded, took) = fuzz(name, &seed, CASES);
        eprintln!(
            "{name}: {CASES} mutants in {took:.2?} ({:.0}/s), {loaded} still loaded",
            CASES as f64 / took.as_secs_f64()
        );
    }
}

#[test]
fn the_crash_corpus_loads_or_fails_cleanly() {
    replay(&corpus_dir());
}

fn replay(dir: &Path) {
    let entries = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("the crash corpus {}: {e}", dir.display()));
    let mut n = 0;
    for e in entries.flatten().filter(|e| e.path().extension().is_some_and(|x| x == "bin")) {
        let bytes = std::fs::read(e.path()).expect("corpus file");
        if let Err(why) = judge(&bytes) {
            panic!("{}: {why}", e.path().display());
        }
        n += 1;
    }
    assert!(n > 0, "{} holds no crasher (*.bin) to replay", dir.display());
    eprintln!("{n} corpus files replayed");
}
