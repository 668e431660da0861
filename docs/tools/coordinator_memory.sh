#!/usr/bin/env bash
# The coordinator's resident memory as jobs end: starts `tessera serve` on a scratch data
# directory and one `tessera work` beside it, submits jobs one after another (--wait), and prints
# the coordinator's VmRSS (now) and VmHWM (peak) from /proc two seconds after each job ends
# (mimalloc, the coordinator's allocator, keeps freed pages for a second before it returns them).
#
#   docs/tools/coordinator_memory.sh BIN stills N WxH     N jobs of the Cornell box, 1 spp each
#   docs/tools/coordinator_memory.sh BIN frames N WxH     one job of N frames of cornell-animated, 1 spp
#
# BIN is a tessera binary (e.g. target/release/tessera); run it for two builds to compare them.
set -euo pipefail
bin=$1 mode=$2 n=$3 size=$4
w=${size%x*} h=${size#*x}
. "$(dirname "$0")/farm.sh"
start_farm "$bin"
memory() { awk '/VmRSS|VmHWM/ { printf "%s %5d MiB   ", $1, $2 / 1024 }' "/proc/$srv/status"; }
echo "coordinator after start:  $(memory)"
case $mode in
stills)
    for i in $(seq 1 "$n"); do
        "$bin" submit cornell-box --server "$url" --spp 1 --width "$w" --height "$h" --wait >/dev/null
        sleep 2
        echo "after job $i of $n ($w×$h): $(memory)"
    done
    ;;
frames)
    "$bin" submit cornell-animated --server "$url" --spp 1 --width "$w" --height "$h" --frames "0..$((n - 1))" --wait >/dev/null
    sleep 2
    echo "after $n frames of $w×$h: $(memory)"
    ;;
*) echo "mode is stills or frames" >&2; exit 2 ;;
esac
