#!/usr/bin/env bash
# Builds the libFuzzer targets on the stable toolchain and runs each for SECONDS (default 60).
#   fuzz/run.sh [SECONDS] [TARGET...]
# cargo-fuzz is not needed: the coverage flags below are the ones it passes, and they are
# stable (only its default -Zsanitizer=address needs nightly; RUSTC_BOOTSTRAP=1 would allow it).
# Crashes land in fuzz/artifacts/<target>/; copy scene crashers to worker/tests/corpus/ (replayed
# by `cargo test -p tessera-worker the_crash_corpus`) once fixed.
set -euo pipefail
cd "$(dirname "$0")"
SECONDS_EACH=${1:-60}
shift || true
TARGETS=${*:-scene_parse sums_decode}
TRIPLE=x86_64-unknown-linux-gnu
export RUSTFLAGS="-Cpasses=sancov-module -Cllvm-args=-sanitizer-coverage-level=4 \
 -Cllvm-args=-sanitizer-coverage-inline-8bit-counters -Cllvm-args=-sanitizer-coverage-pc-table \
 -Cllvm-args=-sanitizer-coverage-trace-compares --cfg fuzzing -Cdebug-assertions -Coverflow-checks"
cargo build --release --bins --target "$TRIPLE"
mkdir -p corpus/scene_parse corpus/sums_decode
cp -n ../scenes/*.gltf ../worker/tests/corpus/*.bin corpus/scene_parse/ 2>/dev/null || true
# A valid 1×1 result (one sample, all sums 0) so the decoder's fuzzing starts past the header.
python3 -c "import struct,sys; sys.stdout.buffer.write(b'TSUM'+struct.pack('<HH6IQd7dQ',1,0,0,0,1,1,0,1,0,0.0,*[0.0]*7,1))" \
  > corpus/sums_decode/one-pixel
for t in $TARGETS; do
  mkdir -p "artifacts/$t"
  "target/$TRIPLE/release/$t" "corpus/$t" -max_total_time="$SECONDS_EACH" -max_len=65536 \
    -rss_limit_mb=2048 -artifact_prefix="artifacts/$t/" -print_final_stats=1
done
