#!/usr/bin/env bash
# shellcheck disable=SC2016,SC2317  # markdown code spans in single quotes are literal; sections are called as sec_$name
# SPDX-License-Identifier: BSD-3-Clause
# Usage: profiling/regen_results.sh [--commerge BIN] [--build DIR] [--data DIR] [--work DIR] [--out FILE]
#                                   [--only SECTION]... [--recall-only REGEX] [--list] [-h|--help]
# Regenerates the tables of profiling/RESULTS.md at one commit: every section runs the command its table states
# and turns the command's output into that table. The file written (--out, default profiling/RESULTS.md.new) starts
# with the commit (`git rev-parse --short HEAD`, "+ uncommitted changes" when the work tree differs), the date,
# the machine (`nproc`, `uname -m`) and the binaries; then one part per section, in the order of RESULTS.md, each
# with its command, its run time and its table. Review it, then copy the tables that changed into RESULTS.md
# (the tables it replaces move to profiling/HISTORY.md). Tables that compared with an older commit come out with
# the current commit's column only; narrative (what a table shows) is not regenerated.
#
#   --commerge BIN     the commerge executable (default BUILD/commerge)
#   --build DIR        the build directory whose profiling/bench_* and ctest are used (default build-host)
#   --data DIR         the shared data (default ../shared/data from the repository; the same as the benchmarks')
#   --work DIR         scratch space: datasets, run reports, logs, one file per section (default
#                      ${TMPDIR:-/tmp}/commerge-regen); the generated datasets need tens of GB for the long sections
#   --out FILE         the regenerated results (default profiling/RESULTS.md.new)
#   --only SECTION     run this section (repeatable; default: every section). Sections whose data is absent here,
#                      or which take hours, run only when selected or when no --only is given.
#   --recall-only RE   smoke test: every bench_recall.sh section runs only the scenarios whose name matches RE (in
#                      place of the section's own scenario filter); the tables then cover those scenarios only
#   --list             print every section: name, estimated run time on the 2-core development VM, data it needs,
#                      the RESULTS.md table it regenerates; exit
# Exit status: 0 when every selected section ran; 1 when one failed (its part says so, the others are written);
# 2 on a usage error.
set -euo pipefail
# One brace group: bash parses the whole script before it runs, so an edit of this file cannot derail a run.
{
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/.." && pwd)
build=$repo/build-host
bin=""
data=$repo/../shared/data
work=${TMPDIR:-/tmp}/commerge-regen
out=$repo/profiling/RESULTS.md.new
only=()
recall_only=""
list=0
while [ $# -gt 0 ]; do
  case "$1" in
    --commerge) bin=$2; shift 2 ;;
    --build) build=$2; shift 2 ;;
    --data) data=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --only) only+=("$2"); shift 2 ;;
    --recall-only) recall_only=$2; shift 2 ;;
    --list) list=1; shift ;;
    -h|--help) sed -n '/^# Usage:/,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "regen_results.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -n "$bin" ] || bin=$build/commerge

# ---------------------------------------------------------------------------------------------------------------
# The sections, in the order of RESULTS.md: name | estimated run time | data or tools it needs | RESULTS.md table.
# Estimates are for the 2-core development VM.
sections=(
  "main-demo|1 min|-|Main job: demo, default flags"
  "main-kitti|10 s|kitti|Main job: KITTI 00 frames 0-9 and 5-15 as two robots"
  "main-long-urban|15 min (5 GB of data)|-|Main job: long urban mission, 2 x 3 000 keyframes"
  "recall-quick|2 min|real|Merge recall: Quick slice (the CI test), default flags and the paper's"
  "recall-real|1 min|real, kitti|Merge recall: real Livox splits"
  "recall-matrix-s11|4 h|-|Merge recall: The generated matrix, seed 11"
  "recall-matrix-s23|2 h|-|Merge recall: The generated matrix, seed 23 (2 and 3 robots)"
  "recall-livox|1 h|-|Merge recall: A forward-looking sensor in the simulator"
  "recall-long|1 h (8 GB of data per scenario)|-|Merge recall: 3 000-keyframe subset"
  "recall-evidence|30 min|-|Merge recall: Evidence at each placement (tune seeds)"
  "recall-indoor-pairs|10 min|-|Merge recall: Why indoor pairs stay unmerged (tune seeds)"
  "recall-distances|0 s (reads the reports of recall-matrix-s11, recall-livox, recall-real)|-|Merge recall: Descriptor distances: generated against real"
  "real-loops|1 min|real|Merge recall: Intra-robot loops on the real sequences"
  "recall-joint-cover|2 h|-|Merge recall: Stage B: joint cover against pairwise"
  "ablation|2 h|-|Merge recall: Exchange-mode ablation"
  "recall-scan-context|1 h|-|Merge recall: Scan Context against the ring descriptor"
  "recall-refinement|2 h (10 GB of data)|-|Merge recall: Final refinement on spread scans"
  "bench-voxel-grid|5 s|kitti|Component benchmarks: voxel grid"
  "bench-descriptor|5 s|kitti|Component benchmarks: SOLiD / Scan Context"
  "bench-robot-keyframe|5 s|kitti|Component benchmarks: robot per keyframe"
  "bench-pose-graph|10 s|-|Component benchmarks: pose graph"
  "bench-affinity|2 min|-|Component benchmarks: affinity + stage A"
  "bench-max-clique|20 min|graphs|Component benchmarks: max clique on DIMACS, stage C model vs GLPK"
  "bench-vertex-cover|40 min|graphs|Component benchmarks: stage B model vs GLPK"
  "bench-registration|30 min|kitti|Component benchmarks: submap registration"
  "bench-sim|5 s|-|Component benchmarks: simulator ray casting"
  "bench-cascade|2 min|-|Component benchmarks: cascade on a generated street mission"
  "master-lp|30 min|graphs|Component benchmarks: Stage B master LP engines"
  "clique-lp-bound|1 min|graphs|Component benchmarks: Stage C LP bound"
  "scenarios-same-flat|3 h (15 GB of data)|-|Generated scenarios: Same direction, flat road"
  "scenarios-tau-area-2500|1 h (after scenarios-same-flat)|-|Generated scenarios: Same direction, tau_area 2500"
  "scenarios-default|3 h (15 GB of data)|-|Generated scenarios: Default simulator setting"
  "scenarios-solid-no-ground|1 h (after scenarios-default)|-|Generated scenarios: Default setting, SOLiD without the ground"
  "scenarios-other-way-flat|3 h (15 GB of data)|-|Generated scenarios: Other way round, flat road"
  "scenarios-seq-smoothed|1 h (after scenarios-same-flat)|-|Generated scenarios: Sequence-smoothed stage A"
  "scenarios-smoothing|2 h (after the three settings and scenarios-seq-smoothed)|-|Generated scenarios: Sequence smoothing against the per-cell threshold"
  "long-missions|14 h (60 GB of data)|-|Long missions"
  "small-scenes|10 min|-|Small scenes: a courtyard walked by hand"
  "network-faults|5 min|root (network namespaces, nftables, tc)|Network fault tests"
  "replay-load|45 min|root|Network fault tests: Exact replay under load"
  "five-robots-memory|5 min|-|Five robots and memory sized from the work"
  "five-robots-town|45 min (19 GB of data)|root|Five robots and memory sized from the work: Five robots at Town scale, ipc-6000"
  "round-cost|30 min|-|Five robots and memory sized from the work: Round cost at scale"
  "mission-long|1 h (12 GB of data)|root|Mission-long exchange"
  "peak-ram-town|15 min (12 GB of data)|root|Peak RAM of a Town-scale mission"
  "import-memory|15 min (2 GB of data)|real, python3-rosbag|Import of a ROS bag: memory follows the largest message"
  "wire-records|15 min (2.4 GB of data)|-|Compact keyframe batches"
  "field-bundle|15 min|build-jetson (the cross build)|Field bundle"
  "ci-time|40 min|a clean clone of the repository|CI time"
)

field() { local IFS='|'; local -a f; read -r -a f <<<"$1"; echo "${f[$2]}"; }

if [ "$list" = 1 ]; then
  printf '%-26s %-62s %-30s %s\n' section "estimated run time" needs "RESULTS.md table"
  for s in "${sections[@]}"; do
    printf '%-26s %-62s %-30s %s\n' "$(field "$s" 0)" "$(field "$s" 1)" "$(field "$s" 2)" "$(field "$s" 3)"
  done
  exit 0
fi

for o in "${only[@]+"${only[@]}"}"; do
  found=0
  for s in "${sections[@]}"; do [ "$(field "$s" 0)" = "$o" ] && found=1; done
  [ "$found" = 1 ] || { echo "regen_results.sh: --only: unknown section '$o' (see --list)" >&2; exit 2; }
