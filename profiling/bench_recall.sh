#!/usr/bin/env bash
# Usage: profiling/bench_recall.sh [--commerge BUILD/commerge] [--work DIR] [--slice quick|generated|long|livox|real|all]
#                                  [--seeds "11 12"] [--keyframes 800] [--long-keyframes 3000] [--run-args "ARGS"]
#                                  [--worlds "urban campus indoor cave"] [--reuse-data] [--shared-data DIR]
#                                  [--send-all] [--only REGEX] [--drop-data]
#                                  [--baseline-commerge BIN] [--baseline-run-args "ARGS"]
#                                  [--tune-seeds "11 23" --test-seeds "S1 S2 S3"] [--summarise ROWS.tsv]
# Merge recall of `commerge run` with its default flags (only --lidar, and the data's own description:
# keyframe spacing of generated data, odometry and reference files of real data), scenario by scenario:
#   generated  every world x 2, 3 and 5 robots x complete / moderate / partial overlap x same / alternating
#              directions x roll-pitch wobble 0 and the simulator's default, --keyframes per robot, per seed;
#   long       a --long-keyframes subset: every world x 2 robots x complete / partial, the simulator's defaults;
#   livox      the simulator's forward-looking Livox model (70 deg cone, non-repetitive; run as --lidar avia):
#              every world x 2 and 3 robots x complete / moderate / partial x same / alternating directions,
#              wobble 0.5 deg, --keyframes per robot, per seed (a forward-looking sensor like the real
#              sequences'; profiling/RESULTS.md "Descriptor distances" compares both sensors with the real data);
#   real       ../shared/data/real/{hku_mb,hku2} split in halves, thirds and two overlapping windows (odometry
#              from odom_poses.txt, reference from poses.txt), and KITTI 00 frames 0-10 / 5-16;
#   quick      a CI slice (the `heavy` test "recall: quick slice ..."): the simulator's default setting on the
#              campus with five robots (moderate overlap, both ways, wobble 0.5 deg, 400 keyframes, seed 5, a tune
#              seed), the indoor world with three robots (the same setting, seed 59, a test seed:
#              core/agent/decisions/024-tune-and-test-seeds.md; --seeds and --keyframes do not apply) and the hku2
#              halves;
#   all        generated + long + livox + real.
# Per scenario one row: robots that truly share a place with robot 0's component (from ground truth,
# core/eval/shared_place.hpp), robots merged (right and wrong: > 1 m or > 3 deg from the truth where the
# robot met a placed robot, core/eval TruthAtSharedPlace, at the keyframes their registration used), the worst
# such error, the worst e_rmse, bytes of
# A+B+C against sending every stored scan and against every raw keyframe scan, the stage that stopped each pair
# that shares a place and was not merged, and the worst translation error against the transform of the true
# start poses (what drift adds), and how the placed robots agree along the path they share (keyframes of two robots
# within 10 m: RMS and 95th percentile of their relative position's error, core/eval/path_agreement.hpp; "-"
# without ground truth or two placed robots that came that close). Then one summary line: recall, real splits merged, wrong merges, median byte
# reductions. Exit 0 (it measures; it does not judge) unless a run fails (a crash, an unreadable input; "no pair merged" is a measurement, not a failure).
# Bytes by kind: per scenario the A+B+C bytes split by message kind (metrics.tsv mode.A+B+C.bytes.<kind>: the
# robots' stream plus the mode's own messages) go to WORK/bytes_by_kind.tsv: a header line, then one row per
# scenario: name, keyframes, pose_updates, policies, scans, status, other (bytes each), total (their sum, the row's
# A+B+C bytes; a run whose kinds do not sum to it counts as failed), stored send-all, raw scan bytes. After the
# summary lines one "bytes by kind" block: per kind the median over the scenarios of its bytes, of its share of
# the stored send-all and of its share of the raw scans (medians of the percentages), the same for the total, and
# the median bytes of the stored send-all and of the raw scans.
# --run-args adds options to every `commerge run` (e.g. the paper's cascade: "--profile paper").
# --only runs just the scenarios whose name matches the extended regular expression (a before/after subset).
# --send-all also runs mode send-all (each pair registers the two complete stored maps) and adds its column:
# robots placed / other robots and the worst e_rmse, what shipping everything buys.
# --drop-data deletes each generated scenario's data once its run is done (0.7-1.8 GB per scenario at 800
# keyframes: the whole matrix does not fit on most disks); the rows and run reports stay. Without it the data
# stays for --reuse-data.
# --baseline-commerge / --baseline-run-args: every scenario runs a second time on the same data, with that
# binary (default: --commerge) and those options instead of --run-args, before the data is dropped; its rows are
# printed with " (baseline)" after the name, kept in WORK/baseline.tsv (reports in WORK/NAME/baseline), and a
# second summary line says what the baseline measured: a before / after over the whole matrix without keeping
# its data.
# --tune-seeds / --test-seeds: the seeds run are both lists (instead of --seeds); after the summary line, one line
# per seed set and world (the livox model counts as its own world, the real splits as "real"): recall, wrong
# merges, median reductions. Tune seeds are those any threshold was chosen on; test seeds were never looked at
# while choosing (core/agent/decisions/024-tune-and-test-seeds.md says which are which).
# --summarise ROWS.tsv prints the summary lines of a rows file (WORK/rows.tsv of an earlier run) and runs nothing;
# with --tune-seeds / --test-seeds the split lines too; and the bytes by kind block when a bytes_by_kind.tsv sits
# beside the rows file (over the scenarios both files hold).
set -euo pipefail
bin=build/commerge
work=${TMPDIR:-/tmp}/commerge-recall
slice=all
seeds="11"
keyframes=800
long_keyframes=3000
run_args=""
worlds="urban campus indoor cave"
reuse=0
shared=""
send_all=0
only=""
drop_data=0
base_bin=""
base_args=""
baseline=0
tune_seeds=""
test_seeds=""
summarise_only=""
while [ $# -gt 0 ]; do
  case "$1" in
    --commerge) bin=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --slice) slice=$2; shift 2 ;;
    --seeds) seeds=$2; shift 2 ;;
    --keyframes) keyframes=$2; shift 2 ;;
    --long-keyframes) long_keyframes=$2; shift 2 ;;
    --run-args) run_args=$2; shift 2 ;;
    --worlds) worlds=$2; shift 2 ;;
    --reuse-data) reuse=1; shift ;;
    --send-all) send_all=1; shift ;;
    --only) only=$2; shift 2 ;;
    --drop-data) drop_data=1; shift ;;
    --baseline-commerge) base_bin=$2; baseline=1; shift 2 ;;
    --baseline-run-args) base_args=$2; baseline=1; shift 2 ;;
    --shared-data) shared=$2; shift 2 ;;
    --tune-seeds) tune_seeds=$2; shift 2 ;;
    --test-seeds) test_seeds=$2; shift 2 ;;
    --summarise) summarise_only=$2; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d'; exit 0 ;;
    *) echo "bench_recall.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
