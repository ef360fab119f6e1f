# Helpers shared by the hostile-user probes (hostile_probe.sh, fresh_probe.sh): sourced, not run.
# Expects DATA (the bonn_crowd_part folder), FAILS (a counter) and the current folder to hold logs/.
# A dataset of the first N frames of bonn_crowd_part (absolute image paths) in folder $1.
small() {
  local dir=$1 n=$2
  rm -rf "$dir"; mkdir -p "$dir"
  ln -s "$DATA/rgb" "$dir/rgb"; ln -s "$DATA/depth" "$dir/depth"  # paths inside the folder
  grep -v '^#' "$DATA/rgb.txt" | head -n "$n" >"$dir/rgb.txt"
  grep -v '^#' "$DATA/depth.txt" | head -n "$n" >"$dir/depth.txt"
  cp "$DATA/groundtruth.txt" "$dir/groundtruth.txt"
}

# verdict NAME RC WANT [DETAIL]: WANT is a |-list of allowed exit codes.
verdict() {
  local name=$1 rc=$2 want=$3 detail=${4:-} v=ok
  if [ "$rc" = 137 ] && [ -f "logs/$name.hang" ]; then v=HANG
  elif grep -q "AddressSanitizer\|LeakSanitizer\|runtime error:" "logs/$name.err" 2>/dev/null; then
    v=SANITIZER
  elif [ "$rc" -ge 128 ] && ! [[ "|$want|" == *"|$rc|"* ]]; then v=CRASH
  elif grep -q "internal error" "logs/$name.err" 2>/dev/null; then v=INTERNAL
  elif ! [[ "|$want|" == *"|$rc|"* ]]; then v=UNEXPECTED
  fi
  [ -n "$detail" ] && [ "$v" = ok ] && v=$detail
  # `early`: killed before its handlers existed, nothing started, nothing lost (not a finding).
  [ "$v" = ok ] || [ "$v" = early ] || FAILS=$((FAILS + 1))
  printf '%-28s rc=%-3s %-10s %s\n' "$name" "$rc" "$v" \
    "$(tail -c 300 "logs/$name.err" 2>/dev/null | grep -v '^\s*$' | tail -1 | cut -c1-150)"
}

# probe NAME WANT SECONDS CMD...: runs CMD with a deadline.
probe() {
  local name=$1 want=$2 secs=$3; shift 3
  rm -f "logs/$name.hang"
  timeout -s KILL "$secs" "$@" >"logs/$name.out" 2>"logs/$name.err"
  local rc=$?
  [ "$rc" = 137 ] && touch "logs/$name.hang"
  verdict "$name" "$rc" "$want"
}

# signal_probe NAME SIG DELAY WANT OUT CMD...: sends SIG after DELAY s; checks outputs kept.
signal_probe() {
  local name=$1 sig=$2 delay=$3 want=$4 out=$5; shift 5
  rm -f "logs/$name.hang"
  "$@" >"logs/$name.out" 2>"logs/$name.err" &
  local pid=$!
  sleep "$delay"; kill -s "$sig" "$pid" 2>/dev/null
  local waited=0
  while kill -0 "$pid" 2>/dev/null && [ $waited -lt 90 ]; do sleep 1; waited=$((waited + 1)); done
  if kill -0 "$pid" 2>/dev/null; then kill -9 "$pid"; touch "logs/$name.hang"; fi
  wait "$pid"; local rc=$?
  local detail=
  # Killed before its handlers existed (libraries still loading on a loaded machine): nothing
  # was started, nothing is lost; the conventional 128 + signal.
  local signum; signum=$(kill -l "$sig")
  if [ "$rc" = $((128 + signum)) ] && [ ! -s "logs/$name.err" ] && { [ -z "$out" ] || [ ! -e "$out" ]; }; then
    want="$want|$rc"; detail=early
  fi
  # Frames processed but no trajectory written: data loss.
  if [ "$rc" = 0 ] && [ -n "$out" ] && [ ! -s "$out/trajectory.txt" ] &&
    grep -q "processed" "logs/$name.out" && ! grep -q "frames: 0 processed" "logs/$name.out"; then
    detail=LOSS
  fi
  verdict "$name" "$rc" "$want" "$detail"
}


# half_written DIR: prints the outputs of DIR that are cut short (a TUM trajectory line without its
# 8 columns, a CSV line with another column count than its header); nothing when all are whole.
half_written() {
  local dir=$1 f
  for f in "$dir"/trajectory*.txt "$dir"/keyframes.txt; do
    [ -f "$f" ] || continue
    awk '!/^#/ && NF && NF != 8 {bad=1} END {exit bad}' "$f" || echo "$f"
  done
  for f in "$dir"/*.csv; do
    [ -f "$f" ] || continue
    awk -F, 'NR==1 {n=NF} NR>1 && NF && NF != n {bad=1} END {exit bad}' "$f" || echo "$f"
  done
}
