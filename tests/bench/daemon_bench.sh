#!/usr/bin/env bash
# Daemon benchmark (issue 6): trigger-to-ResultReady latency over N triggers with the replay driver,
# and the daemon's resident memory before and after M triggers (must stay flat).
#   tests/bench/daemon_bench.sh [BUILD_DIR] [N=1000] [M=10000]
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${1:-$here/build}
n=${2:-1000}
m=${3:-10000}
port=$((20000 + RANDOM % 20000))
web=$((port + 1))
log=$(mktemp /tmp/palletd-bench.XXXXXX.log)
"$build/src/palletd/palletd" --config "$here/config/demo.yaml" --replay "$here/tests/data" --port "$port" \
  --web-port "$web" >"$log" 2>&1 &
pid=$!
trap 'kill "$pid" 2>/dev/null; wait "$pid" 2>/dev/null || true' EXIT
for _ in $(seq 100); do grep -q "palletd ready" "$log" && break; sleep 0.1; done
rss() { awk '/VmRSS/ {print $2}' "/proc/$pid/status"; }
trigger() { "$build/src/palletctl/palletctl" trigger --port "$port" --recipe 6 -n "$1" --quiet --log-level off || true; }

echo "latency over $n triggers (recipe 6, all bundled frames in turn):"
trigger "$n"
trigger 100 >/dev/null
rss_start=$(rss)
echo "memory: RSS after warm-up ${rss_start} kB; running $m more triggers ..."
trigger "$m" | tail -1
rss_end=$(rss)
echo "memory: RSS after $m triggers ${rss_end} kB (change $((rss_end - rss_start)) kB)"
