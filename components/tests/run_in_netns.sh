#!/bin/bash
# Runs a command inside a private network namespace with only loopback up (multicast enabled on
# lo so DDS discovery works): DDS traffic of tests can never leave the machine. The command also
# gets a private, empty /dev/shm (a mount namespace with its own tmpfs): Fast DDS's shared-memory
# transport lives there and crosses network namespaces, so without it tests running in parallel
# would discover each other over shared memory, and the segments of a process a test kills on
# purpose would stay behind for the next ones. The tmpfs goes away with the namespace.
# Usage: run_in_netns.sh <command> [args...]
# Needs CAP_SYS_ADMIN (root); without it, falls back to running the command directly only if
# DYGSLAM_NETNS_OPTIONAL=1 (the components then still use SHM + 127.0.0.1 only).
set -e
source "$(dirname "$(readlink -f "$0")")/../../scripts/netns_lib.sh"
if netns_available; then
  netns_run "$@"
  exit
fi
if [ "${DYGSLAM_NETNS_OPTIONAL:-0}" = "1" ]; then
  exec "$@"
fi
echo "run_in_netns.sh: cannot create a network and mount namespace (need root / CAP_SYS_ADMIN);" \
     "set DYGSLAM_NETNS_OPTIONAL=1 to run on the host with SHM + 127.0.0.1 transports" >&2
exit 1
