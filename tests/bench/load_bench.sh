#!/usr/bin/env bash
# Load benchmark (issues 9 and 20): trigger-to-ResultReady latency of the PLC's handshake (trigger
# every 200 ms, replay of the bundled frames, recipe 6 with its five formats), first idle, then
# with 32 clients polling the status and result blocks at 100 Hz each and FLOODERS clients opening
# 50 connections a second each, every one with a malformed or illegal request, in one run of one
# daemon. Prints p50/p99 of both and the p99 ratio; exits 1 when the ratio exceeds 1.5 (issue 9's
# bound) or a handshake or poll failed.
#   tests/bench/load_bench.sh [BUILD_DIR] [TRIGGERS=200] [POLLERS=32] [FLOODERS=4]
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=${1:-$here/build}
n=${2:-200}
pollers=${3:-32}
flooders=${4:-4}
port=$((20000 + RANDOM % 20000))
dir=$(mktemp -d /tmp/palletd-load-bench.XXXXXX)
{
  sed -n '/^formats:/,/^modbus:/p' "$here/config/demo.yaml" | sed '$d'
  printf 'camera:\n  driver: replay\n  replay:\n    directory: %s\n' "$here/tests/data"
  printf 'modbus:\n  bind_address: 127.0.0.1\n  port: %s\n  max_connections: 48\n' "$port"
  printf 'pipeline:\n  default_recipe: 6\nlogging:\n  level: warn\n'
} >"$dir/bench.yaml"
"$build/src/palletd/palletd" --config "$dir/bench.yaml" >"$dir/palletd.log" 2>&1 &
pid=$!
trap 'kill "$pid" 2>/dev/null; wait "$pid" 2>/dev/null || true; rm -rf "$dir"' EXIT
for _ in $(seq 100); do (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null && break; sleep 0.1; done
load=$build/tests/reliability/palletd_plc_load
"$load" --port "$port" --triggers 22 --period-ms 200 --duration-s 60 >/dev/null  # warm-up: each frame once
idle=$("$load" --port "$port" --triggers "$n" --period-ms 200 --duration-s 3600 | tail -1)
busy=$("$load" --port "$port" --triggers "$n" --period-ms 200 --pollers "$pollers" --poll-hz 100 \
  --flooders "$flooders" --flood-hz 50 --duration-s 3600 | tail -1)
echo "idle:   $idle"
echo "loaded: $busy"
p99() { sed -n 's/.* p99=\([0-9.]*\) ms.*/\1/p' <<<"$1"; }
ratio=$(awk -v a="$(p99 "$idle")" -v b="$(p99 "$busy")" 'BEGIN{printf "%.2f", b/a}')
echo "p99 loaded / idle = $ratio (bound 1.5)"
fails=$(sed -n 's/.*handshakes_failed=\([0-9]*\).*poll_errors=\([0-9]*\).*/\1 \2/p' <<<"$busy")
[[ $fails == "0 0" ]] || { echo "FAIL: failed handshakes / unanswered polls: $fails"; exit 1; }
awk -v r="$ratio" 'BEGIN{exit !(r <= 1.5)}' || { echo "FAIL: p99 ratio $ratio > 1.5"; exit 1; }
echo PASS
