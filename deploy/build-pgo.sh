#!/usr/bin/env bash
# Builds `tessera` with profile-guided optimisation (PGO), for the machines of a farm.
#
# Usage: deploy/build-pgo.sh [--static] [--bench] | --check
#   --static  link statically (glibc, crt-static), as the container image needs (make image)
#   --bench   also build tessera-bench from the same profile, to measure the build
#             (docs/performance.md); its obvhs comparison is trained as much as our code
#   --check   build nothing: exit 0 if the llvm-profdata it needs is here, else say what to
#             install and exit 1 (make image's PGO=auto asks this first)
#
# Four steps, as rustc's book describes them: an instrumented build, a training run (every
# bundled scene rendered small, through the in-process coordinator and worker, so the HTTP and
# merge paths are trained too), llvm-profdata merging the counts, and the optimised build.
# Everything goes under ${CARGO_TARGET_DIR:-target}/pgo (pgo-static with --static); the plain
# `cargo build --release` is left alone. Progress goes to stderr; the binary's path, alone, to stdout.
#
# Why: the render loop's branches and calls are laid out and inlined by what the training
# renders did, not by guesses; that makes the Cornell box render 12-20 % faster and other
# scenes up to 16 % (docs/dev/performance-log.md, 2026-12-04). Floating-point results do not change
# (rustc enables no fast-math, and PGO changes no operation), so the build keeps the renderer
# id and the bits of a plain build. The script checks that: the optimised binary renders every
# training scene again and must give the instrumented build's pixel digests, or it fails.
#
# Needs llvm-profdata of the LLVM that rustc uses (`rustc -vV`, "LLVM version"): from
# `rustup component add llvm-tools`, or a distribution's package (Debian: llvm-22 for LLVM 22).
set -euo pipefail
cd "$(dirname "$0")/.."

static="" bench="" check=""
for arg in "$@"; do
    case "$arg" in
        --static) static=1 ;;
        --bench) bench=1 ;;
        --check) check=1 ;;
        -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "$0"; exit 0 ;;
        *) echo "error: unknown argument $arg (see --help)" >&2; exit 2 ;;
    esac
done

cargo="${CARGO:-cargo}"
host=$(rustc -vV | sed -n 's/^host: //p')
llvm_major=$(rustc -vV | sed -n 's/^LLVM version: \([0-9]*\).*/\1/p')

# The first llvm-profdata of rustc's LLVM major version: a newer one writes profiles rustc may
# not read, an older one cannot read rustc's raw profiles.
find_profdata() {
    local sysroot candidates c
    sysroot=$(rustc --print sysroot)
    candidates=("$sysroot/lib/rustlib/$host/bin/llvm-profdata" "llvm-profdata-$llvm_major"
                "/usr/lib/llvm-$llvm_major/bin/llvm-profdata" "llvm-profdata")
    for c in "${candidates[@]}"; do
        if command -v "$c" >/dev/null 2>&1 && "$c" --version 2>/dev/null | grep -q "LLVM version $llvm_major\."; then
            command -v "$c"
            return
        fi
    done
    echo "error: no llvm-profdata of LLVM $llvm_major (rustc's) found; install one with" >&2
    echo "  rustup component add llvm-tools      or      apt-get install llvm-$llvm_major" >&2
    exit 1
}
profdata=$(find_profdata)
if [[ -n "$check" ]]; then
    echo "llvm-profdata of LLVM $llvm_major: $profdata" >&2
    exit 0
fi

# Static and dynamic builds differ in every crate's flags: apart, neither rebuilds the other.
root="${CARGO_TARGET_DIR:-target}/pgo${static:+-static}"
root=$(mkdir -p "$root" && cd "$root" && pwd)
raw="$root/profiles"
work="$root/training"
rm -rf "$raw" "$work"
mkdir -p "$raw" "$work"

flags="${RUSTFLAGS:-}"
[[ -n "$static" ]] && flags="$flags -C target-feature=+crt-static"
bins=(--bin tessera)
[[ -n "$bench" ]] && bins+=(--bin tessera-bench)

# An explicit --target keeps RUSTFLAGS off build scripts and proc macros: only the shipped code
# is instrumented and optimised. TESSERA_BUILD is the build kind benchmarks print beside their
# figures (tessera-bench's "build:" line); both builds get it, so their sources stay the same.
build() { # target-dir extra-flags
    TESSERA_BUILD=profile-guided RUSTFLAGS="$flags $2" "$cargo" build --release --target "$host" --target-dir "$1" -p tessera-server "${bins[@]}"
}

echo "== 1/4 instrumented build (LLVM $llvm_major, $profdata)" >&2
build "$root/generate" "-C profile-generate=$raw"

# Renders every bundled scene and writes "scene digest" lines to $2.
render_all() { # binary digests-file
    local scene out digest args
    : > "$2"
    for scene in scenes/*.gltf; do
        scene=$(basename "$scene" .gltf)
        args=(--width 128 --height 128 --spp 16)
        [[ "$scene" == cornell-animated ]] && args+=(--frames 0..2)
        out=$("$1" render "$scene" "${args[@]}" -o "$work/$scene.exr")
        digest=$(sed -n 's/^pixels sha256: //p' <<<"$out")
        [[ -n "$digest" ]] || { echo "error: $1 printed no pixel digest for $scene" >&2; exit 1; }
        echo "$scene $digest" >> "$2"
    done
}

echo "== 2/4 training: every bundled scene, 128x128 at 16 spp" >&2
gen="$root/generate/$host/release"
render_all "$gen/tessera" "$work/instrumented.digests"
if [[ -n "$bench" ]]; then
    "$gen/tessera-bench" bvh --scene cornell-box --rounds 1 >/dev/null
    "$gen/tessera-bench" bvh --triangles 200000 --rays 200000 --rounds 1 >/dev/null
fi

echo "== 3/4 merging the profiles" >&2
"$profdata" merge -o "$root/tessera.profdata" "$raw"

echo "== 4/4 optimised build" >&2
build "$root/use" "-C profile-use=$root/tessera.profdata"

out="$root/use/$host/release"
render_all "$out/tessera" "$work/optimised.digests"
if ! diff "$work/instrumented.digests" "$work/optimised.digests" >&2; then
    echo "error: the optimised build renders different pixels from the instrumented one (above);" >&2
    echo "       do not mix it into a farm with plain builds of this source" >&2
    exit 1
fi
echo "the optimised build renders the $(wc -l < "$work/optimised.digests") bundled scenes to the same bits as the instrumented build" >&2
echo "$out/tessera"
