#!/usr/bin/env bash
# Builds the container image: a static `tessera` (glibc, crt-static) copied into FROM scratch.
# Usage: deploy/build-image.sh [TAG]   (default tessera:latest; prints the tag and the size)
#        PGO=1 deploy/build-image.sh [TAG]   the binary from deploy/build-pgo.sh --static instead
#        (renders up to 20 % faster, same bits; needs llvm-profdata, takes two builds and a training run)
#        PGO=auto   the profile-guided binary where llvm-profdata is here, else the plain one with
#        a note saying what to install (`make image` passes auto; PGO=0, the default here, is plain)
# Works offline on an engine with no images. Re-running reuses the cargo build
# (target/x86_64-unknown-linux-gnu/release), so it is quick when nothing changed.
set -euo pipefail
cd "$(dirname "$0")/.."
tag="${1:-tessera:latest}"
target=x86_64-unknown-linux-gnu
# RUSTFLAGS with an explicit --target applies to the binary only, not to build scripts and
# proc macros (which must stay dynamic).
pgo="${PGO:-0}"
case "$pgo" in
    0|1) ;;
    auto)
        if missing=$(deploy/build-pgo.sh --check 2>&1); then
            pgo=1
        else
            echo "note: building the plain binary; the profile-guided one renders up to 20 % faster with the same bits." >&2
            sed 's/^error: //; s/^ */      /' <<<"$missing" >&2
            pgo=0
        fi ;;
    *) echo "error: PGO=$pgo: expected 0, 1 or auto" >&2; exit 2 ;;
esac
if [[ "$pgo" == 1 ]]; then
    bin=$(deploy/build-pgo.sh --static)
else
    RUSTFLAGS="-C target-feature=+crt-static" "${CARGO:-cargo}" build --release --target "$target" -p tessera-server --bin tessera
    bin="${CARGO_TARGET_DIR:-target}/$target/release/tessera"
fi
linkage=$(ldd "$bin" 2>&1 || true)
if [[ "$linkage" != *"not a dynamic executable"* && "$linkage" != *"statically linked"* ]]; then
    echo "error: $bin is not statically linked: $linkage" >&2
    exit 1
fi
context=$(mktemp -d)
trap 'rm -rf "$context"' EXIT
# Line tables stay in target/ for backtraces; the image gets the stripped binary.
strip -o "$context/tessera" "$bin" 2>/dev/null || cp "$bin" "$context/tessera"
mkdir -p "$context/data" "$context/tmp"
chmod 1777 "$context/tmp"
# The legacy builder needs nothing but the engine (no buildx here); BuildKit works too.
DOCKER_BUILDKIT="${DOCKER_BUILDKIT:-0}" docker build -q -f Dockerfile -t "$tag" "$context" >/dev/null
size=$(docker image inspect -f '{{.Size}}' "$tag")
echo "$tag $size bytes ($((size / 1024 / 1024)) MiB)"
