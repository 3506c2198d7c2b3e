#!/usr/bin/env bash
# profiling/bench_recall.sh --summarise with --tune-seeds / --test-seeds on hand-made rows: the per seed set and
# world lines must count the rows of each seed set (from the names' -sSEED) and world (the livox model apart, real
# splits apart) as worked out by hand below, also for a baseline's rows (names ending in " (baseline)"); a seed in
# both sets and a seed that is not a number are usage errors.
# Usage: recall_split_test.sh BENCH_RECALL_SH WORKDIR
set -euo pipefail
bench=$1
work=$2
mkdir -p "$work"
rows=$work/rows.tsv
row() {  # name other sharing merged wrong reduction% reduction-vs-raw%
  printf '%s\t%s\t%s\t%s\t%s\t0.00 m / 0.00 deg\t0.1\t100\t1000\t%s\t10000\t%s\t-\t-\t0.10 m\n' "$@"
}
{
  row urban-2r-moderate-alternate-w0.5-k400-s11 1 1 1 0 96.00 99.900
  row urban-3r-partial-alternate-w0.5-k400-s11 2 2 1 0 94.00 99.800
  row indoor-2r-partial-alternate-w0.5-k400-s11 1 1 0 0 97.00 99.950
  row urban-2r-moderate-alternate-w0.5-k400-s101 1 1 1 0 95.00 99.910
  row urban-5r-partial-alternate-w0.5-k400-s101 4 3 2 1 92.00 99.700
  row urban-5r-partial-alternate-w0.5-k400-s102 4 4 4 0 93.00 99.750
  row cave-2r-moderate-alternate-w0.5-livox-k400-s101 1 1 1 0 90.00 99.600
  row campus-2r-moderate-alternate-w0.5-k400-s7 1 1 1 0 98.00 99.990
  row hku2-halves 1 1 1 0 80.00 98.800
} > "$rows"
out=$("$bench" --summarise "$rows" --tune-seeds "11" --test-seeds "101 102")
expect=(
  "summary: 9 scenarios; recall 12 of 15 robots that share a place (80.0 %); real splits: 1 of 1 robots merged; 1 wrong merges; median reduction 94.00 % vs stored send-all, 99.800 % vs raw scans"
  "tune seeds, urban: 2 scenarios; recall 2 of 3 (66.7 %); 0 wrong merges; median reduction 95.00 % vs stored send-all, 99.850 % vs raw scans"
  "tune seeds, indoor: 1 scenarios; recall 0 of 1 (0.0 %); 0 wrong merges; median reduction 97.00 % vs stored send-all, 99.950 % vs raw scans"
  "test seeds, urban: 3 scenarios; recall 7 of 8 (87.5 %); 1 wrong merges; median reduction 93.00 % vs stored send-all, 99.750 % vs raw scans"
  "test seeds, cave livox: 1 scenarios; recall 1 of 1 (100.0 %); 0 wrong merges; median reduction 90.00 % vs stored send-all, 99.600 % vs raw scans"
  "other seeds, campus: 1 scenarios; recall 1 of 1 (100.0 %); 0 wrong merges; median reduction 98.00 % vs stored send-all, 99.990 % vs raw scans"
  "real splits, hku2: 1 scenarios; recall 1 of 1 (100.0 %); 0 wrong merges; median reduction 80.00 % vs stored send-all, 98.800 % vs raw scans"
)
status=0
for line in "${expect[@]}"; do
  grep -qxF "$line" <<<"$out" || { echo "missing: $line"; status=1; }
done
[ "$(wc -l <<<"$out")" -eq "${#expect[@]}" ] || { echo "expected ${#expect[@]} lines, got:"; echo "$out"; status=1; }
set +e
both=$("$bench" --summarise "$rows" --tune-seeds "11 101" --test-seeds "101" 2>&1); rc_both=$?
word=$("$bench" --summarise "$rows" --tune-seeds "11 x" 2>&1); rc_word=$?
set -e
[[ $rc_both -eq 2 && $both == *"seed 101 is both a tune and a test seed"* ]] || { echo "both sets: rc $rc_both: $both"; status=1; }
[[ $rc_word -eq 2 && $word == *"seed 'x' is not a non-negative integer"* ]] || { echo "not a number: rc $rc_word: $word"; status=1; }
# The baseline's rows (WORK/baseline.tsv) carry " (baseline)" after the name: the same seed sets and worlds.
sed 's/^\([^\t]*\)\t/\1 (baseline)\t/' "$rows" > "$work/baseline.tsv"
base=$("$bench" --summarise "$work/baseline.tsv" --tune-seeds "11" --test-seeds "101 102")
[[ "$base" == "$out" ]] || { echo "baseline rows summarised differently:"; diff <(echo "$out") <(echo "$base"); status=1; }
[[ $status -eq 0 ]] && echo "tune and test seeds summarised per world as worked out by hand"
exit $status