done
[ -x "$bin" ] || { echo "regen_results.sh: $bin is not an executable (use --commerge or --build)" >&2; exit 2; }
bin=$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")
build=$(cd "$build" && pwd)
[ -d "$data" ] && data=$(cd "$data" && pwd)
mkdir -p "$work/sections" "$work/bin"
work=$(cd "$work" && pwd)
# Copies of the binaries: a rebuild of the build directory during a long run must not change (or break) them.
bin_orig=$bin bench_orig=$build/profiling
cp "$bin" "$work/bin/commerge"
bin=$work/bin/commerge
for b in "$bench_orig"/bench_*; do [ -x "$b" ] && cp "$b" "$work/bin/"; done
bench=$work/bin

selected() {
  [ "${#only[@]}" = 0 ] && return 0
  local o
  for o in "${only[@]}"; do [ "$o" = "$1" ] && return 0; done
  return 1
}

# ---------------------------------------------------------------------------------------------------------------
# Helpers. Every section writes markdown to stdout; the driver captures it into WORK/sections/NAME.md.
commit=$(git -C "$repo" rev-parse --short HEAD 2>/dev/null || echo unknown)
if [ -n "$(git -C "$repo" --no-optional-locks status --porcelain --untracked-files=no 2>/dev/null)" ]; then
  commit_note="$commit + uncommitted changes"
else
  commit_note=$commit
fi
today=$(date +%Y-%m-%d)
get() { awk -F'\t' -v k="$1" '$1 == k { print $2 }' "$2"; }
mib() { awk -v b="$1" 'BEGIN { printf "%.2f MiB", b / 1048576 }'; }
# Bytes as the recall tables write them: KiB below 1 MiB, else MiB with one decimal.
kib_mib() { awk -v b="$1" 'BEGIN { if (b < 1048576) printf "%d KiB", b / 1024 + 0.5; else printf "%.1f MiB", b / 1048576 }'; }
# A command as the tables show it: the repository and the work directory shortened.
show() {
  local a s=""
  for a in "$@"; do
    case "$a" in *[[:space:]\|\(\)\'^\$]*) a="\"$a\"" ;; esac
    s="$s${s:+ }$a"
  done
  s=${s//$bin/$bin_orig}; s=${s//$bench\/bench_/$bench_orig/bench_}
  s=${s//$repo\//}; s=${s//$work/WORK}; s=${s//$data/DATA}; echo "$s"
}
stamp() { echo "Commit $commit_note, $today, $(nproc) cores ($(uname -m))."; }
need_data() {  # $1 = path under DATA
  [ -e "$data/$1" ] || { echo "needs $data/$1, which is absent"; return 1; }
}
section_failed=0
fail() { echo; echo "**Not regenerated:** $*"; section_failed=1; }
# Runs a command, its output to a log; prints nothing. $1 = log file, then the command.
run_logged() { local log=$1; shift; "$@" >"$log" 2>&1; }

# The recall benchmark. $1 = section name, then bench_recall.sh options (without --commerge, --work, --shared-data).
recall() {
  local name=$1; shift
  local args=("$@") i
  if [ -n "$recall_only" ]; then
    for i in "${!args[@]}"; do
      if [ "${args[$i]}" = --only ]; then args[i + 1]=$recall_only; fi
    done
    case " ${args[*]} " in *" --only "*) ;; *) args+=(--only "$recall_only") ;; esac
  fi
  rm -rf "${work:?}/$name"
  set +e
  "$here/bench_recall.sh" --commerge "$bin" --work "$work/$name" --shared-data "$data" "${args[@]}" \
      >"$work/$name.out" 2>"$work/$name.err"
  local rc=$?
  set -e
  echo "Command: \`$(show profiling/bench_recall.sh "${args[@]}")\`. $(stamp)"
  echo
  return "$rc"
}
# The summary lines bench_recall.sh printed.
recall_summary() { grep -E '^(summary|baseline summary):' "$work/$1.out" | sed 's/^/- /' || true; }

# Aggregates recall rows (TSV of bench_recall.sh) by a key taken from the scenario name; prints
# key, scenarios, sharing, right, wrong, bytes, median reduction vs stored, median reduction vs raw.
recall_groups() {  # $1 = rows file, $2 = awk expression for the key (name in $1)
  awk -F'\t' "NF >= 13 { key = $2; n[key]++; sh[key] += \$3; ok[key] += \$4; bad[key] += \$5; by[key] += \$8
                 red[key, n[key]] = \$10; raw[key, n[key]] = \$12; if (!(key in seen)) { seen[key] = 1; order[++k] = key } }
    function med(a, key, m,   i, j, t, v) {
      for (i = 1; i <= m; i++) v[i] = a[key, i]
      for (i = 1; i <= m; i++) for (j = i + 1; j <= m; j++) if (v[j] < v[i]) { t = v[i]; v[i] = v[j]; v[j] = t }
      return m % 2 ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2
    }
    END { for (i = 1; i <= k; i++) { key = order[i]
            printf \"%s\t%d\t%d\t%d\t%d\t%.0f\t%.2f\t%.3f\n\", key, n[key], sh[key], ok[key], bad[key], by[key],
                   med(red, key, n[key]), med(raw, key, n[key]) } }" "$1"
}

# A row of the component table: what | command | result | date. $1 = what, $2 = command, $3 = result.
component_row() { printf '| %s | `%s` | %s | %s (%s) |\n' "$1" "$2" "$3" "$today" "$commit_note"; }
component_header() {
  echo "| what | command | result | date (commit) |"
  echo "|---|---|---|---|"
}
# The lines of a benchmark's output that match an extended regex, joined with "; ".
# A regex "from:RE" takes every non-empty line from the first match of RE to the end.
pick() {
  case "$2" in
    from:*) sed -n "/${2#from:}/,\$p" "$1" | grep -v '^ *$' ;;
    *) grep -E "$2" "$1" ;;
  esac | sed 's/^ *//; s/  */ /g; s/[|]/\\|/g' | paste -sd';' - | sed 's/;/; /g'
}

# ---------------------------------------------------------------------------------------------------------------
# Main job
sec_main_demo() {
  local o=$work/demo
  rm -rf "$o"
  set +e
  "$here/peak-ram.sh" "$bin" demo --out "$o" >"$work/demo.log" 2>&1
  local rc=$?
  set -e
  [ "$rc" = 0 ] || { fail "\`commerge demo\` exited $rc (see $work/demo.log)"; return; }
  local m=$o/report/metrics.tsv
  [ -f "$m" ] || m=$(find "$o" -name metrics.tsv | head -n 1)
  echo "| run | command | result | date (commit) |"
  echo "|---|---|---|---|"
  local modes="" md
  for md in send-all A A+B A+C A+B+C; do
    modes="$modes${modes:+, }$md $(kib_mib "$(get "mode.$md.total_bytes" "$m")")"
  done
  local all abc
  all=$(get mode.send-all.total_bytes "$m"); abc=$(get mode.A+B+C.total_bytes "$m")
  printf '| demo (two robots, generated urban world), default flags | `build/commerge demo` | %s; A+B+C %s less than send-all (%s scans); e_rmse A+B+C %s m, send-all %s m; robots merged %s; %s |\n' \
      "$modes" "$(awk -v a="$all" -v b="$abc" 'BEGIN { printf "%.2f %%", 100 * (1 - b / a) }')" \
      "$(get mode.A+B+C.scans "$m")" "$(get mode.A+B+C.worst_rmse_m "$m")" "$(get mode.send-all.worst_rmse_m "$m")" \
      "$(get mode.A+B+C.robots_merged "$m")" \
      "$(grep -o 'peak RSS: [0-9.]* MiB[^,]*, wall [0-9.]* s' "$work/demo.log" | tail -n 1)" | sed "s/|\$/| $today ($commit_note) |/"
}

sec_main_kitti() {
  need_data kitti/kitti00_frames0-15/velodyne || { fail "the KITTI 00 frames are absent"; return; }
  local k=$data/kitti/kitti00_frames0-15 o=$work/kitti
  rm -rf "$o"
  local cmd=("$bin" run "$k:0-10" "$k:5-16" --gt-from-poses --tau-area 4 --no-progress --out "$o")
  run_logged "$work/kitti.log" "${cmd[@]}" || true  # the exit status says whether the pair merged
  local m=$o/report/metrics.tsv
  [ -f "$m" ] || { fail "the run failed (see $work/kitti.log)"; return; }
  echo "| run | command | result | date (commit) |"
  echo "|---|---|---|---|"
  printf '| KITTI 00 frames 0-9 and 5-15 as two robots | `commerge run ../shared/data/kitti/kitti00_frames0-15:0-10 ../shared/data/kitti/kitti00_frames0-15:5-16 --gt-from-poses --tau-area 4` | alignment RMSE %s m; %s scans exchanged (%s keyframes); robots merged %s | %s (%s) |\n' \
      "$(get mode.A+B+C.worst_rmse_m "$m")" "$(get mode.A+B+C.scans "$m")" "$(get keyframes_total "$m")" \
      "$(get mode.A+B+C.robots_merged "$m")" "$today" "$commit_note"
}

