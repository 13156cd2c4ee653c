#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz) with clang and runs each for N seconds on its corpus.
#   scripts/fuzz.sh                  # 60 s per target
#   scripts/fuzz.sh 3600 fuzz_modbus # one target for an hour
# Environment: FUZZ_BUILD_DIR (build-fuzz), FUZZ_WORK_DIR (<build dir>/fuzz-work: the corpus the
# fuzzer grows, crash files, logs), FUZZ_JOBS (parallel fuzzing processes per target, 1; the targets
# themselves run JOBS at a time),
# JOBS (build parallelism), CXX (clang++-14, else clang++), FUZZ_SKIP_BUILD=1.
# Exit status: 0 when no target found anything; 1 when one crashed, leaked, timed out or hit an
# oracle (the input is in FUZZ_WORK_DIR/crashes/, reproduce with `<target> <file>`).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cd "$here"

seconds=${1:-60}
shift || true
all_targets=(fuzz_modbus fuzz_frame_reader fuzz_config fuzz_detection)
targets=("$@")
[[ ${#targets[@]} -eq 0 ]] && targets=("${all_targets[@]}")

build_dir=${FUZZ_BUILD_DIR:-build-fuzz}
work=${FUZZ_WORK_DIR:-$build_dir/fuzz-work}
mkdir -p "$work"
work=$(cd "$work" && pwd)
jobs=${JOBS:-$(nproc)}
cxx=${CXX:-}
if [[ -z "$cxx" ]]; then
  if command -v clang++-14 >/dev/null 2>&1; then cxx=clang++-14; else cxx=clang++; fi
fi

if [[ "${FUZZ_SKIP_BUILD:-0}" != 1 ]]; then
  if [[ ! -f "$build_dir/CMakeCache.txt" ]]; then
    # A folder of its own: only the libraries the targets link (no tests, tools or daemon).
    cmake -S . -B "$build_dir" -G Ninja -DCMAKE_CXX_COMPILER="$cxx" -DPALLETD_BUILD_FUZZ=ON \
      -DPALLETD_BUILD_TESTS=OFF -DCMAKE_BUILD_TYPE=Debug -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g" >/dev/null
  elif ! grep -q '^PALLETD_BUILD_FUZZ:BOOL=ON' "$build_dir/CMakeCache.txt"; then
    echo "fuzz: $build_dir is not configured with PALLETD_BUILD_FUZZ=ON" >&2
    exit 2
  fi
  cmake --build "$build_dir" -j "$jobs" --target "${targets[@]}"
fi

export ASAN_OPTIONS="${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=1:symbolize=1}"
export UBSAN_OPTIONS="${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1:suppressions=$here/tests/sanitizers/ubsan.supp}"
export LSAN_OPTIONS="${LSAN_OPTIONS:-suppressions=$here/tests/sanitizers/lsan.supp:print_suppressions=0}"

# Per target: largest input, and the time one input may take before it counts as a hang [s].
declare -A max_len=([fuzz_modbus]=2048 [fuzz_frame_reader]=8192 [fuzz_config]=16384 [fuzz_detection]=256)
declare -A timeout=([fuzz_modbus]=30 [fuzz_frame_reader]=30 [fuzz_config]=30 [fuzz_detection]=60)

# One target: runs it and writes its table row to $work/logs/$t.row (FAILED when it found something).
fuzz_one() {
  local t=$1 exe="$build_dir/tests/fuzz/$1"
  [[ -x "$exe" ]] || { echo "fuzz: $exe not built" >&2; return; }
  mkdir -p "$work/corpus/$t" "$work/crashes" "$work/logs"
  local log="$work/logs/$t.log"
  # New finds go to the work corpus (first folder); the committed seeds are only read.
  local parallel=()
  if [[ "${FUZZ_JOBS:-1}" != 1 ]]; then  # -fork: N processes share one corpus, one log
    parallel=(-fork="$FUZZ_JOBS" -ignore_crashes=0 -ignore_timeouts=0 -ignore_ooms=0)
  fi
  local started=$SECONDS rc
  set +e
  "$exe" "$work/corpus/$t" "$here/tests/fuzz/corpus/$t" \
    -max_total_time="$seconds" -max_len="${max_len[$t]}" -timeout="${timeout[$t]}" \
    -rss_limit_mb=2048 -print_final_stats=1 "${parallel[@]}" \
    -artifact_prefix="$work/crashes/$t-" >"$log" 2>&1
  rc=$?
  set -e
  local elapsed=$((SECONDS - started)) execs rate cov ft result=ok
  # Plain runs end with -print_final_stats lines; -fork runs only with "#N: cov: .. ft: .." lines.
  execs=$( (grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" || true) | awk '{s+=$2} END{print s+0}')
  rate=$( (grep -o 'stat::average_exec_per_sec: *[0-9]*' "$log" || true) | awk '{s+=$2} END{print s+0}')
  if [[ "$execs" == 0 ]]; then
    execs=$( (grep -oE '^#[0-9]+' "$log" || true) | tail -n 1 | tr -d '#')
    execs=${execs:-0}
    rate=$(( elapsed > 0 ? execs / elapsed : 0 ))
  fi
  cov=$( (grep -o 'cov: [0-9]*' "$log" || true) | tail -n 1 | awk '{print $2}')
  ft=$( (grep -o 'ft: [0-9]*' "$log" || true) | tail -n 1 | awk '{print $2}')
  if [[ $rc -ne 0 ]]; then
    result="FAILED (rc $rc, see $log)"
    grep -m 5 -E 'ERROR:|fuzz oracle:|SUMMARY:|Test unit written' "$log" >&2 || true
  fi
  printf '%-18s %8s %10s %8s %8s %8s  %s\n' "$t" "$elapsed" "${execs:-0}" "${rate:-0}" "${cov:--}" "${ft:--}" \
    "$result" >"$work/logs/$t.row"
}

# The targets run $jobs at a time (each fuzzer is one process on one core); a target whose row is
# missing or says FAILED fails the run.
failed=0
for t in "${targets[@]}"; do
  while [[ $(jobs -rp | wc -l) -ge $jobs ]]; do wait -n || true; done
  rm -f "$work/logs/$t.row"
  fuzz_one "$t" &
done
wait || true
printf '%-18s %8s %10s %8s %8s %8s  %s\n' target seconds execs exec/s cov ft result
for t in "${targets[@]}"; do
  row="$work/logs/$t.row"
  if [[ ! -s "$row" ]] || grep -q FAILED "$row"; then failed=1; fi
  cat "$row" 2>/dev/null || printf '%-18s  no result (see %s)\n' "$t" "$work/logs/$t.log"
done
exit $failed
