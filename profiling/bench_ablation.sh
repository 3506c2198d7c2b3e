#!/usr/bin/env bash
# Usage: profiling/bench_ablation.sh [--commerge BUILD/commerge] [--work DIR] [--keyframes 400] [--seed 11]
#                                    [--worlds "urban campus indoor cave"] [--robots "2 3"]
#                                    [--overlaps "complete moderate partial"] [--run-args "ARGS"] [--drop-data]
# The exchange-mode ablation (the paper's Table "ablation2") under one rule for every mode, beside the paper's
# exact policy. Per generated scenario (`commerge sim`, VLP-16, the simulator's default directions and wobble,
# --keyframes per robot) `commerge run --modes send-all,A,A+B,A+C,A+B+C` runs twice on the same data:
#   ours         the default flags: every mode's selection is padded with stage A's keyframes until each robot's
#                scans hold --min-submap-stored-points (3 000) points, and a refused pair is widened up to
#                --max-widen-steps (2) times; an accepted pair is refined on --refine-scans (2) spread scans
#   paper-exact  --min-submap-scans 0 --min-submap-stored-points 0 --max-widen-steps 0 --refine-scans 0: exactly
#                the mode's selection, one registration
# One row per scenario and mode: scans sent as selected + padded + widened (+ refined) (the mode's own selection: send-all
# every stored scan, A L_seq's endpoints, A+B the cover, A+C the clique's endpoints, A+B+C L_K's endpoints),
# total bytes exchanged (keyframe records included) and robots placed, for both columns. Then per mode the sums
# over the scenarios. Exit 0 unless a run fails (a crash, an unreadable input).
set -euo pipefail
bin=build/commerge
work=${TMPDIR:-/tmp}/commerge-ablation
keyframes=400
seed=11
worlds="urban campus indoor cave"
robot_counts="2 3"
overlaps="complete moderate partial"
run_args=""
drop_data=0
while [ $# -gt 0 ]; do
  case "$1" in
    --commerge) bin=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --keyframes) keyframes=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    --worlds) worlds=$2; shift 2 ;;
    --robots) robot_counts=$2; shift 2 ;;
    --overlaps) overlaps=$2; shift 2 ;;
    --run-args) run_args=$2; shift 2 ;;
    --drop-data) drop_data=1; shift ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d'; exit 0 ;;
    *) echo "bench_ablation.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -x "$bin" ] || { echo "bench_ablation.sh: $bin is not an executable (use --commerge)" >&2; exit 2; }
mkdir -p "$work"
get() { awk -F'\t' -v k="$1" '$1 == k { print $2 }' "$2"; }
modes=(send-all A A+B A+C A+B+C)
sums="$work/sums.tsv"
: > "$sums"
failures=0
echo "commerge ablation: $keyframes keyframes per robot, seed $seed, worlds $worlds, robots $robot_counts, overlaps $overlaps${run_args:+, run options: $run_args}"
echo
echo "| scenario | mode | ours: scans (selected + padded + widened + refined) | ours: bytes | ours: robots placed | paper-exact: scans (selected) | paper-exact: bytes | paper-exact: robots placed |"
echo "|---|---|---|---|---|---|---|---|"
for world in $worlds; do
  for robots in $robot_counts; do
    for overlap in $overlaps; do
      name="$world-${robots}r-$overlap-k$keyframes-s$seed"
      data="$work/$name/data"
      if [ ! -f "$data/robot_$((robots - 1))/poses.txt" ]; then
        "$bin" sim --world "$world" --robots "$robots" --overlap "$overlap" --keyframes "$keyframes" --lidar vlp16 \
            --seed "$seed" --threads 2 --out "$data" --force > "$work/$name.sim.log" 2>&1
      fi
      dirs=()
      for ((r = 0; r < robots; r++)); do dirs+=("$data/robot_$r"); done
      declare -A m=()
      for column in ours paper; do
        extra=""
        [ "$column" = paper ] && extra="--min-submap-scans 0 --min-submap-stored-points 0 --max-widen-steps 0 --refine-scans 0"
        out="$work/$name/$column"
        set +e
        # The simulator writes one scan per metre: a keyframe every 0.9 m keeps every scan despite odometry noise.
        "$bin" run "${dirs[@]}" --lidar vlp-16 --keyframe-spacing-m 0.9 --max-keyframes $((keyframes + 100)) \
            --modes send-all,A,A+B,A+C,A+B+C --no-report --no-progress --out "$out" $extra $run_args \
            > "$work/$name.$column.log" 2>&1
        rc=$?
        set -e
        m[$column]="$out/report/metrics.tsv"
        if [ ! -f "${m[$column]}" ]; then
          echo "| $name | run failed (exit $rc, see $work/$name.$column.log) | | | | | | |"
          failures=$((failures + 1))
          continue 2
        fi
      done
      for mode in "${modes[@]}"; do
        p="mode.$mode."
        o=${m[ours]} e=${m[paper]}
        echo "| $name | $mode | $(get "${p}scans" "$o") ($(get "${p}scans_selected" "$o") + $(get "${p}scans_padded" "$o") + $(get "${p}scans_widened" "$o") + $(get "${p}scans_refined" "$o")) | $(get "${p}total_bytes" "$o") | $(get "${p}robots_merged" "$o") | $(get "${p}scans" "$e") ($(get "${p}scans_selected" "$e")) | $(get "${p}total_bytes" "$e") | $(get "${p}robots_merged" "$e") |"
        printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$mode" "$(get "${p}scans_selected" "$o")" \
            "$(get "${p}scans_padded" "$o")" "$(get "${p}scans_widened" "$o")" "$(get "${p}total_bytes" "$o")" \
            "$(get "${p}robots_merged" "$o" | cut -d/ -f1)" "$(get "${p}scans_selected" "$e")" \
            "$(get "${p}total_bytes" "$e")" "$(get "${p}robots_merged" "$e" | cut -d/ -f1)" \
            "$(get "${p}robots_merged" "$o" | cut -d/ -f2)" "$(get "${p}scans_refined" "$o")" >> "$sums"
      done
      unset m
      if [ "$drop_data" = 1 ]; then rm -rf "$data"; fi
    done
  done
done
echo
echo "Sums over the scenarios:"
echo
echo "| mode | ours: scans (selected + padded + widened + refined) | ours: MiB | ours: robots placed | paper-exact: scans | paper-exact: MiB | paper-exact: robots placed |"
echo "|---|---|---|---|---|---|---|"
for mode in "${modes[@]}"; do
  awk -F'\t' -v mode="$mode" '$1 == mode { s += $2; p += $3; w += $4; b += $5; r += $6; es += $7; eb += $8; er += $9; n += $10; f += $11 }
    END { printf "| %s | %d (%d + %d + %d + %d) | %.2f | %d of %d | %d | %.2f | %d of %d |\n", mode, s + p + w + f, s, p, w, f,
          b / 1048576, r, n, es, eb / 1048576, er, n }' "$sums"
done
[ "$failures" = 0 ] || { echo "bench_ablation.sh: $failures runs failed" >&2; exit 1; }