# One summary line of a rows file; $1 = what the line starts with.
summarise() {
  awk -F'\t' -v label="$1" '
  NF >= 13 { reach += $3; merged += $4; wrong += $5; n++; red[n] = $10; raw[n] = $12
             if ($1 ~ /^(hku|kitti)/) { real_robots += $2; real_merged += $4 } }
  function median(a, k,   i, j, t) {
    for (i = 1; i <= k; i++) for (j = i + 1; j <= k; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
    return k % 2 ? a[(k + 1) / 2] : (a[k / 2] + a[k / 2 + 1]) / 2
  }
  END {
    if (n == 0) { print label ": no scenario ran"; exit }
    printf "%s: %d scenarios; recall %d of %d robots that share a place (%.1f %%); real splits: %d of %d robots merged; %d wrong merges; median reduction %.2f %% vs stored send-all, %.3f %% vs raw scans\n",
           label, n, merged, reach, reach ? 100 * merged / reach : 100, real_merged, real_robots, wrong, median(red, n), median(raw, n)
  }' "$2"
}
# One line per seed set (tune / test, from the scenario name's -sSEED) and world (the name's first word; the
# livox model's rows as "WORLD livox"; real splits as "real"). $1 = rows file (WORK/rows.tsv, or WORK/baseline.tsv
# whose names end in " (baseline)").
summarise_split() {
  awk -F'\t' -v tune=" $tune_seeds " -v test=" $test_seeds " '
  function median(a, key, k,   i, j, t, v) {
    for (i = 1; i <= k; i++) v[i] = a[key, i]
    for (i = 1; i <= k; i++) for (j = i + 1; j <= k; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
    return k % 2 ? v[(k + 1) / 2] : (v[k / 2] + v[k / 2 + 1]) / 2
  }
  NF >= 13 && $1 != "scenario" {
    name = $1; sub(/ \(baseline\)$/, "", name); world = name; sub(/-.*/, "", world)
    if (name ~ /-livox-/) world = world " livox"
    set = "real"
    if (match(name, /-s[0-9]+$/)) {
      seed = substr(name, RSTART + 2)
      set = index(tune, " " seed " ") ? "tune" : (index(test, " " seed " ") ? "test" : "other")
    }
    key = set " " world
    if (!(key in n)) order[++k] = key
    n[key]++; reach[key] += $3; merged[key] += $4; wrong[key] += $5; red[key, n[key]] = $10; raw[key, n[key]] = $12
  }
  END {
    for (s = 1; s <= 4; s++) {
      setname = s == 1 ? "tune" : (s == 2 ? "test" : (s == 3 ? "other" : "real"))
      label = setname == "real" ? "real splits" : setname " seeds"
      for (i = 1; i <= k; i++) {
        key = order[i]; if (substr(key, 1, length(setname) + 1) != setname " ") continue
        printf "%s, %s: %d scenarios; recall %d of %d (%.1f %%); %d wrong merges; median reduction %.2f %% vs stored send-all, %.3f %% vs raw scans\n",
               label, substr(key, length(setname) + 2), n[key], merged[key], reach[key],
               reach[key] ? 100 * merged[key] / reach[key] : 100, wrong[key], median(red, key, n[key]), median(raw, key, n[key])
      }
    }
  }' "$1"
}
# The bytes by kind block: $1 = rows file, $2 = its bytes_by_kind.tsv; over the scenarios of both files, per kind
# the median of the bytes and of the percentages of the stored send-all and of the raw scans. Nothing when $2 is
# absent.
summarise_kinds() {
  [ -f "$2" ] || return 0
  awk -F'\t' '
  function median(a, k,   i, j, t) {
    if (k == 0) return -1
    for (i = 1; i <= k; i++) for (j = i + 1; j <= k; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
    return k % 2 ? a[(k + 1) / 2] : (a[k / 2] + a[k / 2 + 1]) / 2
  }
  function pct(v, digits) { return v < 0 ? "-" : sprintf("%." digits "f", v) }
  FILENAME == ARGV[1] { if (NF >= 13) in_rows[$1] = 1; next }
  FNR == 1 && $1 == "scenario" { for (c = 2; c <= 10; c++) kind[c] = $c; next }
  ($1 in in_rows) && NF >= 10 {
    n++
    for (c = 2; c <= 10; c++) bytes[c, n] = $c
    for (c = 2; c <= 8; c++) {
      if ($9 > 0) { ns[c]++; stored[c, ns[c]] = 100 * $c / $9 }
      if ($10 > 0) { nr[c]++; raw[c, nr[c]] = 100 * $c / $10 }
    }
  }
  END {
    if (n == 0) exit
    printf "bytes by kind: A+B+C (the robots\047 stream + the mode\047s messages), medians over %d scenarios\n", n
    printf "  %-16s %14s %18s %14s\n", "kind", "bytes", "% stored send-all", "% raw scans"
    for (c = 2; c <= 10; c++) {
      name = kind[c]; sub(/_bytes$/, "", name)
      for (i = 1; i <= n; i++) b[i] = bytes[c, i]
      for (i = 1; i <= ns[c]; i++) p[i] = stored[c, i]
      for (i = 1; i <= nr[c]; i++) q[i] = raw[c, i]
      if (c <= 8) printf "  %-16s %14.0f %18s %14s\n", name, median(b, n), pct(median(p, ns[c]), 3), pct(median(q, nr[c]), 4)
      else printf "  %-16s %14.0f\n", c == 9 ? "stored send-all" : "raw scans", median(b, n)
      delete b; delete p; delete q
    }
  }' "$1" "$2"
}
if [ -n "$tune_seeds$test_seeds" ]; then
  seeds=$(echo $tune_seeds $test_seeds)
  for seed in $seeds; do
    [[ "$seed" =~ ^[0-9]+$ ]] || { echo "bench_recall.sh: seed '$seed' is not a non-negative integer" >&2; exit 2; }
  done
  for seed in $tune_seeds; do
    case " $test_seeds " in *" $seed "*) echo "bench_recall.sh: seed $seed is both a tune and a test seed" >&2; exit 2 ;; esac
  done
fi
if [ -n "$summarise_only" ]; then
  [ -f "$summarise_only" ] || { echo "bench_recall.sh: --summarise: no file $summarise_only" >&2; exit 2; }
  summarise summary "$summarise_only"
  [ -z "$tune_seeds$test_seeds" ] || summarise_split "$summarise_only"
  summarise_kinds "$summarise_only" "$(dirname "$summarise_only")/bytes_by_kind.tsv"
  exit 0
fi
case "$slice" in quick|generated|long|livox|real|all) ;; *) echo "bench_recall.sh: --slice: quick, generated, long, livox, real or all" >&2; exit 2 ;; esac
[ -x "$bin" ] || { echo "bench_recall.sh: $bin is not an executable (use --commerge)" >&2; exit 2; }
[ -n "$base_bin" ] || base_bin=$bin
[ -x "$base_bin" ] || { echo "bench_recall.sh: $base_bin is not an executable (--baseline-commerge)" >&2; exit 2; }
here=$(cd "$(dirname "$0")" && pwd)
[ -n "$shared" ] || shared=${COMMERGE_SHARED_DATA:-$here/../../shared/data}
mkdir -p "$work"
rows="$work/rows.tsv"
base_rows="$work/baseline.tsv"
by_kind="$work/bytes_by_kind.tsv"
kinds="keyframes pose_updates policies scans status other"
: > "$rows"
{ printf 'scenario'; for k in $kinds; do printf '\t%s_bytes' "$k"; done
  printf '\ttotal_bytes\tstored_send_all_bytes\traw_scan_bytes\n'; } > "$by_kind"