sec_main_long_urban() {
  local d=$work/long-urban/data o=$work/long-urban/run
  rm -rf "${work:?}/long-urban"
  run_logged "$work/long-urban.sim.log" "$bin" sim --world urban --robots 2 --overlap complete --keyframes 3000 \
      --lidar vlp16 --seed 11 --direction same --wobble-deg 0 --threads 2 --out "$d" --force \
      || { fail "commerge sim failed (see $work/long-urban.sim.log)"; return; }
  set +e
  "$here/peak-ram.sh" "$bin" run "$d/robot_0" "$d/robot_1" --lidar vlp-16 --keyframe-spacing-m 0.9 --board jetson-nano \
      --max-keyframes 3100 --no-progress --out "$o" >"$work/long-urban.run.log" 2>&1
  local rc=$?
  set -e
  local m=$o/report/metrics.tsv md modes=""
  [ -f "$m" ] || { fail "commerge run exited $rc (see $work/long-urban.run.log)"; return; }
  for md in send-all A A+B A+C A+B+C; do modes="$modes${modes:+, }$md $(kib_mib "$(get "mode.$md.total_bytes" "$m")")"; done
  local all abc
  all=$(get mode.send-all.total_bytes "$m"); abc=$(get mode.A+B+C.total_bytes "$m")
  echo "| run | command | result | date (commit) |"
  echo "|---|---|---|---|"
  printf '| long urban mission, 2 x 3 000 keyframes, same direction | `commerge sim --world urban --robots 2 --overlap complete --keyframes 3000 --lidar vlp16 --seed 11 --direction same --wobble-deg 0`, then `commerge run ... --lidar vlp-16 --keyframe-spacing-m 0.9 --board jetson-nano --max-keyframes 3100` | %s = %s less (%s scans, %s of scans); alignment RMSE %s m; %s | %s (%s) |\n' \
      "$modes" "$(awk -v a="$all" -v b="$abc" 'BEGIN { printf "%.2f %%", 100 * (1 - b / a) }')" \
      "$(get mode.A+B+C.scans "$m")" "$(kib_mib "$(get mode.A+B+C.scan_bytes "$m")")" "$(get mode.A+B+C.worst_rmse_m "$m")" \
      "$(grep -o 'peak RSS: [0-9.]* MiB[^,]*, wall [0-9.]* s' "$work/long-urban.run.log" | tail -n 1)" "$today" "$commit_note"
  rm -rf "$d"
}

# ---------------------------------------------------------------------------------------------------------------
# Merge recall
paper_flags="--neighbour-rank 0 --sequence-half-window 0 --tau-area 10000 --tau-area-fraction 0 --tau-inter 0.1 --verify-area-fraction 0 --max-ambiguous-fraction 1 --consensus-max-cells 0 --min-ambiguous-support 0 --chain-check-support 0 --max-colocated-chance 0 --descriptor solid"

sec_recall_quick() {
  echo "### Quick slice (the CI test)"
  echo
  recall recall-quick --slice quick --baseline-run-args "$paper_flags" \
      || { fail "bench_recall.sh failed (see $work/recall-quick.out, .err)"; return; }
  echo "\"Before\": the paper's stage A and SOLiD (\`--baseline-run-args \"$paper_flags\"\`); \"after\": the default flags."
  echo
  echo "| scenario | sharing robots | merged before / after | wrong before / after | worst error after (where met; start poses) | A+B+C bytes before / after | reduction vs stored send-all after |"
  echo "|---|---|---|---|---|---|---|"
  awk -F'\t' 'function h(b) { if (b == "") return "-"; return b < 1048576 ? sprintf("%d KiB", b / 1024 + 0.5) : sprintf("%.1f MiB", b / 1048576) }
    FNR == NR { if (NF >= 13) { n = $1; sub(/ \(baseline\)$/, "", n); b4[n] = $4; bw[n] = $5; bb[n] = $8 }; next }
    NF >= 13 { printf "| %s | %d | %s / %d | %s / %d | %s; %s | %s / %s | %s %% |\n", $1, $3, (($1 in b4) ? b4[$1] : "-"), $4,
                      (($1 in bw) ? bw[$1] : "-"), $5, $6, $15, h(bb[$1]), h($8), $10 }' \
      "$work/recall-quick/baseline.tsv" "$work/recall-quick/rows.tsv"
  echo
  recall_summary recall-quick
}

sec_recall_real() {
  echo "### Real Livox splits"
  echo
  need_data real/hku2/poses.txt || { fail "the real sequences are absent"; return; }
  recall recall-real --slice real --send-all || { fail "bench_recall.sh failed (see $work/recall-real.out, .err)"; return; }
  echo "Odometry \`odom_poses.txt\`, reference \`poses.txt\`. \"placed\" counts every robot given a transform."
  echo
  echo "| split | robots | sharing (criterion) | placed | right / wrong of the sharing | worst error where met | worst e_rmse | A+B+C bytes | reduction vs stored send-all | send-all (complete maps): placed (worst e_rmse) |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  local row name m
  while IFS=$'\t' read -r -a row; do
    [ "${#row[@]}" -ge 13 ] || continue
    name=${row[0]}
    m=$work/recall-real/$name/run/report/metrics.tsv
    printf '| %s | %s | %s | %s | %s / %s | %s | %s m | %s | %s %% | %s |\n' "$name" "${row[1]}" "${row[2]}" \
        "$(get mode.A+B+C.robots_merged "$m" | cut -d/ -f1)" "${row[3]}" "${row[4]}" "${row[5]}" "${row[6]}" \
        "$(kib_mib "${row[7]}")" "${row[9]}" "${row[13]}"
  done <"$work/recall-real/rows.tsv"
  echo
  recall_summary recall-real
}

sec_recall_matrix_s11() {
  echo "### The generated matrix, seed 11"
  echo
  recall recall-matrix-s11 --slice generated --seeds 11 --drop-data \
      || { fail "bench_recall.sh failed (see $work/recall-matrix-s11.out, .err)"; return; }
  echo "| world | 2 and 3 robots: right / sharing (wrong) | 5 robots: right / sharing (wrong) | median reduction vs stored send-all, 2-3 / 5 robots | vs raw scans |"
  echo "|---|---|---|---|---|"
  local g=$work/recall-matrix-s11.groups
  recall_groups "$work/recall-matrix-s11/rows.tsv" '($1 ~ /-5r-/ ? "5" : "23") "\t" substr($1, 1, index($1, "-") - 1)' >"$g"
  recall_groups "$work/recall-matrix-s11/rows.tsv" '($1 ~ /-5r-/ ? "5" : "23") "\tall"' >>"$g"
  awk -F'\t' '{ k = $2; w[k] = 1; if (!(k in seen)) { seen[k] = 1; order[++n] = k }
                c[$1, k] = $5 " / " $4 " (" $6 ")"; r[$1, k] = $8; x[$1, k] = $9 }
    END { for (i = 1; i <= n; i++) { k = order[i]; b = (k == "all") ? "**" : ""
            printf "| %s%s%s | %s | %s | %s / %s %% | %s / %s %% |\n", b, k, b, ((("23", k) in c) ? c["23", k] : "-"),
                   ((("5", k) in c) ? c["5", k] : "-"), d(r["23", k]), d(r["5", k]), d(x["23", k]), d(x["5", k]) } }
    function d(v) { return v == "" ? "-" : v }' "$g"
  echo
  recall_summary recall-matrix-s11
}

sec_recall_matrix_s23() {
  echo "### The generated matrix, seed 23 (2 and 3 robots)"
  echo
  recall recall-matrix-s23 --slice generated --seeds 23 --only '-(2r|3r)-' --drop-data \
      || { fail "bench_recall.sh failed (see $work/recall-matrix-s23.out, .err)"; return; }
  recall_world_table recall-matrix-s23 "| world | right / sharing (wrong) | A+B+C bytes | median reduction vs stored send-all | vs raw scans |" \
      '"| " k " | " ok " / " sh " (" bad ") | " mb " | " red " % | " raw " % |"'
  echo
  recall_summary recall-matrix-s23
}

