#!/usr/bin/env bash
# Usage: profiling/placement_evidence.sh [--true-m 5] [--true-deg 5] WORK [WORK...]
# The evidence at each placement of stage A's clusters, true against false, per world: reads the
# `pair.A-B.placed.K` lines of every run report under the recall benchmark's work folders (WORK/NAME/run/report/
# metrics.tsv, kept by profiling/bench_recall.sh even with --drop-data) and prints one row per world and kind.
# A placement is true when it lies within --true-m and --true-deg of the ground truth's at its place (the line's
# truth_gap_m and truth_gap_deg; reports without ground truth are skipped). Columns: placements, then the 10th
# percentile / median / 90th percentile of the cluster's weight (keyframes), its consensus support (keyframes),
# the fraction of co-located keyframes whose descriptors agree (chance <= 0.05; placements with ranked keyframes
# only) and their median chance. The world is the scenario name's first word (its livox model as "WORLD livox").
set -euo pipefail
true_m=5
true_deg=5
works=()
while [ $# -gt 0 ]; do
  case "$1" in
    --true-m) true_m=$2; shift 2 ;;
    --true-deg) true_deg=$2; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d'; exit 0 ;;
    -*) echo "placement_evidence.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) works+=("$1"); shift ;;
  esac
done
[ "${#works[@]}" -gt 0 ] || { echo "placement_evidence.sh: name at least one work folder (see --help)" >&2; exit 2; }
files=()
for w in "${works[@]}"; do
  [ -d "$w" ] || { echo "placement_evidence.sh: no folder $w" >&2; exit 2; }
  while IFS= read -r f; do files+=("$f"); done < <(find "$w" -path '*/run/report/metrics.tsv' | sort)
done
[ "${#files[@]}" -gt 0 ] || { echo "placement_evidence.sh: no run report under ${works[*]}" >&2; exit 2; }
for f in "${files[@]}"; do
  scenario=${f%/run/report/metrics.tsv}
  scenario=${scenario##*/}
  awk -F'\t' -v scenario="$scenario" '$1 ~ /^pair\.[0-9]+-[0-9]+\.placed\.[0-9]+$/ { print scenario "\t" $2 }' "$f"
done | awk -F'\t' -v tm="$true_m" -v td="$true_deg" '
  function quantiles(key, k,   i, j, t, v, n) {
    n = count[key, k]
    if (n == 0) return "-"
    for (i = 1; i <= n; i++) v[i] = value[key, k, i]
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
    return sprintf("%.2f / %.2f / %.2f", v[int(0.1 * (n - 1)) + 1], v[int((n - 1) / 2) + 1], v[int(0.9 * (n - 1)) + 1])
  }
  function add(key, k, x) { count[key, k]++; value[key, k, count[key, k]] = x }
  {
    world = $1; sub(/-.*/, "", world)
    if ($1 ~ /-livox-/) world = world " livox"
    n = split($2, t, " ")
    delete f
    for (i = 3; i < n; i += 2) f[t[i]] = t[i + 1]
    if (!("truth_gap_m" in f)) next
    kind = (f["truth_gap_m"] + 0 <= tm && f["truth_gap_deg"] + 0 <= td) ? "true" : "false"
    key = world "\t" kind
    if (!(key in rows)) order[++keys] = key
    rows[key]++
    add(key, "weight", f["weight"]); add(key, "support", f["support"])
    if (f["ranked"] + 0 > 0) { add(key, "fraction", f["agreeing"] / f["ranked"]); add(key, "chance", f["median_chance"]) }
  }
  END {
    print "| world | placements | n | weight [kf] | support [kf] | agreeing fraction | median chance |"
    print "|---|---|---|---|---|---|---|"
    for (i = 1; i <= keys; i++) {
      key = order[i]; split(key, w, "\t")
      printf "| %s | %s | %d | %s | %s | %s | %s |\n", w[1], w[2], rows[key], quantiles(key, "weight"),
             quantiles(key, "support"), quantiles(key, "fraction"), quantiles(key, "chance")
    }
  }' | { read -r h; read -r s; echo "$h"; echo "$s"; sort; }