[ "$baseline" = 0 ] || : > "$base_rows"
failures=0
get() { awk -F'\t' -v k="$1" '$1 == k { print $2 }' "$2"; }

# One scenario: the baseline run (when asked for), then the run measured. $1 = name, $2 = lidar preset, then
# dataset specs; extra run options in the array `opts`.
run_scenario() {
  if [ -n "$only" ] && ! [[ "$1" =~ $only ]]; then return; fi
  if [ "$baseline" = 1 ]; then
    run_one "$base_bin" "$base_args" baseline "$base_rows" " (baseline)" "$@"
  fi
  run_one "$bin" "$run_args" run "$rows" "" "$@"
}

# One `commerge run`; appends its row to a rows file (and prints it). $1 = binary, $2 = its extra options, $3 =
# report folder under WORK/NAME, $4 = rows file, $5 = what the printed name gets after it, $6 = name, $7 = lidar
# preset, then dataset specs.
run_one() {
  local run_bin=$1 args=$2 sub=$3 rows_file=$4 label=$5 name=$6 lidar=$7
  shift 7
  local out="$work/$name/$sub" log="$work/$name.$sub.log"
  set +e
  local modes=(A+B+C)
  [ "$send_all" = 1 ] && modes=(send-all A+B+C)
  "$run_bin" run "$@" --lidar "$lidar" --modes "${modes[@]}" --no-report --no-progress --out "$out" "${opts[@]}" $args \
      > "$log" 2>&1
  local rc=$?
  set -e
  local m="$out/report/metrics.tsv"
  if [ ! -f "$m" ] || [ -z "$(get robots "$m")" ]; then
    printf '%s\trun failed (exit %d, see %s)\n' "$name$label" "$rc" "$log" | tee -a "$rows_file"
    failures=$((failures + 1))
    return
  fi
  local robots reachable=0 merged=0 wrong=0 worst_m=0 worst_deg=0 worst_start_m=0 stops=""
  robots=$(get robots "$m")
  for ((r = 1; r < robots; r++)); do
    local reach ok bad em ed sm
    reach=$(get "robot.$r.reachable" "$m"); ok=$(get "robot.$r.merged" "$m"); bad=$(get "robot.$r.wrong" "$m")
    [ "$reach" = 1 ] && reachable=$((reachable + 1))
    if [ "$ok" = 1 ]; then
      if [ "$bad" = 1 ]; then wrong=$((wrong + 1)); elif [ "$reach" = 1 ]; then merged=$((merged + 1)); fi
      em=$(get "robot.$r.error_at_place_m" "$m"); ed=$(get "robot.$r.error_at_place_deg" "$m")
      [ -n "$em" ] || { em=$(get "robot.$r.error_m" "$m"); ed=$(get "robot.$r.error_deg" "$m"); }
      worst_m=$(awk -v a="$worst_m" -v b="$em" 'BEGIN { print (b > a ? b : a) }')
      worst_deg=$(awk -v a="$worst_deg" -v b="$ed" 'BEGIN { print (b > a ? b : a) }')
      sm=$(get "robot.$r.error_m" "$m")
      worst_start_m=$(awk -v a="$worst_start_m" -v b="$sm" 'BEGIN { print (b > a ? b : a) }')
    fi
  done
  stops=$(awk -F'\t' '$1 ~ /^pair\..*\.stopped$/ && $2 != "merged" && $2 != "no shared place" {
                        p = $1; sub(/^pair\./, "", p); sub(/\.stopped$/, "", p); s = s (s ? "; " : "") p ": " $2 }
                      END { print s }' "$m")
  local total stored raw
  total=$(get mode.A+B+C.total_bytes "$m"); stored=$(get stored_send_all_bytes "$m"); raw=$(get raw_keyframe_scan_bytes "$m")
  local send_all_col=-
  if [ "$send_all" = 1 ]; then send_all_col="$(get mode.send-all.robots_merged "$m") ($(get mode.send-all.worst_rmse_m "$m") m)"; fi
  local agreement=-
  if [ -n "$(get path_agreement_rms_m "$m")" ]; then agreement="$(get path_agreement_rms_m "$m") / $(get path_agreement_p95_m "$m")"; fi
  printf '%s\t%d\t%d\t%d\t%d\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name$label" "$((robots - 1))" "$reachable" "$merged" "$wrong" \
      "$(printf '%.2f m / %.2f deg' "$worst_m" "$worst_deg")" "$(get mode.A+B+C.worst_rmse_m "$m")" "$total" "$stored" \
      "$(awk -v a="$stored" -v b="$total" 'BEGIN { printf "%.2f", 100 * (1 - b / a) }')" "$raw" \
      "$(awk -v a="$raw" -v b="$total" 'BEGIN { printf "%.3f", 100 * (1 - b / a) }')" "${stops:--}" "$send_all_col" \
      "$(printf '%.2f m' "$worst_start_m")" "$agreement" | tee -a "$rows_file"
  # The measured run's bytes by kind (the baseline's are not kept): they must sum to the row's A+B+C bytes.
  if [ "$sub" = run ]; then
    local kind_bytes=() sum=0 v k
    for k in $kinds; do
      v=$(get "mode.A+B+C.bytes.$k" "$m")
      [ -n "$v" ] || { echo "bench_recall.sh: $name: metrics.tsv has no mode.A+B+C.bytes.$k (an older commerge): no bytes by kind" >&2; return; }
      kind_bytes+=("$v"); sum=$((sum + v))
    done
    if [ "$sum" != "$total" ]; then
      echo "bench_recall.sh: $name: the bytes by kind sum to $sum, not the A+B+C total $total" >&2
      failures=$((failures + 1))
    fi
    (IFS=$'\t'; printf '%s\t%s\t%s\t%s\t%s\n' "$name" "${kind_bytes[*]}" "$total" "$stored" "$raw") >> "$by_kind"
  fi
}