# One row per world and an "all" row. $1 = section, $2 = table header, $3 = awk expression of a row (k, n, sh,
# ok, bad, mb, red, raw).
recall_world_table() {
  echo "$2"
  echo "$2" | sed 's/[^|]*/---/g; s/^---//; s/---$//'
  { recall_groups "$work/$1/rows.tsv" 'substr($1, 1, index($1, "-") - 1)'
    recall_groups "$work/$1/rows.tsv" '"all"'; } |
    awk -F'\t' "{ k = \$1; n = \$2; sh = \$3; ok = \$4; bad = \$5; mb = sprintf(\"%.2f MiB\", \$6 / 1048576); red = \$7; raw = \$8
                 if (k == \"all\") k = \"**all**\"; print $3 }"
}

# The recall benchmark NAME with ARGS (recall), then its tune-seed lines as a list; false when it failed.
recall_tune() {
  local name=$1
  shift
  recall "$name" "$@" || { fail "bench_recall.sh failed (see $work/$name.out, .err)"; return 1; }
  grep -E '^tune seeds, ' "$work/$name.out" | sed 's/^/- /' || true
}

sec_recall_evidence() {
  echo "### Evidence at each placement (tune seeds)"
  echo
  local slice='-((2r|3r)-(moderate|partial)|5r-partial)-alternate-w0.5'
  recall_tune recall-evidence --slice generated --tune-seeds "11 23" --keyframes 400 --only "$slice" --drop-data \
      || return
  echo
  echo "Every placed cluster of those runs, true (within 5 m and 5 deg of the ground truth at its place) or false;"
  echo "10th percentile / median / 90th percentile. Command: \`profiling/placement_evidence.sh WORK\`."
  echo
  "$here/placement_evidence.sh" "$work/recall-evidence" || fail "placement_evidence.sh failed"
  echo
  recall_summary recall-evidence
}

sec_recall_indoor_pairs() {
  echo "### Why indoor pairs stay unmerged (tune seeds)"
  echo
  local slice='-((2r|3r)-(moderate|partial)|5r-partial)-alternate-w0.5'
  recall_tune recall-indoor-pairs --slice generated --worlds indoor --tune-seeds "11 23 31" --keyframes 400 \
      --only "$slice" --drop-data || return
  echo
  echo "Every pair that shares a place and did not merge, with what its evidence points at. Command:"
  echo "\`profiling/placement_evidence.sh --pairs --world indoor WORK\`."
  echo
  "$here/placement_evidence.sh" --pairs --world indoor "$work/recall-indoor-pairs" \
      || fail "placement_evidence.sh failed"
  echo
}

sec_recall_refinement() {
  echo "### Final refinement on spread scans"
  echo
  local slice='-(2r|3r)-(moderate|partial)-alternate-w0.5' seed outs=()
  for seed in 11 23 83; do
    recall "recall-refinement-s$seed" --slice generated --seeds "$seed" --keyframes 400 --only "$slice" --send-all \
        --baseline-run-args "--refine-scans 0" --drop-data \
        || { fail "bench_recall.sh failed (see $work/recall-refinement-s$seed.out, .err)"; return; }
    outs+=("$work/recall-refinement-s$seed.out")
  done
  echo "Tune seeds 11 and 23, then test seed 83 (\`profiling/refinement_table.sh OUTPUT...\`):"
  echo
  "$here/refinement_table.sh" "${outs[0]}" "${outs[1]}" || fail "refinement_table.sh failed"
  echo
  "$here/refinement_table.sh" "${outs[2]}" || fail "refinement_table.sh failed"
}

sec_recall_livox() {
  echo "### A forward-looking sensor in the simulator"
  echo
  recall recall-livox --slice livox --seeds 11 --drop-data \
      || { fail "bench_recall.sh failed (see $work/recall-livox.out, .err)"; return; }
  recall_world_table recall-livox "| world | scenarios | sharing robots | right | wrong | A+B+C bytes | median reduction vs stored send-all / vs raw |" \
      '"| " k " | " n " | " sh " | " ok " | " bad " | " mb " | " red " % / " raw " % |"'
  echo
  recall_summary recall-livox
}

sec_recall_long() {
  echo "### 3 000-keyframe subset"
  echo
  recall recall-long --slice long --drop-data || { fail "bench_recall.sh failed (see $work/recall-long.out, .err)"; return; }
  echo "| scenario | merged (of sharing) | worst error where met | keyframe records and pose updates | scans (bytes) | A+B+C total | reduction vs stored send-all / vs raw |"
  echo "|---|---|---|---|---|---|---|"
  local row m
  while IFS=$'\t' read -r -a row; do
    [ "${#row[@]}" -ge 13 ] || continue
    m=$work/recall-long/${row[0]}/run/report/metrics.tsv
    printf '| %s | %s of %s%s | %s | %s | %s (%s) | %s | %s %% / %s %% |\n' "${row[0]}" "${row[3]}" "${row[2]}" \
        "$([ "${row[12]}" = - ] || echo " (${row[12]})")" "${row[5]}" "$(kib_mib "$(get stream_bytes "$m")")" \
        "$(get mode.A+B+C.scans "$m")" "$(kib_mib "$(get mode.A+B+C.scan_bytes "$m")")" "$(kib_mib "${row[7]}")" \
        "${row[9]}" "${row[11]}"
  done <"$work/recall-long/rows.tsv"
  echo
  recall_summary recall-long
}

# Medians of the descriptor-distance quantiles over the robot pairs of a group of run reports.
# $1 = group label, then metrics.tsv files.
distance_row() {
  local label=$1; shift
  [ $# -gt 0 ] || { echo "| $label | 0 | - | - | - | - |"; return; }
  awk -F'\t' -v label="$label" '
    $1 ~ /^pair\.[0-9]+-[0-9]+\.true_pairs$/ { tp += $2; pairs++ }
    $1 ~ /^pair\.[0-9]+-[0-9]+\.false_pairs$/ { fp += $2 }
    $1 ~ /\.true_distance_p05_p50_p95$/ { split($2, v, " "); if (v[1] >= 0) { nt++; t1[nt] = v[1]; t2[nt] = v[2]; t3[nt] = v[3] } }
    $1 ~ /\.false_distance_p01_p05_p50$/ { split($2, v, " "); if (v[1] >= 0) { nf++; f1[nf] = v[1]; f2[nf] = v[2]; f3[nf] = v[3] } }
    function med(a, m,   i, j, t) {
      if (m == 0) return "-"
      for (i = 1; i <= m; i++) for (j = i + 1; j <= m; j++) if (a[j] < a[i]) { t = a[i]; a[i] = a[j]; a[j] = t }
      return sprintf("%.3f", (m % 2 ? a[(m + 1) / 2] : (a[m / 2] + a[m / 2 + 1]) / 2))
    }
    END { printf "| %s | %d | %d | %s / %s / %s | %d | %s / %s / %s |\n", label, pairs, tp, med(t1, nt), med(t2, nt),
                 med(t3, nt), fp, med(f1, nf), med(f2, nf), med(f3, nf) }' "$@"
}
reports() {  # $1 = section work dir, $2 = scenario name regex: the run reports of the matching scenarios
  find "$work/$1" -path '*/run/report/metrics.tsv' 2>/dev/null | awk -v re="$2" '{ n = $0; sub(/\/run\/report\/metrics.tsv$/, "", n); sub(/.*\//, "", n); if (n ~ re) print }' | sort
}

sec_recall_distances() {
  echo "### Descriptor distances: generated against real"
  echo
  echo "From the run reports of the sections recall-matrix-s11 (VLP-16, seed 11), recall-livox and recall-real of this"
  echo "run (\`pair.A-B.true_distance_p05_p50_p95\`, \`pair.A-B.false_distance_p01_p05_p50\`, \`pair.A-B.true_pairs\`,"
  echo "\`pair.A-B.false_pairs\` in \`report/metrics.tsv\`): the median of each quantile over the robot pairs of a group. $(stamp)"
  echo
  local have=0
  [ -d "$work/recall-matrix-s11" ] || [ -d "$work/recall-real" ] || [ -d "$work/recall-livox" ] || have=1
  [ "$have" = 0 ] || { fail "run recall-matrix-s11, recall-livox and recall-real first (their reports in WORK)"; return; }
  echo "| group | robot pairs | true pairs | true p05 / p50 / p95 | false pairs | false p01 / p05 / p50 |"
  echo "|---|---|---|---|---|---|"
  local d w
  for d in "same-w0|same direction, wobble 0" "same-w0.5|same direction, wobble 0.5 deg" \
           "alternate-w0|alternating directions, wobble 0" "alternate-w0.5|alternating directions, wobble 0.5 deg"; do
    # shellcheck disable=SC2046
    distance_row "generated urban, ${d#*|}" $(reports recall-matrix-s11 "^urban-.*-${d%%|*}-k")
  done
  # shellcheck disable=SC2046
  distance_row "real hku_mb (halves, thirds, windows)" $(reports recall-real '^hku_mb-')
  # shellcheck disable=SC2046
  distance_row "real hku2 (halves, thirds, windows)" $(reports recall-real '^hku2-')
  for w in campus cave indoor; do
    # shellcheck disable=SC2046
    distance_row "generated $w, VLP-16 (2 and 3 robots, wobble 0.5 deg)" $(reports recall-matrix-s11 "^$w-(2r|3r)-.*-w0.5-k")
  done
  for w in urban campus cave indoor; do
    # shellcheck disable=SC2046
    distance_row "generated $w, Livox model" $(reports recall-livox "^$w-")
  done
}

# Revisits of a pose file: scan pairs less than 3 m apart with at least 15 m of path between them. $1 = poses.txt,
# $2 = first scan, $3 = end (exclusive). Prints "path_m pairs pairs_heading_within_30deg".
revisits() {
  awk -v a="$2" -v b="$3" '{ if (NR - 1 >= a && NR - 1 < b) { n++; x[n] = $4; y[n] = $8; z[n] = $12; h[n] = atan2($5, $1)
                                  if (n > 1) s[n] = s[n - 1] + sqrt((x[n] - x[n-1])^2 + (y[n] - y[n-1])^2 + (z[n] - z[n-1])^2); else s[n] = 0 } }
    END { for (i = 1; i <= n; i++) for (j = i + 1; j <= n; j++) if (s[j] - s[i] >= 15) {
            d = sqrt((x[i] - x[j])^2 + (y[i] - y[j])^2 + (z[i] - z[j])^2)
            if (d < 3) { p++; dh = h[i] - h[j]; while (dh > 3.14159265) dh -= 6.28318531; while (dh < -3.14159265) dh += 6.28318531
                         if (dh < 0) dh = -dh; if (dh <= 30 * 3.14159265 / 180) q++ } }
          printf "%.0f %d %d\n", s[n], p, q }' "$1"
}

