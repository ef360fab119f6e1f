#!/bin/bash
# Private network namespaces for DDS runs: the one place that knows how (sourced by
# components/tests/run_in_netns.sh, scripts/two_hosts.sh, reliability_soak.sh, speed_compare.sh,
# make_benchmarks.py).
# DDS discovery multicasts on every interface; inside a namespace with only loopback up (multicast
# routed to lo) nothing leaves the machine. Fast DDS's shared-memory transport lives in /dev/shm,
# which a network namespace does not isolate: each namespace also gets its own empty tmpfs there
# (a mount namespace), so parallel runs do not discover each other over shared memory and the
# segments of killed processes go away with the namespace. Needs root / CAP_SYS_ADMIN.

# Loopback up with multicast (DDS discovery) inside the current namespace.
netns_loopback_setup='ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo'

# True when this process may create network + mount namespaces.
netns_available() {
  unshare -n -m --propagation private true 2>/dev/null
}

# netns_run CMD [ARGS...]: runs CMD in a fresh network + mount namespace (loopback only, private
# /dev/shm); stdin, stdout and the exit code pass through.
netns_run() {
  unshare -n -m --propagation private bash -c \
    "mount -t tmpfs -o mode=1777 dygslam-netns-shm /dev/shm && $netns_loopback_setup && exec \"\$@\"" \
    netns "$@"
}

# netns_exec CMD [ARGS...]: like netns_run, but replaces this shell (the command keeps its pid, so
# signals sent to it arrive directly).
netns_exec() {
  exec unshare -n -m --propagation private bash -c \
    "mount -t tmpfs -o mode=1777 dygslam-netns-shm /dev/shm && $netns_loopback_setup && exec \"\$@\"" \
    netns "$@"
}

# netns_hold VAR: starts a process that holds a new network + mount namespace (a "host" to enter
# with nsenter -t PID) and sets VAR to its pid once the namespace exists. Kill the pid to end it.
netns_hold() {
  unshare -n -m --propagation private sleep 100000 &
  local pid=$! self_net
  self_net=$(readlink /proc/self/ns/net)
  for _ in $(seq 100); do
    [[ $(readlink /proc/$pid/ns/net 2>/dev/null) != "$self_net" ]] && break
    sleep 0.02
  done
  printf -v "$1" '%s' "$pid"
}
