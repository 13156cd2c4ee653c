#!/usr/bin/env bash
# The main job on bundled data, no camera needed: palletd runs in replay mode on the simulated
# frames in tests/data, and `palletctl trigger` plays the PLC: for each frame it does the Modbus
# TCP trigger handshake and prints the box poses exactly as a PLC reads them from the registers.
# Installs what it needs on a Debian 12 machine.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"

"$here/scripts/install-deps.sh"
build_dir=${BUILD_DIR:-build}
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null
cmake --build "$build_dir" -j "$(nproc)" --target palletd palletctl

port=${PORT:-1502}
log=$(mktemp /tmp/palletd-demo.XXXXXX.log)
"$build_dir/src/palletd/palletd" --config config/demo.yaml --replay tests/data --port "$port" >"$log" 2>&1 &
daemon=$!
trap 'kill "$daemon" 2>/dev/null; wait "$daemon" 2>/dev/null || true' EXIT
for _ in $(seq 100); do
  if grep -q "palletd ready" "$log"; then break; fi
  if ! kill -0 "$daemon" 2>/dev/null; then cat "$log" >&2; exit 1; fi
  sleep 0.1
done
echo "palletd is serving Modbus TCP on 127.0.0.1:$port and its status page on http://127.0.0.1:8080/ (log: $log)"

# The PLC knows the product on the pallet: the recipe of each bundled frame (config/demo.yaml).
recipe_for() {
  case "$1" in
    *mixed_600x400_400x300*) echo 7 ;;
    *600x400*) echo 1 ;;
    *400x300*) echo 2 ;;
    *300x200*) echo 3 ;;
    *315x232*) echo 4 ;;
    *200x150*) echo 5 ;;
    *) echo 6 ;;
  esac
}
request=1
for depth in tests/data/*.depth.png; do
  stem=$(basename "$depth" .depth.png)
  recipe=$(recipe_for "$stem")
  echo
  echo "== frame $stem, recipe $recipe"
  "$build_dir/src/palletctl/palletctl" trigger --host 127.0.0.1 --port "$port" --recipe "$recipe" \
    --request-id "$request" --log-level warn || true
  request=$((request + 1))
done
