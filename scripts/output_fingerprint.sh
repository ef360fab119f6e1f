#!/bin/bash
# Fingerprint of the deterministic outputs (a refactor must keep them byte-identical).
#   scripts/output_fingerprint.sh [BUILD_DIR] [DATASET_DIR] [OUT_DIR]
# Defaults: build, $DYGSLAM_DATA_DIR/bonn_crowd_part (or ../shared/data/...), /tmp/dygslam_fingerprint.
# Runs, all with --deterministic --filter full --quiet:
#   run-direct     dygslam run DATASET --direct
#   run-default    dygslam run DATASET            (DDS components as threads of one process)
#   run-processes  dygslam run DATASET --processes (one process per component)
#   map            dygslam map DATASET
# DDS runs go inside a private network namespace (loopback only), domain $DYGSLAM_DOMAIN_ID
# (default 51). Prints one line per output: `<run> <file> sha256:<hex>` for trajectory.txt,
# keyframes.txt, map.bt and frames.csv without its timing columns (the *_ms columns), plus
# `round9:<hex>`, the sha256 of trajectory.txt / keyframes.txt with every number rounded to 1e-9
# (for runs that are not bit-reproducible). Compare two outputs with diff.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
data_root=${DYGSLAM_DATA_DIR:-$here/../shared/data}
dataset=${2:-$data_root/bonn_crowd_part}
out=${3:-/tmp/dygslam_fingerprint}
domain=${DYGSLAM_DOMAIN_ID:-51}
bin=$build/apps/dygslam
[ -x "$bin" ] || { echo "output_fingerprint.sh: $bin not built" >&2; exit 1; }
[ -d "$dataset" ] || { echo "output_fingerprint.sh: no dataset at $dataset" >&2; exit 1; }
mkdir -p "$out"

netns() {
  unshare -n bash -c 'ip link set lo up && ip link set lo multicast on &&
    ip route add 224.0.0.0/4 dev lo && exec "$@"' fingerprint "$@"
}

common=(--deterministic --filter full --quiet)
run_one() {  # NAME COMMAND...
  local name=$1
  shift
  rm -rf "${out:?}/$name"
  if ! "$@" --out "$out/$name" >"$out/$name.log" 2>&1; then
    echo "output_fingerprint.sh: $name failed (log: $out/$name.log)" >&2
    return 1
  fi
}

run_one run-direct "$bin" run "$dataset" "${common[@]}" --direct
run_one run-default netns "$bin" run "$dataset" "${common[@]}" --domain "$domain"
run_one run-processes netns "$bin" run "$dataset" "${common[@]}" --processes --domain "$domain"
run_one map "$bin" map "$dataset" "${common[@]}"

# frames.csv without the columns whose name ends in _ms (wall times).
strip_timing() {
  awk -F, 'NR == 1 { for (i = 1; i <= NF; ++i) keep[i] = ($i !~ /_ms$/) }
           { line = ""; for (i = 1; i <= NF; ++i) if (keep[i]) line = line (line == "" ? "" : ",") $i;
             print line }' "$1"
}
round9() {
  awk '{ line = ""; for (i = 1; i <= NF; ++i) { v = ($i ~ /^[-+0-9.eE]+$/) ? sprintf("%.9f", $i) : $i;
         if (v == "-0.000000000") v = "0.000000000"; line = line (i > 1 ? " " : "") v } print line }' "$1"
}
sha() { sha256sum | cut -d' ' -f1; }

for name in run-direct run-default run-processes map; do
  for file in trajectory.txt keyframes.txt map.bt frames.csv; do
    path=$out/$name/$file
    if [ ! -f "$path" ]; then
      echo "$name $file missing"
      continue
    fi
    case $file in
      frames.csv) echo "$name $file sha256:$(strip_timing "$path" | sha)" ;;
      *.txt) echo "$name $file sha256:$(sha <"$path") round9:$(round9 "$path" | sha)" ;;
      *) echo "$name $file sha256:$(sha <"$path")" ;;
    esac
  done
done
