#!/usr/bin/env bash
# Builds palletd and runs the whole test suite. Installs what it needs on a Debian 12 machine.
#   scripts/test.sh                 # RelWithDebInfo build in build/ and the whole suite (developers)
#   CI=true scripts/test.sh         # every CI stage: release asan tsan fuzz (what .ci/run does)
#   PALLETD_CI_STAGES="asan" scripts/test.sh       # chosen stages only
#   BUILD_DIR=build-x CMAKE_ARGS="-D..." scripts/test.sh   # the release stage elsewhere / with options
# Stages (each its own build folder, docs/reliability.md "Sanitizers and fuzzing"):
#   release  -Werror build (CI) + whole suite                               build/
#   asan     clang ASan + UBSan (-O1, no benchmarks) + the suite but the soak build-asan/
#   tsan     ThreadSanitizer: daemon, service, Modbus and driver tests only build-tsan/
#            (not palletctl)
#   fuzz     libFuzzer targets, PALLETD_FUZZ_SECONDS each (30)              build-asan/
# Every stage builds each target in unity batches (PALLETD_UNITY_BUILD, on by default in
# CMakeLists.txt): about 60 % of the compile time of one source at a time.
# Every stage runs even when an earlier one failed; the exit status is non-zero if any failed.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"

"$here/scripts/install-deps.sh"

jobs=${JOBS:-$(nproc)}
stages=${PALLETD_CI_STAGES:-}
if [[ -z "$stages" ]]; then
  if [[ "${CI:-}" == "true" ]]; then stages="release asan tsan fuzz"; else stages="release"; fi
fi
werror=()
release_args=()
link_args=()
san_debug="-O1 -g"
if [[ "${CI:-}" == "true" ]]; then
  werror=(-DPALLETD_WERROR=ON)
  # CI keeps line tables only (enough for sanitizer reports and backtraces): full debug info
  # made every compile about a quarter slower.
  release_args=("-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O2 -g1 -DNDEBUG")
  san_debug="-O1 -g1"
fi
# lld links in a fraction of the time of the default linker (7 s against 1 s for palletctl).
if command -v ld.lld >/dev/null 2>&1; then
  link_args=(-DCMAKE_EXE_LINKER_FLAGS=-fuse-ld=lld -DCMAKE_SHARED_LINKER_FLAGS=-fuse-ld=lld
             -DCMAKE_MODULE_LINKER_FLAGS=-fuse-ld=lld)
fi
# Sanitizer builds: -O1 keeps them fast enough to build and run; no benchmarks.
san_args=(-G Ninja -DCMAKE_BUILD_TYPE=Debug "-DCMAKE_CXX_FLAGS_DEBUG=$san_debug" -DPALLETD_BUILD_BENCH=OFF
          "${link_args[@]}")

clang_cxx() { if command -v clang++-14 >/dev/null 2>&1; then echo clang++-14; else echo clang++; fi; }

npm_deps() {  # the npm Modbus client the tests drive the handshake with (npm registry; cached)
  if [[ ! -d "$1/npm/node_modules/modbus-serial" ]]; then
    cmake --build "$1" --target palletd_modbus_npm_deps >/dev/null || true
  fi
}

# Each stage's build folder (the fuzz stage uses the asan stage's).
stage_build_dir() {
  case "$1" in
    release) echo "${BUILD_DIR:-build}" ;;
    asan) echo "${BUILD_DIR_ASAN:-build-asan}" ;;
    tsan) echo "${BUILD_DIR_TSAN:-build-tsan}" ;;
    *) echo "" ;;
  esac
}

stage_release() {
  local build_dir
  build_dir=$(stage_build_dir release)
  local extra_args=()
  if [[ -n "${CMAKE_ARGS:-}" ]]; then read -r -a extra_args <<<"$CMAKE_ARGS"; fi
  cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo "${werror[@]}" "${release_args[@]}" \
    "${link_args[@]}" "${extra_args[@]}" >/dev/null || return 1
  cmake --build "$build_dir" -j "$jobs" || return 1
  npm_deps "$build_dir"
  rm -f "$build_dir/Testing/Temporary/LastTestsFailed.log"
  ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" ${CTEST_ARGS:-}
}

# ASan+UBSan with clang and the fuzzer's coverage instrumentation (PALLETD_BUILD_FUZZ): one build
# runs the whole suite and holds the fuzz targets, so the fuzz stage builds nothing more.
# Tests left out of the ASan+UBSan stage by name (ctest -E regex): none. The list held 14 known
# failures, each followed up (docs/reliability.md "Known ASan-stage failures", with what is still
# open): seeded scenes that depended on argument evaluation order, LeakSanitizer reports from
# OpenNI2's OniFile driver (kept loaded in the ASan test runtime; tests/sanitizers/lsan.supp), and
# time bounds that now scale with PALLETD_TEST_TIME_SCALE. PALLETD_ASAN_EXCLUDE='regex' leaves
# tests out for one run.
asan_exclude_default=''
asan_exclude=${PALLETD_ASAN_EXCLUDE-$asan_exclude_default}
# The 120 s soak (label soak) runs in the release stage only. It judges the daemon's resident
# memory, file descriptors and latency over two minutes, which under ASan are the sanitizer's (its
# quarantine holds freed memory back, every call is slower); memory errors under load are what the
# reliability tests (faults, restarts, 32 pollers, abuse) look for under ASan. Run alone, it took
# 124 s of the stage's 553 s of tests. PALLETD_ASAN_SKIP_LABELS='' runs it.
asan_skip_labels=${PALLETD_ASAN_SKIP_LABELS-soak}

