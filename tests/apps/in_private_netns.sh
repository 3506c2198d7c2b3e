#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Runs a command inside a fresh private network namespace that has only loopback, up, with the LCM multicast route
# on it (spec/PLATFORM.md 4.1): udpm traffic of the command can reach no other address. Sets CM_PRIVATE_NETNS=1
# for the command. Prints "CM-SKIP: ..." (CTest: skipped) where namespaces are unavailable.
#
#   tests/apps/in_private_netns.sh build-host/tests/cm_test_platform_lcm -tc="LcmBus udpm*"
set -euo pipefail
[ $# -ge 1 ] || { echo "usage: $0 COMMAND [ARG...]" >&2; exit 2; }
if [ -z "${CM_PRIVATE_NETNS:-}" ]; then
  if ! command -v unshare >/dev/null; then echo "CM-SKIP: unshare (util-linux) is not installed"; exit 0; fi
  if ! unshare -n true 2>/dev/null; then
    echo "CM-SKIP: cannot create a private network namespace (unshare -n needs root or user namespaces)"; exit 0
  fi
  export CM_PRIVATE_NETNS=1
  exec unshare -n bash "$0" "$@"
fi
ip link set lo up
ip route add 224.0.0.0/4 dev lo
exec "$@"
