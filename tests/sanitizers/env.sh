# Sourced by scripts/test.sh and scripts/fuzz.sh: the sanitizer runtime options for tests.
# halt/abort on the first report so a test fails (exit code != 0) on any report; suppression files
# beside this one (third-party code only).
san_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# detect_leaks: python/node children are not instrumented (ASAN_OPTIONS is harmless to them);
# our own children (palletd, palletctl, the Modbus test server) are checked like the tests.
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:abort_on_error=0:detect_stack_use_after_return=0:strict_init_order=1:check_initialization_order=1${ASAN_OPTIONS_EXTRA:+:$ASAN_OPTIONS_EXTRA}"
export LSAN_OPTIONS="suppressions=$san_dir/lsan.supp:print_suppressions=0"
export UBSAN_OPTIONS="suppressions=$san_dir/ubsan.supp:print_stacktrace=1:halt_on_error=1"
export TSAN_OPTIONS="suppressions=$san_dir/tsan.supp:halt_on_error=1:second_deadlock_stack=1:history_size=4"
unset san_dir
