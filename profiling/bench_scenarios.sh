#!/usr/bin/env bash
# Usage: profiling/bench_scenarios.sh [--commerge BUILD/commerge] [--keyframes N] [--work DIR] [--quick]
#                                     [--direction alternate|same] [--wobble-deg D] [--detection-reflectivity R]
#                                     [--run-args "ARGS"] [--worlds "urban campus indoor cave"] [--reuse-data]
# The generated-scenario tables of profiling/RESULTS.md: for each world (urban, campus, indoor, cave), 2 and 3 robots,
# complete and partial overlap, `commerge sim` writes the dataset and `commerge run` (every exchange mode)
# merges it on the jetson-nano memory profile. Prints one markdown row per scenario: robots merged, worst
# alignment RMSE, bytes exchanged with the full cascade against sending every stored scan and against the
# paper's baseline (every keyframe's raw scan), server time (cascade + registration), and the process's peak RSS
# after the robots and at the end. --quick: urban only.
# --direction/--wobble-deg/--detection-reflectivity go to `commerge sim` (defaults: alternate, 0.5, 0 = off);
# --run-args adds options to every `commerge run` (e.g. "--min-submap-stored-points 0" for the paper's exact policy).
# --worlds: the worlds to run (default all four). --reuse-data: keep a scenario's dataset from an earlier run in
# the same --work directory (with the same sim options) and only run `commerge run` again.
set -euo pipefail
bin=build/commerge
keyframes=800
work=${TMPDIR:-/tmp}/commerge-scenarios
worlds="urban campus indoor cave"
direction=alternate
wobble=0.5
reflectivity=0
run_args=""
reuse=0
while [ $# -gt 0 ]; do
  case "$1" in
    --commerge) bin=$2; shift 2 ;;
    --keyframes) keyframes=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --quick) worlds="urban"; shift ;;
    --direction) direction=$2; shift 2 ;;
    --wobble-deg) wobble=$2; shift 2 ;;
    --detection-reflectivity) reflectivity=$2; shift 2 ;;
    --run-args) run_args=$2; shift 2 ;;
    --worlds) worlds=$2; shift 2 ;;
    --reuse-data) reuse=1; shift ;;
    -h|--help) sed -n '2,14p' "$0"; exit 0 ;;
    *) echo "bench_scenarios.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
for w in $worlds; do
  case "$w" in urban|campus|indoor|cave) ;; *) echo "bench_scenarios.sh: --worlds: unknown world '$w' (urban, campus, indoor, cave)" >&2; exit 2 ;; esac
done
[ -x "$bin" ] || { echo "bench_scenarios.sh: $bin is not an executable (use --commerge)" >&2; exit 2; }
mkdir -p "$work"
get() { awk -F'\t' -v k="$1" '$1 == k { print $2 }' "$2"; }
mib() { awk -v b="$1" 'BEGIN { printf "%.2f MiB", b / 1048576 }'; }
echo "keyframes per robot: $keyframes, lidar VLP-16, default drift, direction $direction, roll/pitch wobble $wobble deg, detection reflectivity $reflectivity; board profile jetson-nano${run_args:+; run options: $run_args}"
echo
echo "| world | robots | overlap | robots merged (widened pairs) | worst e_rmse | A+B+C bytes | send-all bytes | reduction | raw keyframe scans | reduction vs raw | server s (cascade + merge) | peak RSS after robots / end |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for world in $worlds; do
  for robots in 2 3; do
    for overlap in complete partial; do
      name="$world-$robots-$overlap"
      data="$work/$name/data"
      out="$work/$name/run"
      if [ "$reuse" = 0 ] || [ ! -f "$data/robot_$((robots - 1))/poses.txt" ]; then
        "$bin" sim --world "$world" --robots "$robots" --overlap "$overlap" --keyframes "$keyframes" --lidar vlp16 \
            --seed 11 --threads 2 --direction "$direction" --wobble-deg "$wobble" \
            --detection-reflectivity "$reflectivity" --out "$data" --force > "$work/$name.sim.log" 2>&1
      fi
      dirs=()
      for ((r = 0; r < robots; r++)); do dirs+=("$data/robot_$r"); done
      set +e
      "$bin" run "${dirs[@]}" --lidar vlp-16 --keyframe-spacing-m 0.9 --board jetson-nano --no-progress \
          --max-keyframes $((keyframes + 100)) --out "$out" $run_args > "$work/$name.run.log" 2>&1
      rc=$?
      set -e
      m="$out/report/metrics.tsv"
      if [ ! -f "$m" ]; then
        echo "| $world | $robots | $overlap | run failed (exit $rc, see $work/$name.run.log) | | | | | | | | |"
        continue
      fi
      all=$(get mode.send-all.total_bytes "$m"); abc=$(get mode.A+B+C.total_bytes "$m")
      red=$(awk -v a="$all" -v b="$abc" 'BEGIN { printf "%.2f %%", 100 * (1 - b / a) }')
      raw=$(get raw_keyframe_scan_bytes "$m")
      red_raw=$(awk -v a="$raw" -v b="$abc" 'BEGIN { printf "%.2f %%", 100 * (1 - b / a) }')
      rmse=$(get mode.A+B+C.worst_rmse_m "$m"); [ "$rmse" = "-1.000" ] && rmse="-" || rmse="$rmse m"
      server=$(awk -v c="$(get cascade_s "$m")" -v g="$(get mode.A+B+C.merge_s "$m")" 'BEGIN { printf "%.2f", c + g }')
      echo "| $world | $robots | $overlap | $(get mode.A+B+C.robots_merged "$m") ($(get mode.A+B+C.widened_pairs "$m")) | $rmse | $(mib "$abc") | $(mib "$all") | $red | $(mib "$raw") | $red_raw | $server | $(mib "$(get peak_rss_after_robots_bytes "$m")") / $(mib "$(get peak_rss_end_bytes "$m")") |"
    done
  done
done
