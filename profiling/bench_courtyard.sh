#!/usr/bin/env bash
# Usage: profiling/bench_courtyard.sh [--commerge BUILD/commerge] [--work DIR] [--seeds "101 102"]
#                                     [--overlap partial|moderate|complete] [--keyframes 32] [--run-args "ARGS"]
#                                     [--baseline-run-args "ARGS"] [--reuse-data]
# Small scenes (profiling/RESULTS.md "Small scenes: a courtyard walked by hand"): per seed, `commerge sim --world
# courtyard --lidar os0-128` writes two handheld walks, and `commerge run --lidar os0-128 --modes send-all,A+B+C`
# merges them with default flags plus --run-args; with --baseline-run-args a second run on the same data with
# those options instead (e.g. "--ground-up-min-tilt-deg 0"). One line per seed and run: send-all robots merged
# and worst e_rmse, A+B+C robots merged, right or wrong (robot 1 within 1 m / 3 deg of the truth where it met
# robot 0), its error, bytes against send-all's, the robots' lean from their ground, and why a pair was not merged.
# Then per run a summary: send-all merged, A+B+C right and wrong, the worst right error, the median A+B+C share
# of send-all's bytes. Exit 0 unless the simulator fails or a run writes no report.
set -euo pipefail
bin=build-host/commerge
work=${TMPDIR:-/tmp}/commerge-courtyard
seeds="101 102 103 104 105 106 107 108 109 110"
overlap=partial
keyframes=32
run_args=""
baseline_args=""
has_baseline=0
reuse=0
while [ $# -gt 0 ]; do
  case "$1" in
    --commerge) bin=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --overlap) overlap=$2; shift 2 ;;
    --keyframes) keyframes=$2; shift 2 ;;
    --run-args) run_args=$2; shift 2 ;;
    --baseline-run-args) baseline_args=$2; has_baseline=1; shift 2 ;;
    --reuse-data) reuse=1; shift ;;
    -h|--help) sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench_courtyard.sh: unknown option '$1' (--help)" >&2; exit 2 ;;
  esac
done
[ -x "$bin" ] || { echo "bench_courtyard.sh: no commerge binary at '$bin' (--commerge)" >&2; exit 2; }
mkdir -p "$work"

get() { awk -F'\t' -v k="$1" '$1 == k { print $2 }' "$2"; }

# run_one SEED LABEL ARGS: one `commerge run`, one line on stdout, the figures appended to WORK/LABEL.tsv.
run_one() {
  local seed=$1 label=$2 args=$3 data=$work/$overlap-s$1 out=$work/$overlap-s$1-$2
  # Exit 1 with a report is "a pair was not merged", a measurement; no report is a failure.
  # shellcheck disable=SC2086  # ARGS are words on purpose
  "$bin" run "$data/robot_0" "$data/robot_1" --lidar os0-128 --modes send-all,A+B+C --no-progress \
      --out "$out" $args >"$out.log" 2>&1 || true
  local m=$out/report/metrics.tsv verdict=refused why
  [ -f "$m" ] || { echo "bench_courtyard.sh: commerge run wrote no report: $out.log" >&2; exit 1; }
  [ "$(get mode.A+B+C.robots_merged "$m")" = "1/1" ] && verdict=right
  [ "$verdict" = right ] && [ "$(get robot.1.wrong "$m")" = "1" ] && verdict=wrong
  why=$(grep -o 'pair 0-1: not merged: .*' "$out.log" | head -1 | cut -c23-110 || true)
  printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$seed" "$(get mode.send-all.robots_merged "$m")" \
      "$(get mode.send-all.worst_rmse_m "$m")" "$verdict" "$(get robot.1.error_m "$m")" \
      "$(get mode.A+B+C.total_bytes "$m")" "$(get mode.send-all.total_bytes "$m")" \
      "$(get robot.0.ground_up_tilt_deg "$m") $(get robot.1.ground_up_tilt_deg "$m")" "$why" >>"$work/$label.tsv"
  printf '%s seed %s: send-all %s (e_rmse %s m), A+B+C %s %s m, bytes %s / %s, lean %s deg %s\n' "$label" "$seed" \
      "$(get mode.send-all.robots_merged "$m")" "$(get mode.send-all.worst_rmse_m "$m")" "$verdict" \
      "$(get robot.1.error_m "$m")" "$(get mode.A+B+C.total_bytes "$m")" "$(get mode.send-all.total_bytes "$m")" \
      "$(get robot.0.ground_up_tilt_deg "$m") / $(get robot.1.ground_up_tilt_deg "$m")" "$why"
}

summary() {
  local med
  med=$(awk -F'\t' '{ printf "%.3f\n", ($7 > 0 ? 100 * $6 / $7 : 0) }' "$work/$1.tsv" | sort -n |
        awk '{ v[NR] = $1 } END { if (NR == 0) print 0; else print (NR % 2 ? v[(NR + 1) / 2] : (v[NR / 2] + v[NR / 2 + 1]) / 2) }')
  awk -F'\t' -v label="$1" -v med="$med" '
    { n++; if ($2 == "1/1") sa++; if ($4 == "right") { right++; if ($5 + 0 > worst) worst = $5 + 0 } if ($4 == "wrong") wrong++ }
    END { printf "%s summary: %d seeds; send-all merged %d; A+B+C right %d, wrong %d; worst right error %.3f m; median A+B+C bytes %.1f %% of send-all\n",
                 label, n, sa, right, wrong, worst, med }' "$work/$1.tsv"
}

: >"$work/run.tsv"
[ "$has_baseline" = 1 ] && : >"$work/baseline.tsv"
for seed in $seeds; do
  data=$work/$overlap-s$seed
  if [ "$reuse" = 0 ] || [ ! -f "$data/sim_info.txt" ]; then
    "$bin" sim --world courtyard --overlap "$overlap" --keyframes "$keyframes" --lidar os0-128 --seed "$seed" \
        --out "$data" --force >"$data.sim.log" 2>&1 || { echo "bench_courtyard.sh: commerge sim failed: $data.sim.log" >&2; exit 1; }
  fi
  run_one "$seed" run "$run_args"
  [ "$has_baseline" = 1 ] && run_one "$seed" baseline "$baseline_args"
done
summary run
[ "$has_baseline" = 1 ] && summary baseline
exit 0
