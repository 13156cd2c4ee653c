#!/usr/bin/env bash
# Builds palletd and runs the whole test suite. Installs what it needs on a Debian 12 machine.
#   scripts/test.sh                 # RelWithDebInfo build in build/
#   BUILD_DIR=build-asan CMAKE_ARGS="-DPALLETD_SANITIZE_ADDRESS=ON" scripts/test.sh
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"

"$here/scripts/install-deps.sh"

build_dir=${BUILD_DIR:-build}
jobs=${JOBS:-$(nproc)}
extra_args=()
if [[ -n "${CMAKE_ARGS:-}" ]]; then read -r -a extra_args <<<"$CMAKE_ARGS"; fi
if [[ "${CI:-}" == "true" ]]; then extra_args+=(-DPALLETD_WERROR=ON); fi

cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${extra_args[@]}" >/dev/null
cmake --build "$build_dir" -j "$jobs"
# The npm Modbus client the tests drive the handshake with (from the npm registry; cached).
if [[ ! -d "$build_dir/npm/node_modules/modbus-serial" ]]; then
  cmake --build "$build_dir" --target palletd_modbus_npm_deps >/dev/null
fi
ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" ${CTEST_ARGS:-}
