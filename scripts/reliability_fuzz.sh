#!/bin/bash
# Runs libFuzzer targets for a bounded time.
#   reliability_fuzz.sh FUZZER SEED_DIR WORK_DIR SECONDS   one target (used by ctest -L fuzz)
#   reliability_fuzz.sh --all BUILD_DIR SECONDS            every target of a DYGSLAM_FUZZ build, in
#                                                          turn (long run: SECONDS=3600 each)
# The corpus grows in WORK_DIR/corpus (kept between runs); crashes are written to
# WORK_DIR/artifacts/ and make the script fail, printing the reproducer command.
# Environment: FUZZ_JOBS (default 1) parallel fuzzing jobs per target; FUZZ_RSS_MB (2048).
set -euo pipefail

if [ "${1:-}" = "--all" ]; then
  build=${2:?build dir}; seconds=${3:?seconds}
  "$build/fuzz/make_fuzz_seeds" "$build/fuzz/corpus/seeds" "$(dirname "$0")/.." >/dev/null
  status=0
  for bin in "$build"/fuzz/*_fuzzer; do
    name=$(basename "$bin" _fuzzer)
    echo "=== $name ($seconds s)"
    "$0" "$bin" "$build/fuzz/corpus/seeds/$name" "$build/fuzz/corpus/work/$name" "$seconds" || status=1
  done
  exit $status
fi

fuzzer=${1:?fuzzer binary}; seeds=${2:?seed dir}; work=${3:?work dir}; seconds=${4:?seconds}
mkdir -p "$work/corpus" "$work/artifacts" "$seeds"
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:allocator_may_return_null=0:abort_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
log="$work/fuzz.log"
set +e
"$fuzzer" "$work/corpus" "$seeds" \
  -max_total_time="$seconds" -timeout=10 -rss_limit_mb="${FUZZ_RSS_MB:-2048}" \
  -max_len=65536 -jobs="${FUZZ_JOBS:-1}" -workers="${FUZZ_JOBS:-1}" \
  -artifact_prefix="$work/artifacts/" -print_final_stats=1 >"$log" 2>&1
rc=$?
set -e
grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::new_units_added|stat::peak_rss_mb)" "$log" || true
if [ $rc -ne 0 ]; then
  tail -n 60 "$log"
  echo "FAILED: $(basename "$fuzzer") exit $rc; artifacts:" >&2
  ls -1 "$work/artifacts" >&2 || true
  for a in "$work"/artifacts/*; do
    [ -e "$a" ] && echo "reproduce: $fuzzer $a" >&2
  done
  exit 1
fi
echo "OK: $(basename "$fuzzer") ran ${seconds}s without findings (corpus $(ls "$work/corpus" | wc -l) files)"
