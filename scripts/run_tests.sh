#!/usr/bin/env bash
# Runs the ctest suite of a build folder as `make test` and CI do, and prints a summary that says
# what ran: tests passed / failed / skipped, retries, and the time.
#   scripts/run_tests.sh BUILD_DIR [extra ctest arguments]
# - Data, models and built tools are required (DYGSLAM_REQUIRE_DATA=1): a test that needs them
#   fails when they are missing instead of skipping. A skipped test fails the run (set
#   DYGSLAM_ALLOW_SKIPS=1 to only report them, e.g. on a machine without the shared data).
# - No blanket retries. A test that is known to be timing-sensitive on 2 shared cores may be
#   listed in RETRY_BY_NAME below with the reason; it is re-run once, by name, and the retry is
#   printed in the summary. Every other test must pass on its first run.
# - Every selected test must run: the run fails when no test ran, or when fewer ran than
#   `ctest -N` lists for the same arguments (a test that vanished, a crashed ctest).
set -uo pipefail

build=${1:?usage: run_tests.sh BUILD_DIR [ctest args]}
shift
jobs=${JOBS:-2}
export DYGSLAM_REQUIRE_DATA=1

# name regex -> reason. Keep empty unless a test cannot be made event-driven.
declare -A RETRY_BY_NAME=(
  # A mapper that joins a running slam: in about one loaded suite run in five its status reader
  # never matches slam's status writer (no STARTED, also not the one written again when a reader
  # joins), so it ignores every keyframe. Fast DDS's discovery of a late joiner under the burst of
  # 64 keyframes with images; to be fixed in the mapper (keyframe reader made once slam is known).
  ['^dds/Pipeline\.LateMapperReceivesKeyframeHistory$']='late-joiner discovery under load'
)

log=$(mktemp)
trap 'rm -f "$log"' EXIT
start=$(date +%s)
# What the selection lists ("Total Tests: N"); ctest -N runs nothing.
listed=$(ctest --test-dir "$build" -N "$@" 2>&1 | sed -nE 's/^Total Tests: *([0-9]+).*/\1/p')
if [[ -z $listed ]]; then
  echo "run_tests: \`ctest --test-dir $build -N $*\` listed no test count (not a configured build folder?)"
  exit 1
fi
ctest --test-dir "$build" --output-on-failure -j"$jobs" "$@" 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}

count() { grep -cE "$1" "$log" || true; }
total=$(count '^ *[0-9]+/[0-9]+ Test +#[0-9]+:')
passed=$(count '^ *[0-9]+/[0-9]+ Test +#[0-9]+: .* Passed')
skipped=$(count '^ *[0-9]+/[0-9]+ Test +#[0-9]+: .*(\*\*\*Skipped|Not Run)')
failed_names=$(grep -E '^ *[0-9]+/[0-9]+ Test +#[0-9]+:' "$log" | grep -vE 'Passed|\*\*\*Skipped|Not Run' |
  sed -E 's/^ *[0-9]+\/[0-9]+ Test +#[0-9]+: ([^ ]+).*/\1/' || true)

retried=()
still_failing=()
for name in $failed_names; do
  reason=""
  for pattern in "${!RETRY_BY_NAME[@]}"; do
    if [[ $name =~ $pattern ]]; then reason=${RETRY_BY_NAME[$pattern]}; fi
  done
  if [[ -n $reason ]]; then
    echo "run_tests: RETRY $name ($reason)"
    if ctest --test-dir "$build" --output-on-failure -R "^${name}\$"; then
      retried+=("$name")
      continue
    fi
  fi
  still_failing+=("$name")
done
failed=${#still_failing[@]}

echo ""
echo "test summary: $total of $listed listed tests ran, $((passed + ${#retried[@]})) passed, $failed failed, $skipped skipped," \
  "${#retried[@]} retried${retried:+ (${retried[*]})}, $(($(date +%s) - start)) s"
if [[ $failed -gt 0 ]]; then
  echo "failed: ${still_failing[*]}"
  exit 1
fi
if [[ $total -eq 0 ]]; then
  echo "run_tests: no test ran (ctest arguments: ${*:-none}); a run that tests nothing fails"
  exit 1
fi
if [[ $total -lt $listed ]]; then
  echo "run_tests: $total tests ran but ctest -N lists $listed for the same arguments"
  exit 1
fi
if [[ $skipped -gt 0 ]]; then
  grep -E '\*\*\*Skipped|Not Run' "$log" | sed 's/^/  skipped: /'
  if [[ ${DYGSLAM_ALLOW_SKIPS:-0} != 1 ]]; then
    echo "run_tests: $skipped skipped tests (data, models or tools missing?); every test must run"
    exit 1
  fi
fi
if [[ $rc -ne 0 && ${#retried[@]} -eq 0 ]]; then exit "$rc"; fi
exit 0
