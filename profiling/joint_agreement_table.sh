#!/usr/bin/env bash
# Usage: profiling/joint_agreement_table.sh BENCH_RECALL_WORK...
# The joint pose graph against the rigid merge (profiling/RESULTS.md "Joint pose graph on the refinement's
# places") from `bench_recall.sh` work directories: per scenario with a shared-path figure, from its
# run/report/metrics.tsv, the agreement RMS and 95th percentile of the rigid merge and of the joint graph, and
# the inter-robot edges used / given. Then over all of them: the medians, in how many the joint graph is lower /
# higher, the worst joint / rigid ratio and the largest RMS of each. Exit 2 on a missing directory.
set -euo pipefail
case "${1:-}" in -h|--help|"") sed -n '2,7p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
for w in "$@"; do [ -d "$w" ] || { echo "joint_agreement_table.sh: no directory '$w'" >&2; exit 2; }; done
echo "| scenario | RMS rigid / joint [m] | p95 rigid / joint [m] | edges used / given |"
echo "|---|---|---|---|"
for w in "$@"; do
  for m in "$w"/*/run/report/metrics.tsv; do
    [ -f "$m" ] || continue
    name=$(basename "$(dirname "$(dirname "$(dirname "$m")")")")
    awk -F'\t' -v name="$name" '{ v[$1] = $2 }
      END { if (v["path_agreement_rms_m"] == "" || v["joint_path_agreement_rms_m"] == "") exit
            printf "%s\t%s\t%s\t%s\t%s\t%s\t%s\n", name, v["path_agreement_rms_m"], v["joint_path_agreement_rms_m"],
                   v["path_agreement_p95_m"], v["joint_path_agreement_p95_m"], v["joint_edges_used"], v["joint_edges"] }' "$m"
  done
done | awk -F'\t' '
  function median(a, n,   i, j, t) {
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
    return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
  }
  { n++; r[n] = $2; j[n] = $3; rp[n] = $4; jp[n] = $5
    printf "| %s | %.3f / %.3f | %.3f / %.3f | %s / %s |\n", $1, $2, $3, $4, $5, $6, $7
    lower += $3 < $2; higher += $3 > $2
    if ($2 > 0 && $3 / $2 > worst) { worst = $3 / $2; worst_name = $1 }
    if ($2 > rmax) rmax = $2; if ($3 > jmax) jmax = $3 }
  END { if (n == 0) { print "no scenario with a shared-path figure"; exit }
        mr = median(r, n); mj = median(j, n); mrp = median(rp, n); mjp = median(jp, n)
        printf "\n%d scenarios: median RMS rigid %.3f / joint %.3f m, median p95 %.3f / %.3f m; joint lower in %d, higher in %d; worst joint / rigid %.2f (%s); largest RMS %.3f / %.3f m\n",
               n, mr, mj, mrp, mjp, lower, higher, worst, worst_name, rmax, jmax }'