sec_real_loops() {
  echo "### Intra-robot loops on the real sequences"
  echo
  need_data real/hku2/poses.txt || { fail "the real sequences are absent"; return; }
  echo "Revisits from \`poses.txt\`: scan pairs less than 3 m apart with at least 15 m of path between them. Loops:"
  echo "\`commerge run DIR:RANGE DIR:PARTNER --lidar avia --gt-from-poses --odometry odom_poses.txt [--tau-intra X --tau-window W]\`,"
  echo "robot 0's loops and ICP-refused candidates (\`robot.0.loops\`, \`robot.0.loop_candidates_refused\` in \`report/metrics.tsv\`). $(stamp)"
  echo
  echo "| sequence, range | path | revisit scan pairs (heading within 30 deg) | loops, defaults | tau_intra 0.5, window 30: candidates / refused by ICP / loops | tau_intra 0.5, window 15 |"
  echo "|---|---|---|---|---|---|"
  local spec seq range partner path pairs q cols extra m o i runs_failed=0
  mkdir -p "$work/real-loops"
  for spec in "hku2 0-133 133-266" "hku2 133-266 0-133" "hku2 0-266 133-266" "hku_mb 0-457 228-457"; do
    read -r seq range partner <<<"$spec"
    read -r path pairs q < <(revisits "$data/real/$seq/poses.txt" "${range%-*}" "${range#*-}")
    cols=()
    i=0
    for extra in "" "--tau-intra 0.5 --tau-window 30" "--tau-intra 0.5 --tau-window 15"; do
      i=$((i + 1))
      o=$work/real-loops/$seq-$range-$i
      rm -rf "$o"
      # The exit status says whether the pair merged; the loops are in the report either way.
      # shellcheck disable=SC2086
      run_logged "$o.log" "$bin" run "$data/real/$seq:$range" "$data/real/$seq:$partner" --lidar avia --gt-from-poses \
          --odometry odom_poses.txt --modes A+B+C --no-report --no-progress --out "$o" $extra || true
      m=$o/report/metrics.tsv
      if [ -n "$(get robot.0.loops "$m" 2>/dev/null)" ]; then
        local l c
        l=$(get robot.0.loops "$m"); c=$(get robot.0.loop_candidates_refused "$m")
        if [ "$i" = 1 ]; then cols+=("$l"); else cols+=("$((l + c)) / $c / $l"); fi
      else
        cols+=("run failed"); runs_failed=$((runs_failed + 1))
      fi
    done
    printf '| %s %s | %s m | %s (%s) | %s | %s | %s |\n' "$seq" "$range" "$path" "$pairs" "$q" "${cols[0]}" "${cols[1]}" "${cols[2]}"
  done
  [ "$runs_failed" = 0 ] || fail "$runs_failed runs failed (logs in $work/real-loops)"
}

sec_recall_joint_cover() {
  echo "### Stage B: joint cover against pairwise"
  echo
  recall recall-joint-cover --slice generated --worlds "campus urban" --keyframes 400 --only '-(3r|5r)-' \
      --run-args "--cover joint" --baseline-run-args "--cover pairwise" --drop-data \
      || { fail "bench_recall.sh failed (see $work/recall-joint-cover.out, .err)"; return; }
  echo "Stage B seconds from the run logs (\"B ... s\" of each pair line): pairwise summed over the pairs, joint the one solve."
  echo
  echo "| world | robots | scenarios | sharing robots | merged pairwise / joint | wrong pairwise / joint | A+B+C bytes pairwise / joint | joint / pairwise (all) | stage B s per scenario pairwise / joint | joint at the 60 s cap | joint / pairwise per scenario: median (range) |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
  local name p j
  : >"$work/recall-joint-cover.b"
  while IFS=$'\t' read -r name _; do
    case "$name" in *"(baseline)"*) continue ;; esac
    p=$(grep -oE ', B [0-9.]+ s' "$work/recall-joint-cover/$name.baseline.log" 2>/dev/null | awk '{ s += $3 } END { printf "%.3f", s }')
    j=$(grep -oE ', B [0-9.]+ s' "$work/recall-joint-cover/$name.run.log" 2>/dev/null | awk '$3 > m { m = $3 } END { printf "%.3f", m }')
    printf '%s\t%s\t%s\n' "$name" "$p" "$j" >>"$work/recall-joint-cover.b"
  done <"$work/recall-joint-cover/rows.tsv"
  awk -F'\t' 'FILENAME ~ /\.b$/ { bp[$1] = $2; bj[$1] = $3; next }
    FILENAME ~ /baseline/ { if (NF >= 13) { n = $1; sub(/ \(baseline\)$/, "", n); pm[n] = $4; pw[n] = $5; pb[n] = $8 }; next }
    NF >= 13 { w = substr($1, 1, index($1, "-") - 1); r = ($1 ~ /-5r-/) ? 5 : 3; k = w "\t" r
      if (!(k in seen)) { seen[k] = 1; order[++K] = k }
      cnt[k]++; sh[k] += $3; jm[k] += $4; jw[k] += $5; jb[k] += $8; pmk[k] += pm[$1]; pwk[k] += pw[$1]; pbk[k] += pb[$1]
      sp[k] += bp[$1]; sj[k] += bj[$1]; if (bj[$1] >= 59.5) cap[k]++
      ratio[k, cnt[k]] = (pb[$1] > 0 ? $8 / pb[$1] : 0) }
    END { for (i = 1; i <= K; i++) { k = order[i]; split(k, kk, "\t"); m = cnt[k]
            for (a = 1; a <= m; a++) v[a] = ratio[k, a]
            for (a = 1; a <= m; a++) for (b = a + 1; b <= m; b++) if (v[b] < v[a]) { t = v[a]; v[a] = v[b]; v[b] = t }
            med = m % 2 ? v[(m + 1) / 2] : (v[m / 2] + v[m / 2 + 1]) / 2
            printf "| %s | %s | %d | %d | %d / %d | %d / %d | %.1f / %.1f MiB | %.2f | %.3f / %.1f | %d | %.2f (%.2f-%.2f) |\n",
                   kk[1], kk[2], m, sh[k], pmk[k], jm[k], pwk[k], jw[k], pbk[k] / 1048576, jb[k] / 1048576,
                   (pbk[k] > 0 ? jb[k] / pbk[k] : 0), sp[k] / m, sj[k] / m, cap[k], med, v[1], v[m] } }' \
      "$work/recall-joint-cover.b" "$work/recall-joint-cover/baseline.tsv" "$work/recall-joint-cover/rows.tsv"
  echo
  recall_summary recall-joint-cover
}

sec_ablation() {
  echo "### Exchange-mode ablation: one rule for every mode, beside the paper-exact policy"
  echo
  set +e
  "$here/bench_ablation.sh" --commerge "$bin" --work "$work/ablation" --keyframes 400 --drop-data >"$work/ablation.out" 2>&1
  local rc=$?
  set -e
  echo "Command: \`profiling/bench_ablation.sh --keyframes 400 --drop-data\`. $(stamp)"
  [ "$rc" = 0 ] || { fail "bench_ablation.sh exited $rc (see $work/ablation.out)"; return; }
  echo
  sed -n '/^Sums over the scenarios:/,$p' "$work/ablation.out" | sed '1,2d'
}

sec_recall_scan_context() {
  echo "### Scan Context against the ring descriptor"
  echo
  recall recall-scan-context --slice generated --worlds "campus urban indoor cave" --keyframes 400 \
      --only '-(2r|3r)-(complete|partial)-alternate-w0.5-' --run-args "--descriptor scan-context" \
      --baseline-run-args "--descriptor ring" --drop-data \
      || { fail "bench_recall.sh failed (see $work/recall-scan-context.out, .err)"; return; }
  echo "| scenario | sharing robots | merged ring / Scan Context | wrong | A+B+C bytes ring / Scan Context | less than stored send-all | unmerged, ring | unmerged, Scan Context |"
  echo "|---|---|---|---|---|---|---|---|"
  awk -F'\t' 'FNR == NR { if (NF >= 13) { n = $1; sub(/ \(baseline\)$/, "", n); m[n] = $4; w[n] = $5; b[n] = $8; r[n] = $10; s[n] = $13 }; next }
    NF >= 13 { printf "| %s | %d | %s / %d | %s / %d | %.2f / %.2f MiB | %s / %s %% | %s | %s |\n", $1, $3, m[$1], $4, w[$1], $5,
                      b[$1] / 1048576, $8 / 1048576, r[$1], $10, s[$1], $13 }' \
      "$work/recall-scan-context/baseline.tsv" "$work/recall-scan-context/rows.tsv"
  echo
  recall_summary recall-scan-context
}

