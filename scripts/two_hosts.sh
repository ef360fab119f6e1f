#!/usr/bin/env bash
# The DDS pipeline on two "hosts": two network namespaces joined by a veth pair (addresses
# 10.251.0.1 and 10.251.0.2, nothing leaves the machine), shared memory off, each namespace with
# its own empty /dev/shm. Host A runs player + detector, host B slam + mapper + recorder; every
# sample crosses the veth over UDP. Then the same frames run in one process (`dygslam run --direct`)
# and the two trajectories are compared byte for byte (with --deterministic they must be identical).
#
#   scripts/two_hosts.sh OUT_DIR [--discovery-server] [--frames A:B] [--rate R] [--filter MODE]
#                        [--deterministic]
#
# --discovery-server: no multicast on the link (no route for 224.0.0.0/4, multicast off on the
#   veth); a `dygslam discovery-server` on host B and every component a client of it.
# --rate 1: the player sends at the camera's rate (30 Hz); 0: as fast as the pipeline takes them.
# Prints the player's frame-to-pose latency and poses/s, slam's summary, and "trajectory:
# identical" or "trajectory: DIFFERENT" (exit 1 when --deterministic and different).
# Environment: DYGSLAM_BIN (default build/apps/dygslam), DYGSLAM_DATA_DIR (bonn_crowd_part),
# TWO_HOSTS_DOMAIN (DDS domain, default 46). Needs root (network + mount namespaces).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
source "$root/scripts/netns_lib.sh"
out=${1:?usage: two_hosts.sh OUT_DIR [--discovery-server] [--frames A:B] [--rate R] [--filter MODE] [--deterministic]}
shift
frames=0:120 rate=0 filter=full server=0 deterministic=()
while [[ $# -gt 0 ]]; do
  case $1 in
    --discovery-server) server=1 ;;
    --frames) frames=$2; shift ;;
    --rate) rate=$2; shift ;;
    --filter) filter=$2; shift ;;
    --deterministic) deterministic=(--deterministic) ;;
    *) echo "two_hosts.sh: unknown argument $1" >&2; exit 2 ;;
  esac
  shift
done
bin=${DYGSLAM_BIN:-$root/build/apps/dygslam}
data=${DYGSLAM_DATA_DIR:-${DYGSLAM_DEFAULT_DATA_DIR:-$root/../shared/data}}
dataset=$data/bonn_crowd_part
export DYGSLAM_DATA_DIR=$data DYGSLAM_SOURCE_DIR=$root  # the detector finds the models beside the data
config=$root/config/bonn.yaml
domain=${TWO_HOSTS_DOMAIN:-46}
addr_a=10.251.0.1 addr_b=10.251.0.2 port=11811
[[ -x $bin ]] || { echo "two_hosts.sh: $bin not built" >&2; exit 1; }
[[ -d $dataset ]] || { echo "two_hosts.sh: dataset $dataset missing (DYGSLAM_DATA_DIR)" >&2; exit 1; }
rm -rf "$out"
mkdir -p "$out/hosts" "$out/direct"

# Two namespaces (network + mount), kept alive by a sleeping process each.
netns_hold host_a
netns_hold host_b
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  kill "$host_a" "$host_b" 2>/dev/null || true
  wait 2>/dev/null || true
}
trap cleanup EXIT
# Unique names: the pair is created in this namespace before it moves (parallel runs).
if_a=dA$$ if_b=dB$$
ip link add "$if_a" netns "$host_a" type veth peer name "$if_b" netns "$host_b"
setup_host() {  # pid interface address
  nsenter -t "$1" -n -m sh -c "mount -t tmpfs dygslam-host-shm /dev/shm && ip link set lo up &&
    ip addr add $3/24 dev $2 && ip link set $2 up"
  if [[ $server == 1 ]]; then
    nsenter -t "$1" -n ip link set "$2" multicast off
  else
    nsenter -t "$1" -n ip route add 224.0.0.0/4 dev "$2"
  fi
}
setup_host "$host_a" "$if_a" $addr_a
setup_host "$host_b" "$if_b" $addr_b

on() {  # on HOST_PID ADDRESS NAME [args...]: a component on that host, log in $out/NAME.log
  local host=$1 address=$2 name=$3
  shift 3
  local net=(--dds-interface "$address" --no-shm)
  [[ $server == 1 ]] && net+=(--discovery-server "$addr_b:$port")
  nsenter -t "$host" -n -m "$bin" component "$name" --dataset "$dataset" --config "$config" \
    --out "$out/hosts" --frames "$frames" --filter "$filter" --domain "$domain" \
    --partition two_hosts "${net[@]}" "${deterministic[@]}" "$@" > "$out/$name.log" 2>&1 &
  pids+=($!)
}
if [[ $server == 1 ]]; then
  nsenter -t "$host_b" -n -m "$bin" discovery-server --listen "$addr_b:$port" \
    --domain "$domain" > "$out/discovery-server.log" 2>&1 &
  server_pid=$!
fi
start=$(date +%s.%N)
on "$host_b" $addr_b recorder
on "$host_b" $addr_b mapper
on "$host_b" $addr_b slam
on "$host_a" $addr_a detector
on "$host_a" $addr_a player --rate "$rate" --wait-for-components
# Wait for all five; the first one that fails stops the others (they would wait for it).
rc=0
declare -A finished=()
while [[ ${#finished[@]} -lt ${#pids[@]} ]]; do
  for p in "${pids[@]}"; do
    [[ -n ${finished[$p]:-} ]] && continue
    kill -0 "$p" 2>/dev/null && continue
    code=0
    wait "$p" || code=$?
    finished[$p]=$code
    if [[ $code != 0 ]]; then
      rc=1
      for q in "${pids[@]}"; do kill -TERM "$q" 2>/dev/null || true; done
    fi
  done
  sleep 0.1
done
pids=()
end=$(date +%s.%N)
[[ $server == 1 ]] && { kill -INT "$server_pid"; wait "$server_pid" || true; }
# The detector has no end of stream of its own: the player's end stops it (see its log).
for name in player detector slam mapper recorder; do
  echo "== $name: $(grep -E '^\[I\] '"$name"':' "$out/$name.log" | tail -2 | tr '\n' ' ')"
done
[[ $rc == 0 ]] || { echo "two_hosts.sh: a component failed (logs in $out)" >&2; exit 1; }
echo "wall time: $(awk -v a="$start" -v b="$end" 'BEGIN { printf "%.2f", b - a }') s"

"$bin" run "$dataset" --config "$config" --out "$out/direct" --frames "$frames" --filter "$filter" \
  --direct --quiet "${deterministic[@]}" > "$out/direct.log" 2>&1
if cmp -s "$out/hosts/trajectory.txt" "$out/direct/trajectory.txt"; then
  echo "trajectory: identical ($(grep -vc '^#' "$out/hosts/trajectory.txt") poses)"
else
  echo "trajectory: DIFFERENT from the single-process run"
  [[ ${#deterministic[@]} -gt 0 ]] && exit 1
fi
exit 0
