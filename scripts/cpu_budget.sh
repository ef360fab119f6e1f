#!/bin/bash
# CPU per frame (issue 19): user + sys of all threads of `dygslam run` / frames, with ATE RMSE,
# for several configurations, RUNS interleaved rounds (a, b, c, a, b, c, ...), medians per
# configuration:
#   scripts/cpu_budget.sh BUILD_DIR DATASET_DIR RUNS OUT_DIR NAME=FILTER[,SETTINGS_KEY=VALUE...] ...
# Each configuration runs `dygslam run DATASET --filter FILTER --config <settings>` where
# <settings> is config/bonn.yaml with the given keys set (SECTION.KEY=VALUE sets KEY in SECTION,
# e.g. Detector.every_n_frames=3 or OctoMap.pixel_stride=4). Extra run arguments for every
# configuration: $CPU_BUDGET_ARGS (default "--direct --no-map"). DDS modes run inside a private
# network namespace (DYGSLAM_DOMAIN_ID sets the domain). A part `build=DIR` runs that
# configuration with DIR/apps/dygslam instead (e.g. main's build beside this one: the ratio
# against main measured in the same interleaved rounds):
#   scripts/cpu_budget.sh build DATA 3 out/cpu main=full,build=/work/main/build full=full
#   scripts/cpu_budget.sh build ../shared/data/bonn_crowd_part 3 out/cpu none=none full=full \
#       full_k3=full,Detector.every_n_frames=3
# A part `env:VAR=VALUE` sets an environment variable for that configuration's runs (e.g.
# env:OPENCV_FOR_THREADS_NUM=1 or env:GLIBC_TUNABLES=glibc.malloc.trim_threshold=67108864).
# CPU_BUDGET_CASE=robot runs BUILD/tests/cpu_per_frame_benchmark (one run per round) instead of
# `dygslam run`: the frames decoded beforehand, the System's CPU only (the robot case); the table
# then also gives each configuration's CPU per round as a ratio of the first configuration's.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$1 dataset=$2 runs=$3 out=$4
shift 4
case_=${CPU_BUDGET_CASE:-dataset}
[[ $case_ == dataset || $case_ == robot ]] || { echo "cpu_budget.sh: CPU_BUDGET_CASE must be dataset or robot" >&2; exit 2; }
tool=apps/dygslam
[ "$case_" = robot ] && tool=tests/cpu_per_frame_benchmark
bin=$build/$tool
[ -x "$bin" ] || { echo "cpu_budget.sh: $bin not built" >&2; exit 1; }
args=${CPU_BUDGET_ARGS:---direct --no-map}
mkdir -p "$out"
names=()
for spec in "$@"; do
  name=${spec%%=*} rest=${spec#*=}
  IFS=, read -r -a parts <<< "$rest"
  filter=${parts[0]}
  cfg=$out/$name.yaml
  keys=()
  echo "$bin" > "$out/$name.bin"
  : > "$out/$name.env"
  for part in "${parts[@]:1}"; do
    if [[ $part == build=* ]]; then
      echo "${part#build=}/$tool" > "$out/$name.bin"
      [ -x "$(cat "$out/$name.bin")" ] || { echo "cpu_budget.sh: $(cat "$out/$name.bin") not built" >&2; exit 1; }
    elif [[ $part == env:*=* ]]; then
      echo "${part#env:}" >> "$out/$name.env"
    else
      keys+=("$part")
    fi
  done
  # Keys replace the preset's value (in its section) or are added (a new section if needed).
  python3 - "$here/config/bonn.yaml" "$cfg" ${keys[@]+"${keys[@]}"} <<'PY'
import re, sys
src, dst, pairs = sys.argv[1], sys.argv[2], sys.argv[3:]
lines = open(src).read().splitlines()
for kv in pairs:
    key, value = kv.split("=", 1)
    if value == "-":  # KEY=- : left out (its flat line; a nested one is kept)
        lines = [l for l in lines if not re.match(re.escape(key) + r"\s*:", l)]
        continue
    top = [i for i, l in enumerate(lines) if re.match(re.escape(key) + r"\s*:", l)]
    if top:  # ORB-SLAM2's top-level dotted keys (ORBextractor.nFeatures)
        lines[top[0]] = f"{key}: {value}"
        continue
    section, _, field = key.rpartition(".")
    start = next((i for i, l in enumerate(lines) if section and l.rstrip() == section + ":"), None)
    if not section:
        hit = [i for i, l in enumerate(lines) if re.match(re.escape(field) + r"\s*:", l)]
        if hit: lines[hit[0]] = f"{field}: {value}"
        else: lines.append(f"{field}: {value}")
        continue
    if start is None:
        lines += [f"{section}:", f"  {field}: {value}"]
        continue
    end = start + 1
    while end < len(lines) and (lines[end].startswith(" ") or not lines[end].strip()): end += 1
    hit = [i for i in range(start + 1, end) if re.match(r"\s+" + re.escape(field) + r"\s*:", lines[i])]
    if hit: lines[hit[0]] = f"  {field}: {value}"
    else: lines.insert(end, f"  {field}: {value}")
open(dst, "w").write("\n".join(lines) + "\n")
PY
  echo "$filter" > "$out/$name.filter"
  names+=("$name")
done
echo "cpu_budget: $runs rounds of ${names[*]}, $case_ case, args '$args', $(nproc) cores, load at start: $(cut -d' ' -f1-3 /proc/loadavg)"
for r in $(seq 1 "$runs"); do
  for name in "${names[@]}"; do
    dir=$out/$name-$r
    rm -rf "$dir"
    envs=()
    mapfile -t envs < "$out/$name.env"
    if [ "$case_" = robot ]; then
      env ${envs[@]+"${envs[@]}"} "$(cat "$out/$name.bin")" "$dataset" --filter "$(cat "$out/$name.filter")" \
        --config "$out/$name.yaml" --runs 1 > "$dir.log" 2>&1 || { echo "run $name-$r failed:" >&2; tail -n 20 "$dir.log" >&2; exit 1; }
      echo "  $name run $r: $(grep '^| 1 |' "$dir.log")"
      continue
    fi
    # shellcheck disable=SC2086
    unshare -n bash -c 'ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo && exec "$@"' cpu \
      env ${envs[@]+"${envs[@]}"} /usr/bin/time -f "cpu_s %U %S wall_s %e" "$(cat "$out/$name.bin")" run "$dataset" --filter "$(cat "$out/$name.filter")" \
      --config "$out/$name.yaml" --out "$dir" ${DYGSLAM_DOMAIN_ID:+--domain $DYGSLAM_DOMAIN_ID} $args \
      > "$dir.log" 2>&1 || { echo "run $name-$r failed:" >&2; tail -n 20 "$dir.log" >&2; exit 1; }
    echo "  $name run $r: $(grep -a '^frames:' "$dir.log" | grep -o '[0-9.]* fps' | tail -1), $(grep -o 'ATE RMSE [0-9.]* m' "$dir.log" | head -1), $(grep -a 'cpu_s' "$dir.log")"
  done
done
echo "load at end: $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$out" "$runs" "$case_" "${names[@]}" <<'PY'
import re, statistics as st, sys
out, runs, case, names = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4:]
if case == "robot":
    # Row of cpu_per_frame_benchmark: | run | frames | decode | System | sum | wall s | ATE | poses |
    rows = {}
    for name in names:
        rows[name] = []
        for r in range(1, runs + 1):
            line = next(l for l in open(f"{out}/{name}-{r}.log", errors="replace") if l.startswith("| 1 |"))
            f = [c.strip() for c in line.strip().strip("|").split("|")]
            rows[name].append({"frames": int(f[1]), "decode": float(f[2]), "cpu": float(f[3]),
                               "fps": int(f[1]) / float(f[5]), "ate": float(f[6]),
                               "poses": f[7] if len(f) > 7 else "?"})
    base = rows[names[0]]
    print(f"| configuration | System CPU ms per frame (median, min-max) | x {names[0]}, per round | "
          "feed frames/s (median) | decode CPU ms/frame | ATE RMSE m (median, min-max) | poses |")
    print("|---|---|---|---|---|---|---|")
    for name in names:
        v = rows[name]
        cpu = [x["cpu"] for x in v]; ate = [x["ate"] for x in v]
        ratio = " / ".join(f"{x['cpu'] / b['cpu']:.2f}" for x, b in zip(v, base))
        print(f"| {name} | {st.median(cpu):.1f} ({min(cpu):.1f}-{max(cpu):.1f}) | {ratio} | "
              f"{st.median(x['fps'] for x in v):.1f} | {st.median(x['decode'] for x in v):.1f} | "
              f"{st.median(ate):.4f} ({min(ate):.4f}-{max(ate):.4f}) | {', '.join(x['poses'] for x in v)} |")
    sys.exit(0)
print("| configuration | CPU ms per frame (median, min-max) | frames/s (median) | ATE RMSE m (median, min-max) |")
print("|---|---|---|---|")
for name in names:
    cpu, fps, ate = [], [], []
    for r in range(1, runs + 1):
        log = open(f"{out}/{name}-{r}.log", errors="replace").read()
        frames = int(re.search(r"frames: (\d+) processed", log).group(1))
        u, s = map(float, re.search(r"cpu_s ([\d.]+) ([\d.]+)", log).groups())
        cpu.append(1000 * (u + s) / frames)
        # the summary line (the first "fps" of a log is the first progress line's)
        m = re.search(r"^frames:.*?([\d.]+) fps", log, re.M); fps.append(float(m.group(1)) if m else float("nan"))
        m = re.search(r"ATE RMSE ([\d.]+)", log); ate.append(float(m.group(1)) if m else float("nan"))
    print(f"| {name} | {st.median(cpu):.1f} ({min(cpu):.1f}-{max(cpu):.1f}) | {st.median(fps):.1f} | "
          f"{st.median(ate):.4f} ({min(ate):.4f}-{max(ate):.4f}) |")
PY