stage_asan() {
  local build_dir
  build_dir=$(stage_build_dir asan)
  cmake -S . -B "$build_dir" "${san_args[@]}" -DCMAKE_CXX_COMPILER="$(clang_cxx)" -DPALLETD_BUILD_FUZZ=ON \
    -DPALLETD_BUILD_TESTS=ON >/dev/null || return 1
  cmake --build "$build_dir" -j "$jobs" || return 1
  npm_deps "$build_dir"
  rm -f "$build_dir/Testing/Temporary/LastTestsFailed.log"
  (
    # shellcheck source=tests/sanitizers/env.sh
    source tests/sanitizers/env.sh
    local filters=()
    if [[ -n "$asan_skip_labels" ]]; then filters+=(-LE "$asan_skip_labels"); fi
    if [[ -n "$asan_exclude" ]]; then
      echo "test.sh: asan stage leaves out (PALLETD_ASAN_EXCLUDE): $asan_exclude" >&2
      filters+=(-E "$asan_exclude")
    fi
    ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" "${filters[@]}" ${CTEST_ARGS:-}
  )
}

# The threaded parts: the daemon, the service, the Modbus server and its test server, and the
# camera drivers (Aravis, cloud replay, OpenNI2 with its test device and .oni playback;
# docs/reliability.md "Sanitizer results"). palletctl is not built: the three driver cases that
# run `palletctl grab` / `record` (one grab loop on the driver the other cases drive directly) are
# left out here and run in the release and asan stages; building palletctl took a quarter of the
# stage.
tsan_targets=(palletd palletd_daemon_tests palletd_service_tests palletd_modbus_tests
              palletd_modbus_test_server palletd_drivers_tests palletd_drivers_aravis_tests
              palletd_drivers_cloud_tests palletd_drivers_openni2_tests palletd_drivers_openni2_pairing_tests)
# Left out under TSan: the palletctl cases (not built here), and the whole-layer pick sequence
# (about 50 s under a sanitizer; its threads do what a trigger does, which the other service and
# daemon cases run here; it runs in the release and asan stages).
tsan_exclude='palletctl (grab|record)|pick check over Modbus'
tsan_tests='^(palletd_daemon_tests|palletd_service_tests|palletd_modbus_tests|palletd_drivers_tests|palletd_drivers_aravis_tests|palletd_drivers_cloud_tests|palletd_drivers_openni2_tests|palletd_drivers_openni2_pairing_tests):|^palletd_modbus_(pymodbus|npm)_handshake$'

stage_tsan() {
  local build_dir
  build_dir=$(stage_build_dir tsan)
  cmake -S . -B "$build_dir" "${san_args[@]}" "${werror[@]}" -DPALLETD_SANITIZE_THREAD=ON >/dev/null || return 1
  cmake --build "$build_dir" -j "$jobs" --target "${tsan_targets[@]}" || return 1
  npm_deps "$build_dir"
  rm -f "$build_dir/Testing/Temporary/LastTestsFailed.log"
  (
    source tests/sanitizers/env.sh
    ctest --test-dir "$build_dir" --output-on-failure -j "$jobs" -R "$tsan_tests" -E "$tsan_exclude" \
      ${CTEST_ARGS:-}
  )
}

stage_fuzz() {  # in the asan stage's build folder (built there already when that stage ran)
  FUZZ_BUILD_DIR=${FUZZ_BUILD_DIR:-$(stage_build_dir asan)} JOBS=$jobs \
    scripts/fuzz.sh "${PALLETD_FUZZ_SECONDS:-30}"
}

# What a failed stage's tests printed, at the end of the log where a CI summary that keeps only the
# tail still shows it: the names ctest lists as failed and the last lines each one printed.
report_failed_tests() {
  local log_dir=$1/Testing/Temporary
  [[ -s "$log_dir/LastTestsFailed.log" ]] || return 0
  echo "--- $2: failed tests ($1) ---" >&2
  cut -d: -f2- "$log_dir/LastTestsFailed.log" >&2
  [[ -f "$log_dir/LastTest.log" ]] || return 0
  cut -d: -f2- "$log_dir/LastTestsFailed.log" | head -n 3 | while IFS= read -r name; do
    echo "--- $name: last lines of its output ---" >&2
    awk -v name="$name" '
      $0 ~ /^[0-9]+\/[0-9]+ Test: / { sub(/^[0-9]+\/[0-9]+ Test: /, ""); on = ($0 == name); n = 0; next }
      on && /^<end of output>/ { on = 0 }
      on { lines[n++ % 30] = $0; total = n }
      END { s = total > 30 ? total - 30 : 0; for (i = s; i < total; i++) print lines[i % 30] }
    ' "$log_dir/LastTest.log" >&2
  done
}

failed=()
summary=()
# (set -e does not apply inside a function called from an `if`: each step says `|| return 1`.)
for stage in $stages; do
  case "$stage" in release|asan|tsan|fuzz) ;; *) echo "test.sh: unknown stage '$stage'" >&2; exit 2 ;; esac
  echo "=== stage $stage ===" >&2
  start=$SECONDS
  if "stage_$stage"; then result=ok; else result=FAILED; failed+=("$stage"); fi
  summary+=("$(printf '%-8s %-7s %5d s' "$stage" "$result" $((SECONDS - start)))")
done
if [[ ${#summary[@]} -gt 1 ]]; then
  echo "=== stages ===" >&2
  printf '%s\n' "${summary[@]}" >&2
fi
if [[ ${#failed[@]} -gt 0 ]]; then
  for stage in "${failed[@]}"; do
    dir=$(stage_build_dir "$stage")
    if [[ -n "$dir" ]]; then report_failed_tests "$dir" "$stage"; fi
  done
  echo "test.sh: failed stage(s): ${failed[*]}" >&2
  exit 1
fi
