#!/bin/bash
# Runs a command inside a private network namespace that looks like a robot's computer: loopback
# (up, without the MULTICAST flag, as on a stock Linux host) plus a "LAN" interface lan0 with a
# private address (10.252.141.1/24), the MULTICAST flag and the multicast route, so DDS
# implementations on their default settings pick lan0 and announce its address. lan0 is one end
# of a veth pair whose other end (lan1, no address) stays in the namespace too (the kernels here
# have no dummy interface type): nothing leaves the namespace; traffic to the host's own address
# and looped-back multicast are delivered inside it. Like components/tests/run_in_netns.sh, the command also gets a private
# /dev/shm. Needs CAP_SYS_ADMIN + CAP_NET_ADMIN (root).
# Usage: run_in_lan_netns.sh <command> [args...]
set -e
if ! unshare -n -m --propagation private true 2>/dev/null; then
  echo "run_in_lan_netns.sh: cannot create a network and mount namespace (need root)" >&2
  exit 1
fi
exec unshare -n -m --propagation private bash -c '
  set -e
  mount -t tmpfs -o mode=1777 dygslam-test-shm /dev/shm
  ip link set lo up
  ip link add lan0 type veth peer name lan1
  ip addr add 10.252.141.1/24 dev lan0
  ip link set lan0 multicast on
  ip link set lan1 up
  ip link set lan0 up
  ip route add 224.0.0.0/4 dev lan0
  exec "$@"' run_in_lan_netns "$@"
