#!/usr/bin/env bash
# An animation's frame preparations on a farm of two processes, as users run one: starts
# `tessera serve` on a scratch data directory and one `tessera work` beside it, submits one job of
# N frames of SCENE (1 spp, so the frames' preparation is most of the time), and prints the
# job's wall time, each kind of preparation the worker reported (builds, refits, their median
# milliseconds per frame) and the worker's peak resident memory.
#
#   docs/tools/refit_frames.sh BIN SCENE N [WxH] [THREADS]
#
# BIN is a tessera binary (e.g. target/release/tessera); SCENE an animated .glb, e.g. the sliding
# 1M-triangle field of `tessera-bench field --sliding -o slide.glb`. Run it for two builds,
# alternated, to compare them.
set -euo pipefail
bin=$1 scene=$2 n=$3 size=${4:-32x32} threads=${5:-0}
w=${size%x*} h=${size#*x}
. "$(dirname "$0")/farm.sh"
start_farm "$bin" --threads "$threads"
start=$(date +%s.%N)
"$bin" submit "$scene" --server "$url" --spp 1 --width "$w" --height "$h" --tile-size 64 --frames "0..$((n - 1))" --wait >/dev/null
end=$(date +%s.%N)
curl -s "$url/v1/jobs" | python3 -c '
import json, statistics, sys
job = json.load(sys.stdin)
job = job[0] if isinstance(job, list) else job["jobs"][0]
frames = job["frames"]
refits = [f["prepare_ms"] / f["refits"] for f in frames if f["builds"] == 0 and f["refits"] > 0]
builds = [f["prepare_ms"] for f in frames if f["builds"] > 0]
peak = max((f["worker_peak_rss_bytes"] or 0) for f in frames) >> 20
print(f"{len(frames)} frames in {float(sys.argv[1]):.2f} s; {len(builds)} frames built (median {statistics.median(builds) if builds else 0:.0f} ms), "
      f"{len(refits)} refitted (median {statistics.median(refits) if refits else 0:.1f} ms); worker peak resident {peak} MiB")
' "$(echo "$end - $start" | bc)"