generated() {  # $1 = keyframes, $2 = seed, $3 = world, $4 = robots, $5 = overlap, $6 = direction, $7 = wobble,
               # $8 = the simulator's lidar (default vlp16; livox runs with the avia preset and gets it in its name)
  local kf=$1 seed=$2 world=$3 robots=$4 overlap=$5 direction=$6 wobble=$7 sim_lidar=${8:-vlp16}
  local name="$world-${robots}r-$overlap-$direction-w$wobble-k$kf-s$seed" run_lidar=vlp-16
  if [ "$sim_lidar" = livox ]; then name="$world-${robots}r-$overlap-$direction-w$wobble-livox-k$kf-s$seed"; run_lidar=avia; fi
  local data="$work/$name/data"
  if [ -n "$only" ] && ! [[ "$name" =~ $only ]]; then return; fi
  if [ "$reuse" = 0 ] || [ ! -f "$data/robot_$((robots - 1))/poses.txt" ]; then
    "$bin" sim --world "$world" --robots "$robots" --overlap "$overlap" --keyframes "$kf" --lidar "$sim_lidar" --seed "$seed" \
        --threads 2 --direction "$direction" --wobble-deg "$wobble" --out "$data" --force > "$work/$name.sim.log" 2>&1
  fi
  local dirs=()
  for ((r = 0; r < robots; r++)); do dirs+=("$data/robot_$r"); done
  # The simulator writes one scan per metre: a keyframe every 0.9 m keeps every scan despite odometry noise.
  opts=(--keyframe-spacing-m 0.9 --max-keyframes $((kf + 100)))
  run_scenario "$name" "$run_lidar" "${dirs[@]}"
  if [ "$drop_data" = 1 ]; then rm -rf "$data"; fi
}

