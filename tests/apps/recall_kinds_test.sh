#!/usr/bin/env bash
# profiling/bench_recall.sh --summarise on hand-made rows with a bytes_by_kind.tsv beside them: the "bytes by kind"
# block must give, per kind, the median over the scenarios of the rows file of its bytes and of its shares of the
# stored send-all and of the raw scans, as worked out by hand below; a scenario only in bytes_by_kind.tsv and a
# failed run are left out.
# Usage: recall_kinds_test.sh BENCH_RECALL_SH WORKDIR
set -euo pipefail
bench=$1
work=$2
mkdir -p "$work"
rows=$work/rows.tsv
row() {  # name total stored reduction% raw reduction-vs-raw%
  printf '%s\t1\t1\t1\t0\t0.00 m / 0.00 deg\t0.1\t%s\t%s\t%s\t%s\t%s\t-\t-\t0.10 m\n' "$@"
}
{
  row s1 10000 100000 90.00 1000000 99.000
  row s2 20000 400000 95.00 10000000 99.800
  printf 'failed\trun failed (exit 1, see failed.run.log)\n'
  row s3 5000 20000 75.00 500000 99.000
} > "$rows"
{
  printf 'scenario\tkeyframes_bytes\tpose_updates_bytes\tpolicies_bytes\tscans_bytes\tstatus_bytes\tother_bytes\ttotal_bytes\tstored_send_all_bytes\traw_scan_bytes\n'
  printf 's1\t1000\t200\t100\t8700\t0\t0\t10000\t100000\t1000000\n'
  printf 's2\t2000\t0\t200\t17800\t0\t0\t20000\t400000\t10000000\n'
  printf 'only-here\t9\t9\t9\t9\t9\t9\t54\t60\t70\n'
  printf 'failed\t9\t9\t9\t9\t9\t9\t54\t60\t70\n'
  printf 's3\t500\t100\t50\t4350\t0\t0\t5000\t20000\t500000\n'
} > "$work/bytes_by_kind.tsv"
# By hand, over s1, s2, s3: keyframes 1000 2000 500 B = 1 0.5 2.5 % of the stored send-all, 0.1 0.02 0.1 % of
# the raw scans; pose updates 200 0 100 = 0.2 0 0.5 %, 0.02 0 0.02 %; policies 100 200 50 = 0.1 0.05 0.25 %,
# 0.01 0.002 0.01 %; scans 8700 17800 4350 = 8.7 4.45 21.75 %, 0.87 0.178 0.87 %; total 10000 20000 5000 = 10 5
# 25 %, 1 0.2 1 % (100 % less the summary's median reduction, 90 % and 99 %).
out=$("$bench" --summarise "$rows")
norm=$(tr -s ' ' <<<"$out" | sed 's/^ //')
expect=(
  "summary: 3 scenarios; recall 3 of 3 robots that share a place (100.0 %); real splits: 0 of 0 robots merged; 0 wrong merges; median reduction 90.00 % vs stored send-all, 99.000 % vs raw scans"
  "bytes by kind: A+B+C (the robots' stream + the mode's messages), medians over 3 scenarios"
  "kind bytes % stored send-all % raw scans"
  "keyframes 1000 1.000 0.1000"
  "pose_updates 100 0.200 0.0200"
  "policies 100 0.100 0.0100"
  "scans 8700 8.700 0.8700"
  "status 0 0.000 0.0000"
  "other 0 0.000 0.0000"
  "total 10000 10.000 1.0000"
  "stored send-all 100000"
  "raw scans 1000000"
)
status=0
for line in "${expect[@]}"; do
  grep -qxF "$line" <<<"$norm" || { echo "missing: $line"; status=1; }
done
[ "$(wc -l <<<"$out")" -eq "${#expect[@]}" ] || { echo "expected ${#expect[@]} lines, got:"; echo "$out"; status=1; }
[[ $status -eq 0 ]] && echo "bytes by kind: medians of bytes and shares as worked out by hand"
exit $status
