#!/usr/bin/env bash
# Usage: profiling/placement_evidence.sh [--true-m 5] [--true-deg 5] [--pairs [--world W]] [--run run|baseline]
#                                        WORK [WORK...]
# The evidence at each placement of stage A's clusters, true against false, per world: reads the
# `pair.A-B.placed.K` lines of every run report under the recall benchmark's work folders (WORK/NAME/run/report/
# metrics.tsv, kept by profiling/bench_recall.sh even with --drop-data) and prints one row per world and kind.
# A placement is true when it lies within --true-m and --true-deg of the ground truth's at its place (the line's
# truth_gap_m and truth_gap_deg; reports without ground truth are skipped; --run baseline reads the reports of the
# benchmark's --baseline-commerge runs, WORK/NAME/baseline/report/metrics.tsv). Columns: placements, then the 10th
# percentile / median / 90th percentile of the cluster's weight (keyframes), its consensus support (keyframes),
# the fraction of co-located keyframes whose descriptors agree (chance <= 0.05; placements with ranked keyframes
# only) and their median chance. The world is the scenario name's first word (its livox model as "WORLD livox").
# --pairs: instead, one row per robot pair that shares a place (shared_path_m > 0, not stopped at "no shared
# place") and did not merge (--world: of scenarios whose name starts with that world, the Livox model's too), with
# the evidence that says why: where it stopped, whether the placement of the cluster stage A passed on is true and
# its consensus support, the best support of a true and of a false placement among stage A's clusters, the
# descriptor distances of truly co-located keyframe pairs (median) against those of the rest (5th percentile), and
# which part of the cascade the evidence points at:
#   "no true cluster": none of stage A's clusters lies at the true place (stage A and the descriptor);
#   "look-alike outweighs": a false placement has more support than every true one (the decision cannot tell
#     them apart by support; equal support means they agree with each other within the consensus tolerance);
#   "true place refused": the cluster passed on is true and a decision before registration stopped it;
#   "registration": the cluster passed on is true and registration's gates, or a check after them, refused it;
#   "false passed on": a true placement has more support than any false one, but stage A passed on a false one.
set -euo pipefail
true_m=5
true_deg=5
pairs=0
only_world=""
run=run
works=()
while [ $# -gt 0 ]; do
  case "$1" in
    --true-m) true_m=$2; shift 2 ;;
    --true-deg) true_deg=$2; shift 2 ;;
    --pairs) pairs=1; shift ;;
    --world) only_world=$2; shift 2 ;;
    --run)
      case "$2" in run|baseline) run=$2 ;; *) echo "placement_evidence.sh: --run is run or baseline, not '$2'" >&2; exit 2 ;; esac
      shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d'; exit 0 ;;
    -*) echo "placement_evidence.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) works+=("$1"); shift ;;
  esac
done
[ "${#works[@]}" -gt 0 ] || { echo "placement_evidence.sh: name at least one work folder (see --help)" >&2; exit 2; }
files=()
for w in "${works[@]}"; do
  [ -d "$w" ] || { echo "placement_evidence.sh: no folder $w" >&2; exit 2; }
  while IFS= read -r f; do files+=("$f"); done < <(find "$w" -path "*/$run/report/metrics.tsv" | sort)
done
[ "${#files[@]}" -gt 0 ] || { echo "placement_evidence.sh: no run report under ${works[*]}" >&2; exit 2; }
if [ "$pairs" = 1 ]; then
  echo "| scenario | pair | shared path [m] | stopped at | passed on: true, support [kf] | best true / false support [kf] | descriptor distance: true median / others 5 % | evidence points at |"
  echo "|---|---|---|---|---|---|---|---|"
  for f in "${files[@]}"; do
    scenario=${f%/"$run"/report/metrics.tsv}
    scenario=${scenario##*/}
    world=${scenario%%-*}
    [ -z "$only_world" ] || [ "$world" = "$only_world" ] || continue
    awk -F'\t' -v scenario="$scenario" -v tm="$true_m" -v td="$true_deg" '
      function pairof(key,   t) { split(key, t, "."); return t[2] }
      $1 ~ /^pair\.[0-9]+-[0-9]+\.shared_path_m$/ { p = pairof($1); shared[p] = $2; if (!(p in seen)) { seen[p] = 1; order[++n] = p } }
      $1 ~ /^pair\.[0-9]+-[0-9]+\.stopped$/ { stopped[pairof($1)] = $2 }
      $1 ~ /^pair\.[0-9]+-[0-9]+\.true_distance_p05_p50_p95$/ { split($2, d, " "); true_med[pairof($1)] = d[2] }
      $1 ~ /^pair\.[0-9]+-[0-9]+\.false_distance_p01_p05_p50$/ { split($2, d, " "); false_p05[pairof($1)] = d[2] }
      $1 ~ /^pair\.[0-9]+-[0-9]+\.placed\.[0-9]+$/ {
        p = pairof($1)
        m = split($2, t, " ")
        delete f
        for (i = 3; i < m; i += 2) f[t[i]] = t[i + 1]
        if (!("truth_gap_m" in f)) next
        is_true = (f["truth_gap_m"] + 0 <= tm && f["truth_gap_deg"] + 0 <= td)
        s = f["support"] + 0
        if (is_true && s > best_true[p]) best_true[p] = s
        if (!is_true && s > best_false[p]) best_false[p] = s
        if (is_true) any_true[p] = 1
        if (f["passed_on"] == "1") { passed[p] = is_true ? "true" : "false"; passed_support[p] = s }
      }
      END {
        for (i = 1; i <= n; i++) {
          p = order[i]
          if (!(shared[p] + 0 > 0) || stopped[p] == "merged" || stopped[p] == "no shared place") continue
          st = stopped[p]
          if (!(p in any_true)) why = "no true cluster"
          else if (best_false[p] + 0 > best_true[p] + 0) why = "look-alike outweighs"
          else if (passed[p] == "true") why = (st ~ /^registration|^descriptors disagree where|^off the confirmed|^frame solver/) ? "registration" : "true place refused"
          else why = "false passed on"
          printf "| %s | %s | %s | %s | %s | %s / %s | %s / %s | %s |\n", scenario, p, shared[p], st,
                 (p in passed) ? passed[p] ", " passed_support[p] : "-", (p in any_true) ? best_true[p] + 0 : "-",
                 best_false[p] + 0, (p in true_med) ? true_med[p] : "-", (p in false_p05) ? false_p05[p] : "-", why
        }
      }' "$f"
  done | awk -F' [|] ' '{ print; why[$NF]++; n++ }
    END { printf "\n%d pairs:", n; for (w in why) { sub(/ [|]$/, "", w); printf " %s %d;", w, why[w " |"] } print "" }'
  exit 0
fi
for f in "${files[@]}"; do
  scenario=${f%/"$run"/report/metrics.tsv}
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
