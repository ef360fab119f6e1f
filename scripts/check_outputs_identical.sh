#!/bin/bash
# A refactor must keep the deterministic outputs of bonn_crowd_part byte-identical.
#   scripts/check_outputs_identical.sh record BUILD_DIR OUT_DIR   the four runs into OUT_DIR
#   scripts/check_outputs_identical.sh compare BASE_OUT NEW_OUT   cmp every output of the runs
#   scripts/check_outputs_identical.sh BASE_BUILD NEW_BUILD [OUT] both (OUT default /tmp/dygslam_identical)
# The runs are the ones of scripts/output_fingerprint.sh (all --deterministic --filter full):
# run --direct, run (components as threads), run --processes (the DDS runs in a private network
# namespace, domain $DYGSLAM_DOMAIN_ID, default 51) and map. Compared with cmp: trajectory.txt,
# trajectory_online.txt, keyframes.txt, map.bt, map.ot, and frames.csv without its wall-time
# (*_ms) columns. Exit 0 when every output is identical, 1 otherwise (the differing files named).
# Example (before and after a change, builds in build-base and build):
#   DYGSLAM_DOMAIN_ID=205 scripts/check_outputs_identical.sh build-base build
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
runs=(run-direct run-default run-processes map)
files=(trajectory.txt trajectory_online.txt keyframes.txt map.bt map.ot frames.csv)

usage() {
  sed -n '2,5p' "$0" | sed 's/^# \{0,1\}//' >&2
  exit 2
}

record() {  # BUILD_DIR OUT_DIR (dataset: $DATASET, default bonn_crowd_part)
  "$here/output_fingerprint.sh" "$1" "${DATASET:-}" "$2" >/dev/null
}

# frames.csv without the columns whose name ends in _ms (wall times).
strip_timing() {
  awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) keep[i] = ($i !~ /_ms$/) }
           { line = ""; for (i = 1; i <= NF; ++i) if (keep[i]) line = line (line == "" ? "" : ",") $i;
             print line }' "$1"
}

compare() {  # BASE_OUT NEW_OUT
  local base=$1 new=$2 differ=0 same=0 run file a b
  for run in "${runs[@]}"; do
    for file in "${files[@]}"; do
      a=$base/$run/$file
      b=$new/$run/$file
      if [ ! -e "$a" ] && [ ! -e "$b" ]; then
        continue
      elif [ ! -e "$a" ] || [ ! -e "$b" ]; then
        echo "DIFFERS   $run/$file: only in $([ -e "$a" ] && echo "$base" || echo "$new")"
        differ=$((differ + 1))
        continue
      fi
      if [ "$file" = frames.csv ]; then
        if cmp -s <(strip_timing "$a") <(strip_timing "$b"); then
          echo "identical $run/$file (state columns)"
          same=$((same + 1))
        else
          echo "DIFFERS   $run/$file (state columns): $(cmp <(strip_timing "$a") <(strip_timing "$b") 2>&1 | head -1)"
          differ=$((differ + 1))
        fi
      elif cmp -s "$a" "$b"; then
        echo "identical $run/$file ($(stat -c %s "$a") bytes)"
        same=$((same + 1))
      else
        echo "DIFFERS   $run/$file: $(cmp "$a" "$b" 2>&1 | head -1)"
        differ=$((differ + 1))
      fi
    done
  done
  echo "$same identical, $differ different"
  [ "$same" -gt 0 ] && [ "$differ" -eq 0 ]
}

case ${1:-} in
  record)
    [ $# -eq 3 ] || usage
    record "$2" "$3"
    ;;
  compare)
    [ $# -eq 3 ] || usage
    compare "$2" "$3"
    ;;
  "" | -h | --help) usage ;;
  *)
    [ $# -ge 2 ] || usage
    out=${3:-/tmp/dygslam_identical}
    record "$1" "$out/base"
    record "$2" "$out/new"
    compare "$out/base" "$out/new"
    ;;
esac