real_splits() {  # $1 = folder under real/, $2 = scans
  local dir="$shared/real/$1" n=$2
  if [ ! -f "$dir/poses.txt" ]; then
    echo "CM-SKIP: $dir is absent: the real splits of $1 are not run" >&2
    return
  fi
  opts=(--gt-from-poses --odometry odom_poses.txt)
  local h=$((n / 2)) t=$((n / 3)) a=$((n * 6 / 10)) b=$((n * 4 / 10))
  run_scenario "$1-halves" avia "$dir:0-$h" "$dir:$h-$n"
  [ "$slice" = quick ] && return
  run_scenario "$1-thirds" avia "$dir:0-$t" "$dir:$t-$((2 * t))" "$dir:$((2 * t))-$n"
  run_scenario "$1-windows" avia "$dir:0-$a" "$dir:$b-$n"
}

if [ "$slice" = quick ]; then
  echo "commerge recall benchmark: slice quick (campus, 5 robots, seed 5; indoor, 3 robots, test seed 59; 400 keyframes; hku2 halves)${run_args:+, run options: $run_args}"
else
  echo "commerge recall benchmark: slice $slice, seeds $seeds, $keyframes keyframes (long: $long_keyframes)${run_args:+, run options: $run_args}"
fi
[ "$baseline" = 0 ] || echo "baseline: $base_bin${base_args:+, run options: $base_args}"
printf 'scenario\tother robots\tsharing robots\tmerged\twrong\tworst transform error\tworst e_rmse [m]\tA+B+C bytes\tstored send-all bytes\treduction %%\traw scan bytes\treduction vs raw %%\tunmerged pairs stopped at\tsend-all placed (worst e_rmse)\tworst error vs start poses\tshared-path agreement RMS / p95 [m]\n'
for seed in $seeds; do
  case "$slice" in
    quick)
      if [ "$seed" = "${seeds%% *}" ]; then
        generated 400 5 campus 5 moderate alternate 0.5
        generated 400 59 indoor 3 moderate alternate 0.5
      fi ;;
    generated|all)
      for world in $worlds; do
        for robots in 2 3 5; do
          for overlap in complete moderate partial; do
            for direction in same alternate; do
              for wobble in 0 0.5; do generated "$keyframes" "$seed" "$world" "$robots" "$overlap" "$direction" "$wobble"; done
            done
          done
        done
      done ;;
  esac
  if [ "$slice" = livox ] || [ "$slice" = all ]; then
    for world in $worlds; do
      for robots in 2 3; do
        for overlap in complete moderate partial; do
          for direction in same alternate; do generated "$keyframes" "$seed" "$world" "$robots" "$overlap" "$direction" 0.5 livox; done
        done
      done
    done
  fi
  if [ "$slice" = long ] || [ "$slice" = all ]; then
    for world in $worlds; do
      for overlap in complete partial; do generated "$long_keyframes" "$seed" "$world" 2 "$overlap" alternate 0.5; done
    done
  fi
done
if [ "$slice" = real ] || [ "$slice" = all ] || [ "$slice" = quick ]; then
  real_splits hku2 266
  [ "$slice" = quick ] || real_splits hku_mb 457
  if [ "$slice" != quick ] && [ -f "$shared/kitti/kitti00_frames0-15/poses.txt" ]; then
    opts=(--gt-from-poses)
    run_scenario kitti00-0-10-5-16 hdl-64e "$shared/kitti/kitti00_frames0-15:0-10" "$shared/kitti/kitti00_frames0-15:5-16"
  fi
fi
summarise summary "$rows"
[ -z "$tune_seeds$test_seeds" ] || summarise_split "$rows"
[ "$baseline" = 0 ] || summarise "baseline summary" "$base_rows"
summarise_kinds "$rows" "$by_kind"
[ "$failures" -eq 0 ] || { echo "bench_recall.sh: $failures run(s) failed" >&2; exit 1; }
