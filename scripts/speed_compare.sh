#!/bin/bash
# Frame time of the full method against the no-filter baseline, measured in the same invocation:
# RUNS interleaved runs of each (none, full, none, full, ...) of
#   dygslam run DATASET --direct --no-map --filter none|full
# (real threading, detection prefetched one frame ahead), then per filter the median over runs of
# the per-frame median of FeedRgbdFrame's wall time, frames/s over the whole loop (PNG loading
# included), ATE RMSE, and the ratio full / none.
#   scripts/speed_compare.sh [BUILD_DIR] [DATASET_DIR] [RUNS] [OUT_DIR] [-- extra run arguments]
# Defaults: build-rel, $DYGSLAM_DATA_DIR/bonn_crowd_part (or ../shared/data/...), 3, out/speed.
#
# Pipeline modes instead: RUNS interleaved runs of `dygslam run DATASET --filter FILTER`
# in each mode (--direct, default = DDS components as threads, --processes), DDS runs inside a
# private network namespace; per mode the median frames/s (dygslam's own figure: frames over the
# whole run, start-up included), its ratio to --direct, and CPU (user + sys of all processes) per
# frame:
#   scripts/speed_compare.sh --modes [BUILD_DIR] [DATASET_DIR] [RUNS] [OUT_DIR] [-- extra run args]
# FILTER: $SPEED_FILTER (default full). DYGSLAM_DOMAIN_ID sets the DDS domain.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
source "$here/scripts/netns_lib.sh"
if [ "${1:-}" = "--modes" ]; then
  shift
  build=${1:-$here/build-rel}
  data_root=${DYGSLAM_DATA_DIR:-$here/../shared/data}
  dataset=${2:-$data_root/bonn_crowd_part}
  runs=${3:-3}
  out=${4:-$here/out/speed_modes}
  shift $(($# < 4 ? $# : 4))
  [ "${1:-}" = "--" ] && shift
  filter=${SPEED_FILTER:-full}
  bin=$build/apps/dygslam
  [ -x "$bin" ] || { echo "speed_compare.sh: $bin not built" >&2; exit 1; }
  mkdir -p "$out"
  echo "speed: $runs interleaved runs of direct/default/processes, filter $filter, extra args '$*' on $dataset;" \
       "$(nproc) cores; load at start: $(cut -d' ' -f1-3 /proc/loadavg)"
  for r in $(seq 1 "$runs"); do
    for mode in direct default processes; do
      case $mode in direct) flag=--direct ;; default) flag= ;; processes) flag=--processes ;; esac
      dir=$out/$mode-$r
      rm -rf "$dir"
      netns_run /usr/bin/time -f "cpu_s %U %S" "$bin" run "$dataset" --filter "$filter" --out "$dir" --quiet \
        ${DYGSLAM_DOMAIN_ID:+--domain $DYGSLAM_DOMAIN_ID} $flag "$@" > "$dir.log" 2>&1 ||
        { echo "run $mode-$r failed:" >&2; tail -n 20 "$dir.log" >&2; exit 1; }
      echo "  $mode run $r: $(grep -o '[0-9.]* fps' "$dir.log" | head -1), $(grep -o 'ATE RMSE [0-9.]* m' "$dir.log" | head -1), $(grep -a 'cpu_s' "$dir.log")"
    done
  done
  echo "load at end: $(cut -d' ' -f1-3 /proc/loadavg)"
  py=python3; [ -x /usr/bin/python3 ] && py=/usr/bin/python3
  "$py" - "$out" "$runs" <<'PY'
import re, statistics as st, sys
out, runs = sys.argv[1], int(sys.argv[2])
rows = {}
for mode in ("direct", "default", "processes"):
    fps, cpu, ate = [], [], []
    for r in range(1, runs + 1):
        log = open(f"{out}/{mode}-{r}.log", errors="replace").read()
        fps.append(float(re.search(r"([\d.]+) fps", log).group(1)))
        frames = int(re.search(r"frames: (\d+) processed", log).group(1))
        u, s = map(float, re.search(r"cpu_s ([\d.]+) ([\d.]+)", log).groups())
        cpu.append(1000 * (u + s) / frames)
        m = re.search(r"ATE RMSE ([\d.]+)", log); ate.append(float(m.group(1)) if m else float("nan"))
    rows[mode] = dict(fps=st.median(fps), spread=(min(fps), max(fps)), cpu=st.median(cpu), ate=st.median(ate))
