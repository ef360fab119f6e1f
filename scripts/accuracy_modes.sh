#!/bin/bash
# ATE RMSE of the three run modes, interleaved (the accuracy-by-mode table of BENCHMARKS.md).
# ROUNDS rounds of
#   dygslam run DATASET --config CONFIG --filter full --no-map [--direct | (default) | --processes]
# (real threading, not --deterministic), the DDS modes inside a private network namespace
# (scripts/netns_lib.sh), then one line per run: mode, round, ATE RMSE (dygslam eval), the number
# of poses in trajectory.txt and the run's own "poses:" summary.
#   scripts/accuracy_modes.sh [BUILD_DIR] [DATASET_DIR] [ROUNDS] [OUT_DIR]
# Defaults: build, $DYGSLAM_DATA_DIR/bonn_crowd_part (or ../shared/data/...), 3, out/accuracy_modes.
# CONFIG: $ACCURACY_CONFIG (default config/bonn.yaml); DDS domain $DYGSLAM_DOMAIN_ID (default 41).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/scripts/netns_lib.sh"
build=${1:-$here/build}
data_root=${DYGSLAM_DATA_DIR:-$here/../shared/data}
dataset=${2:-$data_root/bonn_crowd_part}
rounds=${3:-3}
out=${4:-$here/out/accuracy_modes}
config=${ACCURACY_CONFIG:-$here/config/bonn.yaml}
domain=${DYGSLAM_DOMAIN_ID:-41}
bin=$build/apps/dygslam
[ -x "$bin" ] || { echo "accuracy_modes.sh: $bin not built" >&2; exit 1; }
[ -d "$dataset" ] || { echo "accuracy_modes.sh: no dataset at $dataset" >&2; exit 1; }
mkdir -p "$out"

common=("$dataset" --config "$config" --filter full --no-map --quiet)
for ((round = 1; round <= rounds; ++round)); do
  for mode in direct default processes; do
    run=$out/${mode}_$round
    rm -rf "$run"
    case $mode in
      direct) "$bin" run "${common[@]}" --direct --out "$run" >"$run.log" 2>&1 ;;
      default) netns_run "$bin" run "${common[@]}" --domain "$domain" --out "$run" >"$run.log" 2>&1 ;;
      processes)
        netns_run "$bin" run "${common[@]}" --processes --domain "$domain" --out "$run" \
          >"$run.log" 2>&1 ;;
    esac
    rmse=$("$bin" eval "$dataset/groundtruth.txt" "$run/trajectory.txt" 2>/dev/null |
      grep -m1 rmse | awk '{print $2}')
    echo "$mode $round rmse $rmse poses $(grep -c '^[0-9]' "$run/trajectory.txt")" \
      "$(grep -o 'poses: .*' "$run.log" | head -1)"
  done
done
