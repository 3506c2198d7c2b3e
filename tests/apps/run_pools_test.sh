#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# `commerge run` sizes its pools from the datasets it opened (issue "Five robots end to end"): the keyframes a
# robot's pools hold equal the most keyframes a robot made (printed per robot), the raw points a scan hold the
# largest scan file's (its size / 16 B; never fewer than the board's), and a shorter slice of the same robots gets
# smaller pools and a smaller budget. Used by the CTest "cli: run: the pools follow the datasets ...".
#
#   tests/apps/run_pools_test.sh OUT_DIR "COMMERGE [EMULATOR WORDS]" ROBOT_DIR...
set -euo pipefail
out=$1
bin=$2
shift 2
robots=("$@")
[ ${#robots[@]} -ge 2 ] || { echo "run_pools_test.sh: give at least two robot directories" >&2; exit 2; }

run_once() {  # $1 = log, rest = datasets
  local log=$1
  shift
  # shellcheck disable=SC2086  # $bin may be "qemu-aarch64 -L ... commerge"
  $bin run "$@" --no-report --no-progress --out "$out/run" >"$log" 2>&1 || true
}
pools() {  # $1 = log -> "keyframes points store_text total_text"
  sed -n 's/.*pools for \([0-9]*\) keyframes and \([0-9]*\)-point scans a robot, scan stores of \([0-9.]* [KMG]*i*B\); memory budget of run fits: \([0-9.]* [KMG]*i*B\) of.*/\1 \2|\3|\4/p' "$1"
}
to_bytes() {  # "25.1 KiB" -> bytes
  awk -v t="$1" 'BEGIN { split(t, a, " "); m = 1; if (a[2] == "KiB") m = 1024; if (a[2] == "MiB") m = 1048576;
                         if (a[2] == "GiB") m = 1073741824; printf "%.0f", a[1] * m }'
}

mkdir -p "$out"
run_once "$out/full.log" "${robots[@]}"
line=$(pools "$out/full.log")
[ -n "$line" ] || { echo "run_pools_test.sh: no pools line in the run's output:" >&2; head -5 "$out/full.log" >&2; exit 1; }
read -r keyframes points_and_rest <<<"$line"
points=${points_and_rest%%|*}
rest=${points_and_rest#*|}
store=${rest%%|*}
total=${rest#*|}
made=$(sed -n 's/.* scans -> \([0-9]*\) keyframes .*/\1/p' "$out/full.log" | sort -n | tail -n 1)
largest=0
for r in "${robots[@]}"; do
  for f in "$r"/velodyne/*.bin; do
    n=$(($(wc -c <"$f") / 16))
    [ "$n" -gt "$largest" ] && largest=$n
  done
done
echo "full datasets: pools for $keyframes keyframes (robots made at most $made), $points points a scan (largest file" \
     "$largest points), scan stores of $store, budget $total"
[ -n "$made" ] && [ "$keyframes" = "$made" ] ||
  { echo "run_pools_test.sh: the pools hold $keyframes keyframes, the robots made at most ${made:-?}" >&2; exit 1; }
[ "$points" -ge "$largest" ] ||
  { echo "run_pools_test.sh: the pools take $points-point scans, the largest file has $largest" >&2; exit 1; }

# The first two scans of each robot: fewer keyframes, smaller stores and budget.
slices=()
for r in "${robots[@]}"; do slices+=("$r:0-2"); done
run_once "$out/slice.log" "${slices[@]}"
line=$(pools "$out/slice.log")
[ -n "$line" ] || { echo "run_pools_test.sh: no pools line in the sliced run's output" >&2; head -5 "$out/slice.log" >&2; exit 1; }
read -r keyframes2 rest2 <<<"$line"
rest2=${rest2#*|}
store2=${rest2%%|*}
total2=${rest2#*|}
echo "first two scans: pools for $keyframes2 keyframes, scan stores of $store2, budget $total2"
[ "$keyframes2" -le 2 ] && [ "$keyframes2" -lt "$keyframes" ] ||
  { echo "run_pools_test.sh: two scans a robot gave pools for $keyframes2 keyframes" >&2; exit 1; }
[ "$(to_bytes "$store2")" -lt "$(to_bytes "$store")" ] && [ "$(to_bytes "$total2")" -lt "$(to_bytes "$total")" ] ||
  { echo "run_pools_test.sh: the sliced run's store ($store2) or budget ($total2) is not below the full one's" >&2; exit 1; }
echo "run pools follow the datasets"