print("| mode | frames/s (median, min-max) | x direct | CPU ms per frame (user+sys, median) | ATE RMSE (m, median) |")
print("|---|---|---|---|---|")
for mode, r in rows.items():
    print(f"| {mode} | {r['fps']:.1f} ({r['spread'][0]:.1f}-{r['spread'][1]:.1f}) | {r['fps'] / rows['direct']['fps']:.2f} | "
          f"{r['cpu']:.1f} | {r['ate']:.4f} |")
PY
  exit 0
fi
build=${1:-$here/build-rel}
data_root=${DYGSLAM_DATA_DIR:-$here/../shared/data}
dataset=${2:-$data_root/bonn_crowd_part}
runs=${3:-3}
out=${4:-$here/out/speed}
shift $(($# < 4 ? $# : 4))
[ "${1:-}" = "--" ] && shift
bin=$build/apps/dygslam
[ -x "$bin" ] || { echo "speed_compare.sh: $bin not built" >&2; exit 1; }
mkdir -p "$out"
echo "speed: $runs interleaved runs of none/full on $dataset; $(nproc) cores; load at start: $(cut -d' ' -f1-3 /proc/loadavg)"
for r in $(seq 1 "$runs"); do
  for filter in none full; do
    dir=$out/$filter-$r
    rm -rf "$dir"
    "$bin" run "$dataset" --direct --no-map --filter "$filter" --out "$dir" --quiet "$@" > "$dir.log" 2>&1 ||
      { echo "run $filter-$r failed:" >&2; cat "$dir.log" >&2; exit 1; }
    echo "  $filter run $r: $(grep -o '[0-9.]* fps' "$dir.log" | head -1), $(grep -o 'ATE RMSE [0-9.]* m' "$dir.log" | head -1)"
  done
done
echo "load at end: $(cut -d' ' -f1-3 /proc/loadavg)"
py=python3; [ -x /usr/bin/python3 ] && py=/usr/bin/python3
"$py" - "$out" "$runs" <<'PY'
import csv, re, statistics as st, sys
out, runs = sys.argv[1], int(sys.argv[2])
rows = {}
for f in ("none", "full"):
    medians, means, fps, ate, orb, det, wait_frames = [], [], [], [], [], [], []
    for r in range(1, runs + 1):
        frames = list(csv.DictReader(open(f"{out}/{f}-{r}/frames.csv")))
        total = [float(x["total_ms"]) for x in frames]
        medians.append(st.median(total)); means.append(st.mean(total))
        orb.append(st.median(float(x["orb_ms"]) for x in frames))
        det.append(st.median(float(x["detection_ms"]) for x in frames))
        log = open(f"{out}/{f}-{r}.log").read()
        m = re.search(r"([\d.]+) fps", log); fps.append(float(m.group(1)) if m else float("nan"))
        m = re.search(r"ATE RMSE ([\d.]+)", log); ate.append(float(m.group(1)) if m else float("nan"))
    rows[f] = dict(median=st.median(medians), mean=st.median(means), fps=st.median(fps), ate=st.median(ate),
                   orb=st.median(orb), det=st.median(det), spread=(min(medians), max(medians)))
print("| filter | ORB extraction (median) | detection, worker thread (median) | frame time median | frame time mean | x no filter (median) | frames/s | ATE RMSE (m) |")
print("|---|---|---|---|---|---|---|---|")
for f in ("none", "full"):
    r = rows[f]
    ratio = r["median"] / rows["none"]["median"]
    det = "-" if f == "none" else f"{r['det']:.1f}"
    print(f"| {f} | {r['orb']:.1f} | {det} | {r['median']:.2f} ({r['spread'][0]:.2f}-{r['spread'][1]:.2f}) | "
          f"{r['mean']:.2f} | {ratio:.2f} | {r['fps']:.1f} | {r['ate']:.4f} |")
PY
