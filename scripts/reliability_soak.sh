#!/bin/bash
# Soak benchmark: loops a dataset through the SLAM System for MINUTES of wall time, recording RSS
# and per-frame time (tests/reliability/soak_benchmark.cc), then plots them when matplotlib is
# available.
#   scripts/reliability_soak.sh [BUILD_DIR] [MINUTES] [DATASET_DIR] [FILTER] [OUT_DIR]
# Defaults: build-rel, 30, $DYGSLAM_DATA_DIR/bonn_crowd_part (or ../shared/data/...), full,
# out/soak. Build first: cmake --build BUILD_DIR --target reliability_soak
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build-rel}
minutes=${2:-30}
data_root=${DYGSLAM_DATA_DIR:-$here/../shared/data}
dataset=${3:-$data_root/bonn_crowd_part}
filter=${4:-full}
out=${5:-$here/out/soak}
bin=$build/tests/reliability/reliability_soak
[ -x "$bin" ] || { echo "reliability_soak.sh: $bin not built (cmake --build $build --target reliability_soak)" >&2; exit 1; }
mkdir -p "$out"
echo "soak: $minutes min of $dataset (filter $filter) -> $out; load at start: $(cut -d' ' -f1-3 /proc/loadavg)"
"$bin" "$dataset" --minutes "$minutes" --filter "$filter" --out "$out" | tee "$out/summary.txt"
echo "load at end: $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$out/summary.txt"
py=python3; [ -x /usr/bin/python3 ] && py=/usr/bin/python3
"$py" - "$out" <<'PY' || echo "(no plot: matplotlib missing)"
import csv, sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
out = sys.argv[1]
rows = list(csv.DictReader(open(out + "/soak.csv")))
t = [float(r["wall_s"]) / 60 for r in rows]
fig, ax = plt.subplots(4, 1, figsize=(9, 10), sharex=True)
ax[0].plot(t, [float(r["rss_mb"]) for r in rows], label="resident")
ax[0].plot(t, [float(r["heap_mb"]) for r in rows], label="heap in use")
ax[0].set_ylabel("memory (MB)"); ax[0].legend()
ax[1].plot(t, [float(r["total_ms"]) for r in rows], ",", alpha=0.5); ax[1].set_ylabel("frame time (ms)")
ax[1].set_yscale("log")
ax[2].plot(t, [int(r["keyframes"]) for r in rows]); ax[2].set_ylabel("keyframes in map")
ax[3].plot(t, [int(r["map_points"]) for r in rows], label="in map")
ax[3].plot(t, [int(r["live_points"]) for r in rows], label="alive")
ax[3].set_ylabel("map points"); ax[3].legend()
ax[3].set_xlabel("wall time (min)")
fig.tight_layout(); fig.savefig(out + "/soak.png", dpi=90)
print("plot: " + out + "/soak.png")
PY
