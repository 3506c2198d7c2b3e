#!/usr/bin/env bash
# profiling/placement_evidence.sh --pairs on hand-made run reports: one row per pair that shares a place and did not
# merge, with the class of evidence worked out by hand below (no true cluster, a look-alike of more support, a
# true place refused before registration, registration, a false cluster passed on over a better supported true
# one); merged pairs, pairs without shared path and pairs the benchmark says share no place are left out;
# --world keeps one world; a missing folder and an unknown --run are usage errors.
# Usage: placement_pairs_test.sh PLACEMENT_EVIDENCE_SH WORKDIR
set -euo pipefail
tool=$1
work=$2
rm -rf "$work"
report() {  # scenario, then lines "key<TAB>value"
  local dir=$work/runs/$1/run/report
  mkdir -p "$dir"
  shift
  printf '%s\n' "$@" > "$dir/metrics.tsv"
}
T=$'\t'
placed() {  # pair k support passed_on gap_m gap_deg
  echo "pair.$1.placed.$2${T}0-9 0-9 weight 10 support $3 passed_on $4 mean 0.1 colocated 5 ranked 5 agreeing 1 median_chance 0.3 truth_gap_m $5 truth_gap_deg $6"
}
report indoor-3r-partial-alternate-w0.5-k400-s11 \
  "pair.0-1.shared_path_m${T}60.0" "pair.0-1.stopped${T}ambiguous place" \
  "pair.0-1.true_distance_p05_p50_p95${T}0.09 0.15 0.28" "pair.0-1.false_distance_p01_p05_p50${T}0.08 0.11 0.21" \
  "$(placed 0-1 0 19 1 40.0 90.0)" "$(placed 0-1 1 31 0 0.6 0.4)" "$(placed 0-1 2 19 0 22.0 90.0)" \
  "pair.0-2.shared_path_m${T}70.0" "pair.0-2.stopped${T}ambiguous place" \
  "$(placed 0-2 0 28 1 30.0 180.0)" "$(placed 0-2 1 12 0 12.0 90.0)" \
  "pair.1-2.shared_path_m${T}65.0" "pair.1-2.stopped${T}registration (GNC failed)" \
  "$(placed 1-2 0 49 1 1.1 0.5)" "$(placed 1-2 1 49 0 6.0 2.0)" "$(placed 1-2 2 20 0 48.0 90.0)"
report indoor-2r-partial-alternate-w0.5-k400-s23 \
  "pair.0-1.shared_path_m${T}50.0" "pair.0-1.stopped${T}descriptors disagree at stage A's placement" \
  "$(placed 0-1 0 30 1 0.8 1.0)" "$(placed 0-1 1 25 0 24.0 0.5)"
report indoor-5r-partial-alternate-w0.5-k400-s31 \
  "pair.0-3.shared_path_m${T}66.0" "pair.0-3.stopped${T}place check" \
  "$(placed 0-3 0 16 1 3.0 1.0)" "$(placed 0-3 1 40 0 24.0 0.2)" \
  "pair.1-2.shared_path_m${T}60.0" "pair.1-2.stopped${T}merged" "$(placed 1-2 0 60 1 0.5 0.5)" \
  "pair.1-3.shared_path_m${T}0" "pair.1-3.stopped${T}ambiguous place" "$(placed 1-3 0 16 1 50.0 90.0)" \
  "pair.2-3.shared_path_m${T}6.0" "pair.2-3.stopped${T}no shared place" "$(placed 2-3 0 16 1 50.0 90.0)"
report cave-2r-moderate-alternate-w0.5-k400-s11 \
  "pair.0-1.shared_path_m${T}100.0" "pair.0-1.stopped${T}frame solver (inconsistent)" \
  "$(placed 0-1 0 90 1 0.4 0.2)" "$(placed 0-1 1 14 0 80.0 30.0)"

out=$("$tool" --pairs "$work/runs")
expect=(
  "| cave-2r-moderate-alternate-w0.5-k400-s11 | 0-1 | 100.0 | frame solver (inconsistent) | true, 90 | 90 / 14 | - / - | registration |"
  "| indoor-2r-partial-alternate-w0.5-k400-s23 | 0-1 | 50.0 | descriptors disagree at stage A's placement | true, 30 | 30 / 25 | - / - | true place refused |"
  "| indoor-3r-partial-alternate-w0.5-k400-s11 | 0-1 | 60.0 | ambiguous place | false, 19 | 31 / 19 | 0.15 / 0.11 | false passed on |"
  "| indoor-3r-partial-alternate-w0.5-k400-s11 | 0-2 | 70.0 | ambiguous place | false, 28 | - / 28 | - / - | no true cluster |"
  "| indoor-3r-partial-alternate-w0.5-k400-s11 | 1-2 | 65.0 | registration (GNC failed) | true, 49 | 49 / 49 | - / - | registration |"
  "| indoor-5r-partial-alternate-w0.5-k400-s31 | 0-3 | 66.0 | place check | true, 16 | 16 / 40 | - / - | look-alike outweighs |"
)
status=0
for line in "${expect[@]}"; do
  if ! grep -qxF -- "$line" <<< "$out"; then
    echo "missing: $line" >&2
    status=1
  fi
done
rows=$(grep -c '^| [a-z]*-[0-9]r-' <<< "$out" || true)
if [ "$rows" != "${#expect[@]}" ]; then
  echo "expected ${#expect[@]} pair rows, got $rows" >&2
  status=1
fi
counts="6 pairs: registration 2; true place refused 1; false passed on 1; no true cluster 1; look-alike outweighs 1;"
for part in "6 pairs:" "registration 2;" "true place refused 1;" "false passed on 1;" "no true cluster 1;" "look-alike outweighs 1;"; do
  grep -qF -- "$part" <<< "$(tail -1 <<< "$out")" || { echo "summary line lacks '$part' (want $counts)" >&2; status=1; }
done
one=$("$tool" --pairs --world cave "$work/runs")
[ "$(grep -c '^| [a-z]*-[0-9]r-' <<< "$one" || true)" = 1 ] || { echo "--world cave: expected 1 row" >&2; status=1; }
if "$tool" --pairs "$work/none" 2> /dev/null; then echo "a missing folder must be an error" >&2; status=1; fi
if "$tool" --pairs --run other "$work/runs" 2> /dev/null; then echo "--run other must be an error" >&2; status=1; fi
[ "$status" = 0 ] && echo "placement_pairs_test: ${#expect[@]} rows as worked out by hand"
exit "$status"
