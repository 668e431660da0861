# Sourced by the measurement scripts beside it: `start_farm BIN [WORK ARGS…]` starts `tessera
# serve` on a scratch data directory at a random loopback port and one `tessera work` beside it
# (with WORK ARGS), and sets `data`, `url`, `srv` (the coordinator's pid) and `wrk` (the
# worker's); both are stopped and the directory removed when the script exits.
start_farm() {
    local bin=$1
    shift
    data=$(mktemp -d)
    local port=$((20000 + RANDOM % 20000))
    url=http://127.0.0.1:$port
    "$bin" serve --listen 127.0.0.1:$port --data "$data/coordinator" >"$data/serve.log" 2>&1 &
    srv=$!
    wrk=
    trap 'kill $srv $wrk 2>/dev/null; wait 2>/dev/null; rm -rf "$data"' EXIT
    until "$bin" healthcheck --url "$url/healthz" >/dev/null 2>&1; do sleep 0.1; done
    "$bin" work --coordinator "$url" "$@" >"$data/work.log" 2>&1 &
    wrk=$!
}