# ---------------------------------------------------------------------------------------------------------------
# Component benchmarks: one row each, the benchmark's summary lines as the result.
component() {  # $1 = section, $2 = what, $3 = regex of the summary lines, then the command
  local name=$1 what=$2 re=$3; shift 3
  local log=$work/$name.out
  local t0=$SECONDS
  set +e
  "$@" >"$log" 2>&1
  local rc=$?
  set -e
  [ "$rc" = 0 ] || { fail "\`$(show "$@")\` exited $rc (see $log)"; return; }
  component_header
  component_row "$what" "$(show "$@")" "$(pick "$log" "$re") ($((SECONDS - t0)) s)"
}
sec_bench_voxel_grid() {
  need_data kitti/kitti00_frames0-15 || { fail "KITTI 00 is absent"; return; }
  component bench-voxel-grid "voxel grid, 1 m, KITTI 00 frame 0" 'points in/out|time per call|throughput|peak RSS' \
      "$bench/bench_voxel_grid" --reps 100
}
sec_bench_descriptor() {
  need_data kitti/kitti00_frames0-15 || { fail "KITTI 00 is absent"; return; }
  component bench-descriptor "SOLiD / Scan Context on the same scan" '^(SOLiD|Scan Context|distance|keyframe record)' \
      "$bench/bench_descriptor"
}
sec_bench_robot_keyframe() {
  need_data kitti/kitti00_frames0-15 || { fail "KITTI 00 is absent"; return; }
  component bench-robot-keyframe "robot per keyframe on KITTI 00: SOLiD + voxel + encode/store + loop search over 20 000 descriptors" \
      '^(ms per keyframe|memory per stored|raw scan|peak RSS)' "$bench/bench_robot_keyframe"
}
sec_bench_pose_graph() {
  component bench-pose-graph "pose graph, 500 m circuit, loop every 100 keyframes (nodes, edges, loops, ATE anchored and aligned before / after, LM iterations, CPU and wall ms, workspace)" \
      '^ +[0-9]+ +[0-9]+ +[0-9]+ [|]|^peak RSS' "$bench/bench_pose_graph"
}
sec_bench_affinity() {
  component bench-affinity "affinity + stage A, D = 40, one core" '^==|kernel only|affinity [+] stage A|sequence-half-window|peak RSS' \
      "$bench/bench_affinity" --reps 9
}
sec_bench_max_clique() {
  need_data graphs/dimacs_clique || { fail "the DIMACS graphs are absent"; return; }
  component bench-max-clique "max clique on DIMACS (our branch and bound) and stage C model vs GLPK glp_intopt" \
      '^(==|--)' "$bench/bench_max_clique"
}
sec_bench_vertex_cover() {
  need_data graphs/exchange_cslam_resource || { fail "the exchange graphs are absent"; return; }
  component bench-vertex-cover "stage B model vs GLPK glp_intopt (same MILP, BalancedCoverMilp)" \
      'from:^ours with the GLPK master' "$bench/bench_vertex_cover" --glpk-limit 20
}
sec_bench_registration() {
  component bench-registration "submap registration, 1 m voxels, single thread" \
      'from:^set ' \
      "$bench/bench_registration"
}
sec_bench_sim() {
  component bench-sim "simulator ray casting, one thread (scans/s per world and lidar)" '^[a-z]+ .*[|]|^peak RSS' \
      "$bench/bench_sim" --quick
}
sec_bench_cascade() {
  component bench-cascade "cascade on a generated street mission, 2 x 400 keyframes, 150 overlapping" \
      'stage|policy|loops|clique|GLPK' "$bench/bench_cascade" --keyframes 400 --overlap 150
}
sec_master_lp() {
  echo "### Stage B master LP engines"
  echo
  need_data graphs/exchange_cslam_resource || { fail "the exchange graphs are absent"; return; }
  local fam
  component_header
  for fam in "generated|--family grid --family blocks --family random --family band --family nrobot" \
             "real exchange graphs|--family icra-unbalanced --family icra-balanced --family icra-unit --family rss"; do
    local t0=$SECONDS log=$work/master-lp-${fam%%|*}.out
    log=${log// /-}
    # shellcheck disable=SC2086
    if "$bench/bench_vertex_cover" ${fam#*|} --glpk-limit 10 --our-limit 10 >"$log" 2>&1; then
      component_row "${fam%%|*}: GLPK master against the dense one" "bench_vertex_cover ${fam#*|} --glpk-limit 10 --our-limit 10" \
          "$(pick "$log" 'from:^ours with the GLPK master') ($((SECONDS - t0)) s)"
    else
      fail "bench_vertex_cover failed (see $log)"
    fi
  done
}
sec_clique_lp_bound() {
  echo "### Stage C LP bound"
  echo
  need_data graphs/dimacs_clique || { fail "the DIMACS graphs are absent"; return; }
  set +e
  "$bench/bench_max_clique" --quick --objective edge >"$work/clique-lp-bound.out" 2>&1
  local rc=$?
  set -e
  echo "Command: \`build-host/profiling/bench_max_clique --quick --objective edge\`. $(stamp)"
  [ "$rc" = 0 ] || { fail "bench_max_clique exited $rc (see $work/clique-lp-bound.out)"; return; }
  echo
  echo '```'
  cat "$work/clique-lp-bound.out"
  echo '```'
}

# ---------------------------------------------------------------------------------------------------------------
# Generated scenarios (bench_scenarios.sh prints the markdown rows itself).
scenarios() {  # $1 = section, $2 = work subdir (shared by the settings that reuse data), then options
  local name=$1 dir=$2; shift 2
  set +e
  "$here/bench_scenarios.sh" --commerge "$bin" --work "$work/$dir" "$@" >"$work/$name.out" 2>"$work/$name.err"
  local rc=$?
  set -e
  echo "Command: \`$(show profiling/bench_scenarios.sh --commerge build/commerge "$@")\`. $(stamp)"
  echo
  [ "$rc" = 0 ] || { fail "bench_scenarios.sh exited $rc (see $work/$name.err)"; return; }
  grep '^|' "$work/$name.out"
}
sec_scenarios_same_flat() {
  echo "### Same direction, flat road"; echo
  scenarios scenarios-same-flat same-flat --detection-reflectivity 0.8 --direction same --wobble-deg 0
}
sec_scenarios_tau_area_2500() {
  echo "### Same direction, tau_area 2500"; echo
  scenarios scenarios-tau-area-2500 same-flat --detection-reflectivity 0.8 --direction same --wobble-deg 0 \
      --run-args "--tau-area 2500" --reuse-data
}
sec_scenarios_default() {
  echo "### Default simulator setting"; echo
  scenarios scenarios-default default --detection-reflectivity 0.8
}
sec_scenarios_solid_no_ground() {
  echo "### Default setting, SOLiD without the ground"; echo
  scenarios scenarios-solid-no-ground default --detection-reflectivity 0.8 --run-args "--solid-min-z-m -0.5 --tau-inter 0.2" --reuse-data
}
sec_scenarios_other_way_flat() {
  echo "### Other way round, flat road"; echo
  scenarios scenarios-other-way-flat other-way-flat --detection-reflectivity 0.8 --wobble-deg 0
}
sec_scenarios_seq_smoothed() {
  echo "### Sequence-smoothed stage A"; echo
  scenarios scenarios-seq-smoothed same-flat --detection-reflectivity 0.8 --direction same --wobble-deg 0 \
      --run-args "--sequence-half-window 8" --reuse-data
}
sec_scenarios_smoothing() {
  echo "### Sequence smoothing against the per-cell threshold"; echo
  local f
  for f in scenarios-same-flat scenarios-seq-smoothed scenarios-other-way-flat scenarios-default; do
    [ -f "$work/$f.out" ] || { fail "run $f first (its table in WORK)"; return; }
  done
  scenarios scenarios-smoothing-other-w8 other-way-flat --detection-reflectivity 0.8 --wobble-deg 0 \
      --run-args "--sequence-half-window 8" --reuse-data >/dev/null
  scenarios scenarios-smoothing-default-w8 default --detection-reflectivity 0.8 \
      --run-args "--sequence-half-window 8" --reuse-data >/dev/null
  echo "Robots merged (widened pairs) and worst e_rmse, w = 8 against the default half window, in the three simulator"
  echo "settings: the tables above, and for w = 8 in the other two settings their commands with"
  echo "\`--run-args \"--sequence-half-window 8\" --reuse-data\`. $(stamp)"
  echo
  echo "| world | robots | overlap | same direction, default w | same direction, w = 8 | other way round, flat, default w | other way round, flat, w = 8 | default setting, default w | default setting, w = 8 |"
  echo "|---|---|---|---|---|---|---|---|---|"
  awk -F' [|] ' 'FNR == 1 { file++ }
    /^[|] (urban|campus|indoor|cave) / { k = $1 " | " $2 " | " $3; sub(/^[|] /, "", k)
      v = $4 ($5 == "-" ? "" : ", " $5); cell[k, file] = v; if (file == 1) order[++n] = k }
    END { for (i = 1; i <= n; i++) { k = order[i]; printf "| %s", k; for (f = 1; f <= 6; f++) printf " | %s", cell[k, f]; print " |" } }' \
      "$work/scenarios-same-flat.out" "$work/scenarios-seq-smoothed.out" "$work/scenarios-other-way-flat.out" \
      "$work/scenarios-smoothing-other-w8.out" "$work/scenarios-default.out" "$work/scenarios-smoothing-default-w8.out"
}

sec_long_missions() {
  scenarios long-missions long --keyframes 3000 --direction same --wobble-deg 0 --detection-reflectivity 0.8
}

sec_small_scenes() {
  echo "Command per overlap O: \`profiling/bench_courtyard.sh --overlap O --seeds S --baseline-run-args"
  echo "\"--ground-up-min-tilt-deg 0\"\` (the run: default flags; the baseline: the descriptor levelled by the frame's z)."
  stamp
  echo
  echo "| seeds | overlap | run | summary |"
  echo "|---|---|---|---|"
  local o seeds line
  for o in partial moderate complete; do
    seeds="101 102 103 104 105 106 107 108 109 110"
    [ "$o" = partial ] && seeds="$seeds 111 112 113 114 115 116 117 118 119 120"
    "$repo/profiling/bench_courtyard.sh" --commerge "$bin" --work "$work/small-scenes-$o" --overlap "$o" --seeds "$seeds" \
        --baseline-run-args "--ground-up-min-tilt-deg 0" >"$work/small-scenes-$o.out" 2>&1 \
        || { fail "bench_courtyard.sh failed (see $work/small-scenes-$o.out)"; return; }
    while read -r line; do
      printf '| %s | %s | %s | %s |\n' "${seeds%% *}-${seeds##* }" "$o" "${line%% summary:*}" "${line#*summary: }"
    done < <(grep ' summary: ' "$work/small-scenes-$o.out")
  done
}

# ---------------------------------------------------------------------------------------------------------------
# Tests and missions run by ctest or the profiling scripts.
ctest_table() {  # $1 = section, then ctest options
  local name=$1; shift
  set +e
  ctest --test-dir "$build" "$@" >"$work/$name.out" 2>&1
  local rc=$?
  set -e
  echo "Command: \`$(show ctest --test-dir build-host "$@")\`. $(stamp)"
  echo
  echo "| test | result | seconds |"
  echo "|---|---|---|"
  sed -nE 's/^ *[0-9]+\/[0-9]+ Test +#[0-9]+: (.*[^ .]) \.*[* ]*(Passed|Failed|\*\*\*Failed|Not Run|Timeout|Skipped|[A-Za-z* ]+) +([0-9.]+) sec$/| \1 | \2 | \3 |/p' "$work/$name.out"
  echo
  grep -E 'tests passed|tests failed' "$work/$name.out" | sed 's/^/- /'
  [ "$rc" = 0 ] || fail "ctest exited $rc (see $work/$name.out)"
}
sec_network_faults() {
  ctest_table network-faults -R "lcm mission" -j2
}
sec_replay_load() {
  echo "### Exact replay under load"; echo
  echo "Five runs in a row of the whole host suite with the \`heavy\` tests. $(stamp)"
  echo
  echo "| run | wall time | tests passed | replay | replay-load (3 replays under load) |"
  echo "|---|---|---|---|---|"
  local i t0 log
  for i in 1 2 3 4 5; do
    log=$work/replay-load-$i.out
    t0=$SECONDS
    set +e
    ctest --test-dir "$build" -j3 --timeout 900 >"$log" 2>&1
    set -e
    printf '| %d | %d min %d s | %s | %s | %s |\n' "$i" "$(((SECONDS - t0) / 60))" "$(((SECONDS - t0) % 60))" \
        "$(sed -nE 's/.* tests passed, ([0-9]+) tests failed out of ([0-9]+)/\2 - \1 of \2/p' "$log" | awk '{ print $1 - $3 " of " $5 }')" \
        "$(sed -nE 's/.*lcm mission: replay \.+ *([A-Za-z*]+) +([0-9.]+) sec$/\1, \2 s/p' "$log")" \
        "$(sed -nE 's/.*lcm mission: replay-load \.+ *([A-Za-z*]+) +([0-9.]+) sec$/\1, \2 s/p' "$log")"
  done
  echo
  echo "Command: \`ctest --test-dir build-host -j3 --timeout 900\`, five times."
}
sec_five_robots_memory() {
  local d=$work/five/data
  rm -rf "${work:?}/five"
  run_logged "$work/five.sim.log" "$bin" sim --world urban --robots 5 --overlap complete --direction same --wobble-deg 0 \
      --keyframes 400 --seed 11 --threads 2 --out "$d" --force || { fail "commerge sim failed (see $work/five.sim.log)"; return; }
  set +e
  "$here/peak-ram.sh" "$bin" run "$d/robot_0" "$d/robot_1" "$d/robot_2" "$d/robot_3" "$d/robot_4" --lidar vlp-16 \
      --keyframe-spacing-m 0.9 --modes A+B+C --no-report --no-progress --out "$work/five/run" >"$work/five.run.log" 2>&1
  local rc1=$?
  "$here/peak-ram.sh" "$bin" demo --out "$work/five/demo" >"$work/five.demo.log" 2>&1
  local rc2=$?
  set -e
  echo "| run | command | result | date (commit) |"
  echo "|---|---|---|---|"
  printf '| 5 robots x 400 keyframes, urban | `commerge sim --world urban --robots 5 --overlap complete --direction same --wobble-deg 0 --keyframes 400 --seed 11`, then `profiling/peak-ram.sh commerge run D/robot_0 ... D/robot_4 --lidar vlp-16 --keyframe-spacing-m 0.9 --modes A+B+C --no-report` | %s; robots merged %s | %s (%s) |\n' \
      "$( [ "$rc1" = 0 ] && grep -o 'peak RSS: [0-9.]* MiB[^,]*, wall [0-9.]* s' "$work/five.run.log" | tail -n 1 || echo "run failed")" \
      "$(get mode.A+B+C.robots_merged "$work/five/run/report/metrics.tsv" 2>/dev/null)" "$today" "$commit_note"
  printf '| the demo, 2 robots | `profiling/peak-ram.sh commerge demo` | %s | %s (%s) |\n' \
      "$( [ "$rc2" = 0 ] && grep -o 'peak RSS: [0-9.]* MiB[^,]*, wall [0-9.]* s' "$work/five.demo.log" | tail -n 1 || echo "run failed")" \
      "$today" "$commit_note"
  rm -rf "$d"
}
town() {  # $1 = section, then profile_town.sh options
  local name=$1; shift
  set +e
  "$here/profile_town.sh" --commerge "$bin" --work "$work/$name" "$@" >"$work/$name.out" 2>"$work/$name.err"
  local rc=$?
  set -e
  echo "Command: \`$(show profiling/profile_town.sh --commerge build-host/commerge --work WORK/"$name" "$@")\`. $(stamp)"
  echo
  echo '```'
  cat "$work/$name.out"
  echo '```'
  [ "$rc" = 0 ] || fail "profile_town.sh exited $rc (see $work/$name.err)"
}
sec_five_robots_town() {
  echo "### Five robots at Town scale, ipc-6000"; echo
  town five-robots-town --robots 5 --board ipc-6000 --check --max-runtime-s 2400
}
sec_round_cost() {
  echo "### Round cost at scale"; echo
  local cmd=(taskset -c 0 "$bench/bench_round" --keyframes 3000 --cache "$work/round-cost.cache")
  command -v taskset >/dev/null || cmd=("${cmd[@]:2}")
  set +e
  "${cmd[@]}" >"$work/round-cost.out" 2>&1
  local rc=$?
  set -e
  echo "Command: \`$(show "${cmd[@]}")\`. $(stamp)"
  [ "$rc" = 0 ] || { fail "bench_round exited $rc (see $work/round-cost.out)"; return; }
  echo
  echo '```'
  cat "$work/round-cost.out"
  echo '```'
}
sec_mission_long() {
  town mission-long --check --bytes-budget-mb 3 --max-runtime-s 2400 --keep
  local d=$work/mission-long/data
  if [ -d "$d" ] && [ -d "$work/mission-long/server" ]; then
    echo
    echo "\`build-host/profiling/bench_rigid_floor D W/server\`:"
    echo
    echo '```'
    "$bench/bench_rigid_floor" "$d" "$work/mission-long/server" 2>&1 || true
    echo '```'
  fi
  rm -rf "$d"
}
sec_peak_ram_town() {
  town peak-ram-town
  echo
  ctest_table peak-ram-town-smoke -R "profile town"
}
sec_import_memory() {
  local d=$work/import-memory fixture=$repo/tests/apps/ros1_bag_fixture.py
  rm -rf "$d" && mkdir -p "$d"
  run_logged "$d/sim.log" "$bin" sim --world urban --robots 2 --overlap complete --lidar hdl64 --keyframes 300 \
      --out "$d/sim" || { fail "commerge sim failed (see $d/sim.log)"; return; }
  /usr/bin/python3 "$fixture" "$d/sim/robot_0" "$d/big.bag" --compression none >"$d/big.log" 2>&1 \
    && /usr/bin/python3 "$fixture" "$data/real/hku2:0-133" "$d/hku2a.bag" --compression lz4 >"$d/small.log" 2>&1 \
    || { fail "ros1_bag_fixture.py failed (see $d/big.log, $d/small.log)"; return; }
  rm -rf "$d/sim"
  echo "| bag | file | messages | largest message | chunks | peak RSS | wall |"
  echo "|---|---|---|---|---|---|---|"
  local name bag stats
  for name in "hku2, first half (Livox Avia, PointCloud2)|hku2a" "generated urban, HDL-64|big"; do
    bag=${name#*|}
    set +e
    "$here/peak-ram.sh" "$bin" import "$d/$bag.bag" --scan-topic /velodyne_points --pose-topic /odom \
        --out "$d/$bag.imp" >"$d/$bag.import.log" 2>&1
    local rc=$?
    set -e
    stats=$(/usr/bin/python3 -c 'import rosbag, sys
b = rosbag.Bag(sys.argv[1])
print("%d | %.2f MB | %d" % (b.get_message_count(), max(len(m[1]) for _, m, _ in b.read_messages(raw=True)) / 1e6,
                             len(b._chunks)))' "$d/$bag.bag")
    printf '| %s | %.1f MB | %s | %s |\n' "${name%|*}" "$(awk -v b="$(stat -c %s "$d/$bag.bag")" 'BEGIN { print b / 1e6 }')" "$stats" \
        "$( [ "$rc" = 0 ] && grep -o 'peak RSS: [0-9.]* MiB' "$d/$bag.import.log" | sed 's/peak RSS: //' || echo "import failed") | $(grep -o 'wall [0-9.]* s' "$d/$bag.import.log" | sed 's/wall //')"
    rm -rf "$d/$bag.imp"
  done
  rm -f "$d/big.bag"
}
sec_wire_records() {
  local d=$work/wire-records b
  rm -rf "$d" && mkdir -p "$d"
  run_logged "$d/sim.log" "$bin" sim --world urban --robots 2 --overlap complete --keyframes 3000 --lidar vlp16 \
      --seed 11 --direction same --wobble-deg 0 --force --out "$d/data" || { fail "commerge sim failed (see $d/sim.log)"; return; }
  echo "| --record-descriptor-bits | keyframe records received | per keyframe | streamed pose updates (messages) | total exchanged (A+B+C) | vs stored send-all | scans (selected + padded) | pair merged | e_rmse |"
  echo "|---|---|---|---|---|---|---|---|---|"
  for b in 0 6 7 8 10; do
    "$bin" run "$d/data/robot_0" "$d/data/robot_1" --lidar vlp-16 --keyframe-spacing-m 0.9 --board jetson-nano \
        --max-keyframes 3100 --modes A+B+C --no-progress --no-report --out "$d/run$b" --record-descriptor-bits "$b" \
        >"$d/run$b.log" 2>&1 || { fail "commerge run --record-descriptor-bits $b failed (see $d/run$b.log)"; continue; }
    awk -v b="$b" '/streamed to the server: keyframes/ { rec = $6 " " $7; n = $8; sub(/\(/, "", n)
                                                         pu = $0; sub(/.*pose updates /, "", pu) }
                   /^\| A\+B\+C/ { split($0, c, "|"); for (i in c) gsub(/^ +| +$/, "", c[i])
                                   total = c[7]; vs = c[8]; scans = c[3]; merged = c[9]; e = c[10] }
                   END { kib = rec; sub(/ KiB/, "", kib); if (rec ~ /MiB/) { kib = rec; sub(/ MiB/, "", kib); kib *= 1024 }
                         printf "| %s | %s | %.1f B | %s | %s | %s | %s | %s | %s |\n", (b == 0 ? "0 (92-byte records)" : b), rec,
                                kib * 1024 / n, pu, total, vs, scans, merged, e }' "$d/run$b.log"
  done
  rm -rf "$d/data"
}
sec_field_bundle() {
  local jet=$repo/build-jetson
  [ -d "$jet" ] || { fail "the cross build $jet is absent (cmake -S . -B build-jetson -DCMAKE_TOOLCHAIN_FILE=toolchains/aarch64-jetson-nano.cmake)"; return; }
  echo "| measurement | command | result | date (commit) |"
  echo "|---|---|---|---|"
  local b f
  for b in "$jet" "$build"; do
    if cmake --build "$b" --target bundle >"$work/field-bundle.$(basename "$b").log" 2>&1; then
      f=$(find "$b" -maxdepth 2 -name 'commerge-*.tar.gz' -printf '%T@ %p\n' | sort -n | tail -n 1 | cut -d' ' -f2-)
      component_row "bundle size, $(basename "$b")" "cmake --build $(basename "$b") --target bundle" \
          "\`$(basename "$f")\` $(mib "$(stat -c %s "$f")"), $(tar -tzf "$f" | grep -c '/lib/.') files in \`lib/\`"
    else
      fail "the bundle of $b failed"
    fi
  done
  ctest_table field-bundle-host -R "bundle: "
}
sec_ci_time() {
  local clone=$work/ci-clone
  rm -rf "$clone"
  git clone --quiet "$repo" "$clone"
  local t0=$SECONDS
  set +e
  (cd "$clone" && bash .ci/run) >"$work/ci-time.out" 2>&1
  local rc=$?
  set -e
  echo "Command: \`bash .ci/run\` on a clean clone of $commit (the committed tree, without uncommitted changes). $(stamp)"
  echo
  echo "| run | total | result |"
  echo "|---|---|---|"
  printf '| %s | %d s | %s |\n' "$commit" "$((SECONDS - t0))" "$([ "$rc" = 0 ] && echo "all passed" || echo "exit $rc")"
  echo
  echo "Per stage (tests/run.sh's lines):"
  echo
  echo '```'
  grep -E 'CPU|wall|[0-9]+ s' "$work/ci-time.out" | tail -n 40 || true
  echo '```'
}

# ---------------------------------------------------------------------------------------------------------------
# Driver.
ran=() failed=() times=()
for s in "${sections[@]}"; do
  name=$(field "$s" 0)
  selected "$name" || continue
  fn=sec_${name//-/_}
  echo "[regen $(date +%H:%M:%S)] $name (about $(field "$s" 1)) ..." >&2
  t0=$SECONDS
  section_failed=0
  part=$work/sections/$name.md
  { "$fn"; } >"$part" 2>>"$work/sections/$name.err" || section_failed=1
  secs=$((SECONDS - t0))
  if grep -q '^\*\*Not regenerated:\*\*' "$part"; then section_failed=1; fi
  times+=("$name|$secs")
  if [ "$section_failed" = 1 ]; then failed+=("$name"); else ran+=("$name"); fi
  echo "[regen $(date +%H:%M:%S)] $name: $secs s$([ "$section_failed" = 1 ] && echo ", FAILED")" >&2
done

mkdir -p "$(dirname "$out")"
{
  echo "# Measured results"
  echo
  echo "Regenerated by \`profiling/regen_results.sh\` at commit $commit_note (\`git rev-parse --short HEAD\`), $today,"
  echo "on $(nproc) cores ($(uname -m), $(uname -n)); commerge \`$(show "$bin_orig")\` (built $(date -r "$bin_orig" '+%Y-%m-%d %H:%M'),"
  echo "copied at the start), benchmarks \`$(show "$bench_orig")\`, data \`$(show "$data")\`."
  echo "Sections run: ${ran[*]:-none}.${failed[*]:+ Failed: ${failed[*]}.}"
  echo
  group=""
  for s in "${sections[@]}"; do
    name=$(field "$s" 0)
    [ -f "$work/sections/$name.md" ] || continue
    selected "$name" || continue
    g=$(field "$s" 3); g=${g%%:*}
    if [ "$g" != "$group" ]; then echo "## $g"; echo; group=$g; fi
    cat "$work/sections/$name.md"
    echo
  done
  echo "## Run times of this regeneration"
  echo
  echo "| section | seconds |"
  echo "|---|---|"
  for t in "${times[@]+"${times[@]}"}"; do echo "| ${t%%|*} | ${t#*|} |"; done
} | awk '
  # Consecutive tables with the same header (the component benchmarks, the main job) become one table.
  $0 == "" { blanks++; next }
  /^[|]/ && last ~ /^[|]/ && $0 == hdr { skip = 1; blanks = 0; next }
  skip && /^[|]---/ { skip = 0; next }
  { skip = 0
    if (/^[|]/ && (last !~ /^[|]/ || blanks > 0)) hdr = $0
    else if (!/^[|]/) hdr = ""
    while (blanks > 0) { print ""; blanks-- }
    print; last = $0 }' >"$out"
echo "regen_results.sh: wrote $out (${#ran[@]} sections ran, ${#failed[@]} failed)" >&2
[ "${#failed[@]}" = 0 ] || exit 1
exit 0
}
