#!/bin/bash
# Soak benchmark: loops a dataset through the SLAM System for MINUTES of wall time, recording RSS
# and per-frame time (tests/reliability/soak_benchmark.cc), then plots them when matplotlib is
# available.
#   scripts/reliability_soak.sh [BUILD_DIR] [MINUTES] [DATASET_DIR] [FILTER] [OUT_DIR]
# Defaults: build-rel, 30, $DYGSLAM_DATA_DIR/bonn_crowd_part (or ../shared/data/...), full,
# out/soak. Build first: cmake --build BUILD_DIR --target reliability_soak
# DYGSLAM_SOAK_CONFIG=FILE: settings file instead of config/bonn.yaml (loop closing is on by
# default: the summary counts the loops closed per soak loop; `LoopClosing: {enabled: false}` turns it off).
#
# The DDS pipeline instead: `dygslam run DATASET --loop-minutes MINUTES` (the player
# replays the frames, map on) in the default mode (components as threads) or with --processes,
# inside a private network namespace; the resident memory of every process is sampled every 5 s
# (OUT_DIR/rss.csv), the slope of each over the second half is printed (MB/min) and plotted
# (OUT_DIR/rss.png):
#   scripts/reliability_soak.sh --pipeline default|processes [BUILD_DIR] [MINUTES] [DATASET_DIR]
#                               [FILTER] [OUT_DIR]
# DYGSLAM_DOMAIN_ID sets the DDS domain (default 0; the run's partition is unique anyway).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/scripts/netns_lib.sh"
if [ "${1:-}" = "--pipeline" ]; then
  mode=${2:?--pipeline needs default or processes}
  case "$mode" in default) flag= ;; processes) flag=--processes ;;
    *) echo "reliability_soak.sh: --pipeline default|processes, not '$mode'" >&2; exit 2 ;; esac
  shift 2
  build=${1:-$here/build-rel}
  minutes=${2:-30}
  data_root=${DYGSLAM_DATA_DIR:-$here/../shared/data}
  dataset=${3:-$data_root/bonn_crowd_part}
  filter=${4:-full}
  out=${5:-$here/out/soak_pipeline_$mode}
  bin=$build/apps/dygslam
  [ -x "$bin" ] || { echo "reliability_soak.sh: $bin not built" >&2; exit 1; }
  mkdir -p "$out"
  echo "pipeline soak ($mode): $minutes min of $dataset (filter $filter, map on) -> $out;" \
       "$(nproc) cores; load at start: $(cut -d' ' -f1-3 /proc/loadavg)" | tee "$out/summary.txt"
  py=python3; [ -x /usr/bin/python3 ] && py=/usr/bin/python3
  netns_run "$py" - "$out" "$bin" run "$dataset" --filter "$filter" --loop-minutes "$minutes" \
      --out "$out/run" --quiet ${DYGSLAM_DOMAIN_ID:+--domain $DYGSLAM_DOMAIN_ID} $flag <<'PY' | tee -a "$out/summary.txt"
import csv, os, subprocess, sys, time
out, cmd = sys.argv[1], sys.argv[2:]
log = open(out + "/run.log", "w")
proc = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT)
def tree(root):
    parents = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = open(f"/proc/{d}/stat").read()
                parents[int(d)] = int(stat[stat.rindex(")") + 2:].split()[1])
            except (OSError, ValueError):
                pass
    pids, grew = {root}, True
    while grew:
        grew = False
        for p, pp in parents.items():
            if pp in pids and p not in pids:
                pids.add(p); grew = True
    return pids
def name_rss(pid):
    try:
        argv = open(f"/proc/{pid}/cmdline").read().split("\0")
        rss = next(int(l.split()[1]) for l in open(f"/proc/{pid}/status") if l.startswith("VmRSS:"))
    except (OSError, StopIteration):
        return None
    return (argv[2] if len(argv) > 2 and argv[1] == "component" else "run"), rss / 1024.0
t0 = time.time()
with open(out + "/rss.csv", "w", newline="") as f:
    w = csv.writer(f); w.writerow(["wall_s", "process", "rss_mb"])
    while proc.poll() is None:
        now = time.time() - t0
        for pid in tree(proc.pid):
            nr = name_rss(pid)
            if nr: w.writerow([f"{now:.1f}", nr[0], f"{nr[1]:.1f}"])
        f.flush()
        for _ in range(50):
            if proc.poll() is not None: break
            time.sleep(0.1)
print(f"exit code {proc.returncode}; wall time {time.time() - t0:.0f} s")
PY
  grep -a "frames:\|ATE\|slam:\|mapper:" "$out/run.log" | tr '\r' '\n' | grep -a "frames:\|ATE\|\[I\]" | tail -n 5 | tee -a "$out/summary.txt"
  echo "load at end: $(cut -d' ' -f1-3 /proc/loadavg)" | tee -a "$out/summary.txt"
  "$py" - "$out" "$mode" <<'PY' | tee -a "$out/summary.txt"
import collections, csv, sys
out, mode = sys.argv[1], sys.argv[2]
series = collections.defaultdict(list)
for r in csv.DictReader(open(out + "/rss.csv")):
    series[r["process"]].append((float(r["wall_s"]) / 60, float(r["rss_mb"])))
end = max(t for s in series.values() for t, _ in s)
print("| process | RSS at 1 min (MB) | RSS at half (MB) | RSS at end (MB) | slope, second half (MB/min) |")
print("|---|---|---|---|---|")
for name, s in sorted(series.items()):
    at = lambda m: min(s, key=lambda p: abs(p[0] - m))[1]
    half = [(t, y) for t, y in s if t >= end / 2 and t <= end - 0.25]  # the last 15 s: shutdown
    n = len(half); sx = sum(t for t, _ in half); sy = sum(y for _, y in half)
    sxx = sum(t * t for t, _ in half); sxy = sum(t * y for t, y in half)
    slope = (n * sxy - sx * sy) / (n * sxx - sx * sx) if n > 2 and n * sxx != sx * sx else float("nan")
    print(f"| {name} | {at(1):.1f} | {at(end / 2):.1f} | {at(end - 0.25):.1f} | {slope:.3f} |")
try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
except ImportError:
    print("(no plot: matplotlib missing)"); sys.exit(0)
fig, ax = plt.subplots(figsize=(9, 4.5))
for name, s in sorted(series.items()):
    ax.plot([t for t, _ in s], [y for _, y in s], label=name)
ax.axvline(end / 2, color="grey", ls=":", lw=1)
ax.set_xlabel("wall time (min)"); ax.set_ylabel("resident memory (MB)")
ax.set_title(f"DDS pipeline soak, {mode} mode: resident memory per process")
ax.legend(); fig.tight_layout(); fig.savefig(out + "/rss.png", dpi=90)
print("plot: " + out + "/rss.png")
PY
  exit 0
fi
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
"$bin" "$dataset" --minutes "$minutes" --filter "$filter" --out "$out" \
  ${DYGSLAM_SOAK_CONFIG:+--config "$DYGSLAM_SOAK_CONFIG"} | tee "$out/summary.txt"
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
