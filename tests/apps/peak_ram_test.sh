#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Usage: tests/apps/peak_ram_test.sh PEAK_RAM_SH PROBE
# Checks profiling/peak-ram.sh against a command whose memory is known: PROBE (cm_alloc_probe) touches 1 MiB in
# one run and 65 MiB in another, so the two peak RSS figures must differ by 64 MiB (plus at most 1/8 and a few
# pages under AddressSanitizer, whose shadow maps 8 bytes to 1). The difference, not the absolute figure, is the
# reference: the probe's start-up RSS depends on the build (an ASan binary starts near 45 MiB, a plain one near
# 7 MiB).
# Also checks that peak-ram.sh passes the command's exit code through (a usage error of the probe is 2).
set -u
peak_ram=$1 probe=$2
fail() { echo "FAIL: $*"; exit 1; }

peak_mib() {  # prints the MiB figure of peak-ram.sh's report of PROBE --touch-mb $1
  local out
  out=$("$peak_ram" "$probe" --touch-mb "$1" 2>&1) || fail "peak-ram.sh $probe --touch-mb $1 exited $?: $out"
  echo "$out" | sed -n 's/^peak RSS: \([0-9]*\.[0-9]\) MiB ([0-9]* KiB), wall .* s, exit 0: .*/\1/p'
}
small=$(peak_mib 1)
large=$(peak_mib 65)
if [ -z "$small" ] || [ -z "$large" ]; then
  fail "no 'peak RSS: X MiB (N KiB), wall S s, exit 0: CMD' line (got '$small', '$large')"
fi
echo "peak RSS: $small MiB touching 1 MiB, $large MiB touching 65 MiB"
awk -v a="$small" -v b="$large" 'BEGIN { d = b - a; printf "difference %.1f MiB (expected 62 to 76)\n", d;
  exit !(d >= 62.0 && d <= 76.0) }' || fail "the difference is not the 64 MiB the probe touched"

"$peak_ram" "$probe" --touch-mb 0 >/dev/null 2>&1
rc=$?
[ $rc -eq 2 ] || fail "peak-ram.sh returned $rc for a command that exits 2"
echo "PASS"
