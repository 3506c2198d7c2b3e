#!/usr/bin/env bash
# Usage: profiling/peak-ram.sh CMD [ARGS...]
# Runs CMD and prints its peak resident set size (the kernel's maxrss, via GNU time), then exits with
# CMD's exit code. Measure native builds: under qemu-user the figure includes the emulator.
set -u
if [ $# -eq 0 ] || [ "$1" = "-h" ] || [ "$1" = "--help" ]; then
  sed -n '2,4p' "$0"; exit 2
fi
if [ ! -x /usr/bin/time ]; then
  echo "peak-ram.sh: /usr/bin/time is missing (apt-get install time)" >&2; exit 127
fi
report=$(mktemp)
trap 'rm -f "$report"' EXIT
/usr/bin/time -f '%M %e' -o "$report" "$@"
rc=$?
read -r kib secs < <(tail -n 1 "$report")
case "$kib" in ''|*[!0-9]*) echo "peak-ram.sh: could not measure '$*'" >&2; exit "$rc" ;; esac
awk -v k="$kib" -v s="$secs" -v c="$*" -v rc="$rc" 'BEGIN {
  printf "peak RSS: %.1f MiB (%d KiB), wall %s s, exit %d: %s\n", k / 1024, k, s, rc, c }' >&2
exit "$rc"
