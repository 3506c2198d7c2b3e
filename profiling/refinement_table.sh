#!/usr/bin/env bash
# Usage: profiling/refinement_table.sh BENCH_RECALL_OUTPUT...
# The final refinement's effect (core/agent/pair_refinement.hpp; profiling/RESULTS.md "Final refinement on spread
# scans") from the output of `bench_recall.sh --send-all --baseline-run-args "--refine-scans 0"` (rows of the run and
# "(baseline)" rows of the same scenarios). One markdown row per scenario: robots merged, wrong merges, worst
# e_rmse of A+B+C before / after and send-all's, the shared-path agreement RMS before / after, A+B+C bytes before /
# after. Then over every file: the median of A+B+C's worst e_rmse over send-all's (scenarios where send-all and both
# runs placed every robot they share a place with), the median shared-path RMS (scenarios with a figure both times)
# and in how many it fell, the median and total byte ratio. Exit 2 on a missing file.
set -euo pipefail
case "${1:-}" in -h|--help|"") sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
for f in "$@"; do [ -f "$f" ] || { echo "refinement_table.sh: no file '$f'" >&2; exit 2; }; done
echo "| scenario | merged | wrong | worst e_rmse before / after [m] | send-all [m] | shared-path RMS before / after [m] | A+B+C bytes before / after |"
echo "|---|---|---|---|---|---|---|"
awk -F'\t' '
  function median(a, n,   i, j, t) {
    for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
    return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
  }
  NF >= 16 && $1 !~ /^scenario/ && $2 ~ /^[0-9]+$/ {
    name = $1; base = sub(/ \(baseline\)$/, "", name)
    key = base ? "b" : "n"
    merged[key, name] = $4; wrong[key, name] = $5; rmse[key, name] = $7; bytes[key, name] = $8
    split($16, a, " / "); agree[key, name] = a[1]
    sa_ok[name] = 0; sa_rmse[name] = -1
    if (match($14, /^[0-9]+\/[0-9]+ \(/)) {
      split($14, s, /[\/ ()]+/); sa_ok[name] = (s[1] == s[2] && s[2] > 0); sa_all[name] = s[2]; sa_rmse[name] = s[3]
    }
    if (!(name in seen)) { seen[name] = 1; order[++k] = name }
  }
  END {
    for (i = 1; i <= k; i++) {
      nm = order[i]
      if (!(("b", nm) in merged) || !(("n", nm) in merged)) continue
      printf "| %s | %s / %s | %s / %s | %s / %s | %s | %s / %s | %s / %s |\n", nm, merged["b", nm], merged["n", nm],
             wrong["b", nm], wrong["n", nm], rmse["b", nm], rmse["n", nm], sa_rmse[nm] < 0 ? "-" : sa_rmse[nm],
             agree["b", nm], agree["n", nm], bytes["b", nm], bytes["n", nm]
      if (sa_ok[nm] && merged["b", nm] == sa_all[nm] && merged["n", nm] == sa_all[nm] && sa_rmse[nm] > 0 &&
          rmse["b", nm] > 0 && rmse["n", nm] > 0) {
        rb[++nr] = rmse["b", nm] / sa_rmse[nm]; rn[nr] = rmse["n", nm] / sa_rmse[nm]
      }
      if (agree["b", nm] ~ /^[0-9.]+$/ && agree["n", nm] ~ /^[0-9.]+$/) {
        ab[++na] = agree["b", nm]; an[na] = agree["n", nm]; fell += (an[na] + 0 < ab[na] + 0)
      }
      if (bytes["b", nm] > 0) { br[++nb] = bytes["n", nm] / bytes["b", nm]; tb += bytes["b", nm]; tn += bytes["n", nm] }
    }
    print ""
    if (nr > 0) printf "- worst e_rmse of A+B+C over send-all'"'"'s, median over %d scenarios: %.2f before, %.2f after\n", nr, median(rb, nr), median(rn, nr)
    if (na > 0) printf "- shared-path agreement RMS, median over %d scenarios: %.3f m before, %.3f m after; lower in %d\n", na, median(ab, na), median(an, na), fell
    if (nb > 0) printf "- A+B+C bytes after / before: median %.2f, total %.2f (%d scenarios)\n", median(br, nb), tn / tb, nb
  }' "$@"
