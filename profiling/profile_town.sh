#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Peak-RAM profiling of a Town-scale mission with separate processes (issue 8 item 3):
#
#   profiling/profile_town.sh --commerge build-host/commerge --work /work/scratch/town
#
# 1. sim:     `commerge sim --world urban --robots R --keyframes N --lidar vlp16 --overlap complete
#             --direction same --wobble-deg 0 --seed 11`: the robots patrol the same town tour (complete overlap:
#             the largest stage A clusters, so the heaviest cascade and registration rounds), driven the same way
#             round on a flat road (robots driving the other way round, or with roll/pitch wobble, do not merge in
#             urban worlds: profiling/RESULTS.md "Generated scenarios"; with --overlap moderate, about half of each
#             route shared, the 3 x 10 000 mission ended with robot 1 unmerged). About 0.4 MB of .bin files per scan:
#             3 x 10 000 scans take about 12 GB under --work.
# 2. mission: `commerge server` and R `commerge robot` processes on the --board memory profile (--robots R
#             --max-keyframes N), each under `/usr/bin/time -f %M` (peak RSS from the kernel), inside a private
#             network namespace (unshare -n: udpm on loopback only, ttl=0; nothing reaches a real interface).
#             The robots replay their scans as fast as they map them (--rate-hz 1000); the mission ends when
#             the server places every robot in the world frame (--exit-when-merged R).
# Prints the wall time of each phase, then per process its peak RSS against its budget total on jetson-nano and
# ipc-6000 and the goal (server < 512 MB, robot < 384 MB: decimal MB, on the jetson-nano profile), and per
# process the budget, used (at exit) and high-water bytes of every budget module, from the daemons' exit summary
# ("memory:" lines). Samples VmRSS / VmHWM of every process every 2 s into WORK/rss_samples.tsv and prints
# when each process reached its peak. Progress lines on stderr during the run.
#
# Options:
#   --commerge BIN | --build DIR   the commerge executable (native build: qemu inflates RSS)
#   --work DIR                     work directory (logs, table; the dataset under DIR/data unless --data)
#   --keyframes N                  keyframes (scans, 1 m apart) per robot (default 10000)
#   --robots R                     robots (default 3)
#   --board B                      memory profile of the processes (default jetson-nano)
#   --overlap O                    complete | moderate | partial (commerge sim; default complete)
#   --data DIR                     use this `commerge sim` dataset instead of generating one (kept)
#   --keep                         keep the generated dataset (default: deleted at the end)
#   --check                        CI checks: also fail (exit 1) unless every process's peak RSS <= its budget
#                                  total on --board, every module's high-water <= its budget, and (jetson-nano)
#                                  every goal met
#   --max-runtime-s S              the server gives up after S seconds (default 300 + 0.05 N), a robot
#                                  60 + 0.02 N s after its last scan; both still print their memory summary (exit 1)
#   --bytes-budget-mb B            with --check, also fail unless the server received at most the keyframe
#                                  records (92 B each) plus B MB (decimal)
#   --every-round                  the server registers every pair every round (commerge server --every-round):
#                                  the exchange before rounds knew what they had verified
# Then the exchange: what the server received by kind (its exchange_summary.tsv: keyframe records, pose updates,
# scans, re-sends, robot status, the total) and the exchange policies (scan requests) it sent the robots (its
# outgoing traffic, policies_sent_bytes, not in the total), each with its bytes, MB and share of sending every
# stored scan with the records (the stored send-all) and of the raw scans (the dataset's .bin files); the keyframe
# records alone, the stored send-all and the raw scans themselves; d_exch and t_comm (the paper's eqs.
# exchmetric, commmetric); the round at which each robot was first placed (exchange_rounds.tsv); each robot's final
# transform error against the truth (inv(T_gt_start0) T_gt_start_r from start_transforms.txt: translation, and the
# angle of the rotation error); how the placed robots agree along the whole path they share (profiling/path_agreement
# on the server's last trajectories against the dataset's truth: keyframes of two robots within 10 m, the error of
# their relative position; core/eval/path_agreement.hpp). The server's exchange_bytes.png is the bytes per robot
# over time.
# Exit status: 0 when every process exited 0 (and, with --check, every check passed); 1 otherwise; 2 usage.
# Prints "CM-SKIP: ..." and exits 0 when no private network namespace can be created.
set -euo pipefail

usage() { sed -n '3,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; exit 2; }
bin="" work="" keyframes=10000 robots=3 board=jetson-nano data="" keep=0 check=0 max_runtime_s="" overlap=complete
bytes_budget_mb="" every_round=()
args=("$@")
while [ $# -gt 0 ]; do
  case "$1" in
    --commerge) bin=$2; shift 2 ;;
    --build) bin=$2/commerge; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --keyframes) keyframes=$2; shift 2 ;;
    --robots) robots=$2; shift 2 ;;
    --board) board=$2; shift 2 ;;
    --overlap) overlap=$2; shift 2 ;;
    --data) data=$2; shift 2 ;;
    --keep) keep=1; shift ;;
    --check) check=1; shift ;;
    --max-runtime-s) max_runtime_s=$2; shift 2 ;;
    --bytes-budget-mb) bytes_budget_mb=$2; shift 2 ;;
    --every-round) every_round=(--every-round); shift ;;
    -h|--help) usage ;;
    *) echo "profile_town.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ -n "$bin" ] && [ -n "$work" ] || usage
[ -x "$bin" ] || { echo "profile_town.sh: $bin is not an executable (--commerge or --build)" >&2; exit 2; }
case "$keyframes" in ''|*[!0-9]*) echo "profile_town.sh: --keyframes must be a number" >&2; exit 2 ;; esac
case "$robots" in 2|3|4|5) ;; *) echo "profile_town.sh: --robots must be 2..5 (commerge sim)" >&2; exit 2 ;; esac
[ -x /usr/bin/time ] || { echo "profile_town.sh: /usr/bin/time (GNU time) is missing (apt-get install time)" >&2; exit 2; }
case "$overlap" in complete|moderate|partial) ;; *) echo "profile_town.sh: --overlap: complete, moderate or partial" >&2; exit 2 ;; esac
[ -n "$max_runtime_s" ] || max_runtime_s=$((300 + keyframes / 20))

# Everything runs inside a private network namespace: multicast must never reach a real interface.
if [ "${CM_PROFILE_IN_NETNS:-0}" != 1 ]; then
  if ! command -v unshare >/dev/null; then echo "CM-SKIP: unshare (util-linux) is not installed"; exit 0; fi
  if ! unshare -n true 2>/dev/null; then
    echo "CM-SKIP: cannot create a private network namespace (unshare -n needs root or user namespaces)"; exit 0
  fi
  export CM_PROFILE_IN_NETNS=1
  exec unshare -n bash "$0" "${args[@]}"
fi

bin=$(readlink -f "$bin")
mkdir -p "$work"
work=$(readlink -f "$work")
rm -f "$work"/*.err "$work"/*.out "$work"/*.time "$work/rss_samples.tsv" "$work/summary.txt"
rm -rf "$work/server"
ip link set lo up
ip route add 224.0.0.0/4 dev lo
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"

log() { printf '[profile_town %5d s] %s\n' "$((SECONDS - t_start))" "$*" >&2; }
mib() { awk -v b="$1" 'BEGIN { if (b < 0) print "-"; else printf "%.1f MiB", b / 1048576 }'; }
t_start=$SECONDS
pids=()
generated=0  # 1: the dataset is this run's (deleted at the end unless --keep)
cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  if [ "$keep" = 0 ] && [ "$generated" = 1 ] && [ -d "$work/data" ]; then rm -rf "$work/data"; fi
}
trap cleanup EXIT

# ---- Phase 1: the dataset --------------------------------------------------------------------------------
sim_s=0
if [ -n "$data" ]; then
  data=$(readlink -f "$data")
  log "using the dataset $data (not generated)"
else
  data="$work/data"
  generated=1
  log "sim: urban, $robots robots x $keyframes keyframes, VLP-16, overlap $overlap, same direction, flat road -> $data"
  sim_start=$SECONDS
  "$bin" sim --world urban --robots "$robots" --overlap "$overlap" --keyframes "$keyframes" --lidar vlp16 \
      --direction same --wobble-deg 0 --seed 11 --threads 2 --force --out "$data" >"$work/sim.out" 2>"$work/sim.err" &
  sim_pid=$!
  pids+=("$sim_pid")
  total=$((robots * keyframes))
  while kill -0 "$sim_pid" 2>/dev/null; do
    for _ in $(seq 30); do kill -0 "$sim_pid" 2>/dev/null || break; sleep 0.5; done
    kill -0 "$sim_pid" 2>/dev/null || break
    n=$(find "$data" -name '*.bin' 2>/dev/null | wc -l)
    log "sim: $n of $total scans written"
  done
  if ! wait "$sim_pid"; then
    echo "profile_town.sh: commerge sim failed:" >&2; tail -n 5 "$work/sim.err" "$work/sim.out" >&2; exit 1
  fi
  sim_s=$((SECONDS - sim_start))
  log "sim: done in $sim_s s ($(du -sh "$data" | cut -f1))"
fi
for ((r = 0; r < robots; r++)); do
  [ -f "$data/robot_$r/poses.txt" ] || { echo "profile_town.sh: missing $data/robot_$r/poses.txt" >&2; exit 2; }
done

# ---- Phase 2: the mission ----------------------------------------------------------------------------------
tau_area=10000                      # the paper's; a short mission's overlap spans fewer cells
[ "$keyframes" -lt 1000 ] && tau_area=1000
sizing=(--board "$board" --robots "$robots" --max-keyframes "$keyframes")
names=(server)
for ((r = 0; r < robots; r++)); do names+=("robot$r"); done
declare -A tpid cpid
start_proc() {  # $1 = name, rest = commerge arguments
  local name=$1; shift
  /usr/bin/time -f '%M %e %x' -o "$work/$name.time" "$bin" "$@" >"$work/$name.out" 2>"$work/$name.err" &
  tpid[$name]=$!
  pids+=("$!")
}
child_of() {  # the commerge process under /usr/bin/time $1
  local c=""
  [ -r "/proc/$1/task/$1/children" ] && c=$(cat "/proc/$1/task/$1/children" 2>/dev/null)
  [ -z "$c" ] && command -v pgrep >/dev/null && c=$(pgrep -P "$1" 2>/dev/null || true)
  echo "${c%% *}"
}
vm() {  # $1 = pid, $2 = field (VmRSS, VmHWM) -> kB or -1
  local v
  v=$(awk -v f="$2:" '$1 == f { print $2 }' "/proc/$1/status" 2>/dev/null || true)
  echo "${v:--1}"
}

log "mission: server + $robots robots on the $board profile (--max-keyframes $keyframes), tau_area $tau_area"
mission_start=$SECONDS
start_proc server server --out "$work/server" "${sizing[@]}" --exit-when-merged "$robots" --tau-area "$tau_area" \
    --round-quiet-s 3 --max-runtime-s "$max_runtime_s" --linger-s 5 "${every_round[@]}"
sleep 0.5
for ((r = 0; r < robots; r++)); do
  start_proc "robot$r" robot --id "$r" --data "$data/robot_$r" "${sizing[@]}" --lidar vlp-16 \
      --keyframe-spacing-m 0.9 --rate-hz 1000 --exit-when-merged "$robots" --linger-s "$((60 + keyframes / 50))"
done
printf 'time_s\tprocess\tvmrss_kib\tvmhwm_kib\tstate\n' >"$work/rss_samples.tsv"
declare -A peak_at last_hwm
next_log=$SECONDS
while :; do
  running=0
  for name in "${names[@]}"; do
    kill -0 "${tpid[$name]}" 2>/dev/null || continue
    running=1
    [ -n "${cpid[$name]:-}" ] || cpid[$name]=$(child_of "${tpid[$name]}")
    [ -n "${cpid[$name]}" ] || continue
    rss=$(vm "${cpid[$name]}" VmRSS)
    hwm=$(vm "${cpid[$name]}" VmHWM)
    [ "$hwm" -ge 0 ] || continue
    state=$(tail -n 1 "$work/$name.err" 2>/dev/null | sed 's/^commerge [a-z]* *[0-9]*: //' | tr '\t' ' ' | cut -c1-120)
    printf '%d\t%s\t%s\t%s\t%s\n' "$((SECONDS - mission_start))" "$name" "$rss" "$hwm" "$state" >>"$work/rss_samples.tsv"
    if [ "$hwm" -gt "${last_hwm[$name]:-0}" ]; then last_hwm[$name]=$hwm; peak_at[$name]=$((SECONDS - mission_start)); fi
  done
  [ "$running" = 1 ] || break
  if [ "$SECONDS" -ge "$next_log" ]; then
    next_log=$((SECONDS + 15))
    line=""
    for name in "${names[@]}"; do
      kill -0 "${tpid[$name]}" 2>/dev/null || { line+=" $name: exited;"; continue; }
      state=$(tail -n 1 "$work/$name.err" 2>/dev/null | sed 's/^commerge [a-z]* *[0-9]*: //' | cut -c1-60)
      line+=" $name $(mib $(( ${last_hwm[$name]:-0} * 1024 ))) peak (${state});"
    done
    log "mission:${line}"
  fi
  sleep 2
done
mission_s=$((SECONDS - mission_start))
rc=0
declare -A peak_kib exit_code
for name in "${names[@]}"; do
  code=0
  wait "${tpid[$name]}" || code=$?
  read -r kib _secs _x < <(tail -n 1 "$work/$name.time" 2>/dev/null || echo "- - -")
  peak_kib[$name]=$kib
  exit_code[$name]=$code
  if [ "$code" != 0 ]; then
    rc=1
    echo "profile_town.sh: $name exited $code:" >&2
    tail -n 5 "$work/$name.err" "$work/$name.out" >&2 || true
  fi
done
log "mission: done in $mission_s s"

# ---- The exchange ------------------------------------------------------------------------------------------
summary_value() { awk -F'\t' -v k="$1" '$1 == k { print $2 }' "$work/server/exchange_summary.tsv" 2>/dev/null; }
keyframe_record_bytes() {  # 92 B per keyframe the server holds
  local n=0 r k
  for ((r = 0; r < robots; r++)); do k=$(summary_value "robot${r}_keyframes"); n=$((n + ${k:-0})); done
  echo $((n * 92))
}
# Robot r's final T_world_map against inv(T_gt_start0) * T_gt_start_r: "<translation m> <rotation deg>" or
# "unmerged".
transform_error() {
  awk -v id="$1" '
    NR == FNR { if (NF == 12) { n++; for (i = 1; i <= 12; i++) s[n, i] = $i }; next }
    $1 == "robot" && $2 == id && $3 == "merged" { for (i = 1; i <= 12; i++) e[i] = $(i + 3); found = 1 }
    END {
      if (!found) { print "unmerged"; exit }
      for (r = 0; r < 3; r++) for (c = 0; c < 4; c++) { a[r, c] = s[1, 4 * r + c + 1]; b[r, c] = s[id + 1, 4 * r + c + 1] }
      for (r = 0; r < 3; r++) {  # T = inv(a) * b
        for (c = 0; c < 3; c++) { R[r, c] = 0; for (k = 0; k < 3; k++) R[r, c] += a[k, r] * b[k, c] }
        t[r] = 0; for (k = 0; k < 3; k++) t[r] += a[k, r] * (b[k, 3] - a[k, 3])
      }
      for (r = 0; r < 3; r++) for (c = 0; c < 4; c++) E[r, c] = e[4 * r + c + 1]
      tr = 0; for (r = 0; r < 3; r++) for (k = 0; k < 3; k++) tr += R[k, r] * E[k, r]  # trace(R^T E)
      ca = (tr - 1) / 2; if (ca > 1) ca = 1; if (ca < -1) ca = -1
      dx = E[0, 3] - t[0]; dy = E[1, 3] - t[1]; dz = E[2, 3] - t[2]
      printf "%.3f %.2f\n", sqrt(dx * dx + dy * dy + dz * dz), atan2(sqrt(1 - ca * ca), ca) * 180 / 3.141592653589793
    }' "$data/start_transforms.txt" "$work/server/transforms.txt"
}
exchange_table() {
  [ -f "$work/server/exchange_summary.tsv" ] || { echo; echo "exchange: the server wrote no exchange_summary.tsv"; return; }
  local total records send_all raw
  total=$(summary_value total_bytes)
  records=$(keyframe_record_bytes)
  send_all=$(summary_value send_all_bytes)
  raw=$(find "$data" -name '*.bin' -printf '%s\n' | awk '{ s += $1 } END { printf "%.0f", s }')
  echo
  echo "Exchange (bytes the server received, and the policies it sent; decimal MB; per row its share of every stored"
  echo "scan with the records, the stored send-all, and of the raw scans):"
  printf '  %-42s %14s %10s %11s %10s\n' what bytes MB "% send-all" "% raw"
  row() {  # $1 = what, $2 = bytes ("" when the server did not write the key: "-")
    awk -v w="$1" -v b="$2" -v a="$send_all" -v r="$raw" 'BEGIN {
      if (b == "") { printf "  %-42s %14s %10s %11s %10s\n", w, "-", "-", "-", "-"; exit }
      pa = "-"; if (a > 0) pa = sprintf("%.3f", 100 * b / a)
      pr = "-"; if (r > 0) pr = sprintf("%.4f", 100 * b / r)
      printf "  %-42s %14s %10.2f %11s %10s\n", w, b, b / 1e6, pa, pr }'
  }
  row "keyframe records (in batches)" "$(summary_value keyframe_records_bytes)"
  row "pose updates" "$(summary_value pose_updates_bytes)"
  row "scans" "$(summary_value scans_bytes)"
  row "re-sends" "$(summary_value resends_bytes)"
  row "robot status" "$(summary_value robot_status_bytes)"
  row "total received" "$total"
  row "policies sent (the server's outgoing)" "$(summary_value policies_sent_bytes)"
  row "d_exch (eq. exchmetric)" "$(summary_value d_exch_bytes)"
  row "the keyframe records alone (92 B)" "$records"
  row "every stored scan + the records" "$send_all"
  row "the raw scans (.bin files)" "$raw"
  echo "  (policies sent: the scan requests the server published to the robots, repeats included; not in the total received)"
  awk -v t="$total" -v r="$records" -v a="$send_all" -v w="$raw" -v c="$(summary_value t_comm_s)" 'BEGIN {
    printf "  total - records: %.2f MB; %.2f %% less than every stored scan, %.4f %% of the raw scans; t_comm %s s\n",
           (t - r) / 1e6, 100 * (1 - t / a), 100 * t / w, c }'
  echo "  placed (round first in the world frame) and final transform against the truth:"
  local r first err
  for ((r = 1; r < robots; r++)); do
    first=$(awk -F'\t' -v id="$r" 'NR > 1 { n = split($(NF - 1), p, ","); for (i = 1; i <= n; i++) if (p[i] == id) { print $1; exit } }' \
            "$work/server/exchange_rounds.tsv")
    err=$(transform_error "$r")
    printf '    robot %d: round %s; %s\n' "$r" "${first:-never}" "$( [ "$err" = unmerged ] && echo unmerged || awk -v e="$err" 'BEGIN { split(e, v, " "); printf "%s m, %s deg", v[1], v[2] }')"
  done
  # Along the whole shared path, not only where the robots were registered (profiling/path_agreement.cpp).
  local agreement_tool
  agreement_tool="$(dirname "$bin")/profiling/path_agreement"
  if [ -x "$agreement_tool" ] && [ -f "$data/robot_0/poses_gt.txt" ]; then
    echo "  along the shared path (the server's last trajectories against the truth):"
    echo "    $("$agreement_tool" --trajectories "$work/server/trajectories" --data "$data" 2>&1)"
  else
    echo "  along the shared path: not measured (no $agreement_tool or no ground truth in $data)"
  fi
}

# ---- The table ---------------------------------------------------------------------------------------------
budget_total() {  # $1 = robot|server, $2 = board -> bytes (from `commerge budget`'s total line)
  "$bin" budget --app "$1" --board "$2" --robots "$robots" --max-keyframes "$keyframes" 2>/dev/null |
    awk '$1 == "total" { v = $2; u = $3; m = (u == "GiB") ? 1073741824 : (u == "MiB") ? 1048576 : (u == "KiB") ? 1024 : 1
                         printf "%.0f\n", v * m; exit }'
}
declare -A total_nano total_ipc
for app in robot server; do
  total_nano[$app]=$(budget_total "$app" jetson-nano)
  total_ipc[$app]=$(budget_total "$app" ipc-6000)
done
checks_failed=0
fail_check() { checks_failed=1; echo "CHECK FAILED: $*"; }
{
  echo "Town-scale mission: urban, $robots robots x $keyframes keyframes (VLP-16, overlap $overlap, same direction,"
  echo "flat road, seed 11); processes on the $board profile (--robots $robots --max-keyframes $keyframes)"
  echo
  printf '%-10s %8s\n' phase "wall [s]"
  printf '%-10s %8s\n' sim "$sim_s" mission "$mission_s"
  echo
  printf '%-8s %4s %13s %13s %13s %10s %5s %13s\n' process exit "peak RSS" "jetson-nano" "ipc-6000" goal "" "peak at [s]"
  for name in "${names[@]}"; do
    app=robot; goal_mb=384
    [ "$name" = server ] && { app=server; goal_mb=512; }
    kib=${peak_kib[$name]}
    bytes=-1
    case "$kib" in ''|*[!0-9]*) ;; *) bytes=$((kib * 1024)) ;; esac
    goal_text="< $goal_mb MB"
    verdict=miss
    if [ "$board" != jetson-nano ]; then
      goal_text="-"; verdict="-"  # the field goals are the Jetson Nano's; other boards: within the budget total
    elif [ "$bytes" -ge 0 ] && [ "$bytes" -lt $((goal_mb * 1000000)) ]; then
      verdict=pass
    fi
    printf '%-8s %4s %13s %13s %13s %10s %5s %13s\n' "$name" "${exit_code[$name]}" "$(mib "$bytes")" \
        "$(mib "${total_nano[$app]:--1}")" "$(mib "${total_ipc[$app]:--1}")" "$goal_text" "$verdict" "${peak_at[$name]:--}"
    if [ "$check" = 1 ]; then
      [ "$verdict" != miss ] || fail_check "$name: peak RSS $(mib "$bytes") is not below the goal $goal_mb MB"
      own_total=$(sed -n 's/^memory: peak RSS .*\[\(-\{0,1\}[0-9]*\) \([0-9]*\)\]$/\2/p' "$work/$name.err" | tail -n 1)
      if [ -z "$own_total" ]; then
        fail_check "$name: no memory exit summary on stderr"
      elif [ "$bytes" -lt 0 ] || [ "$bytes" -gt "$own_total" ]; then
        fail_check "$name: peak RSS $(mib "$bytes") exceeds its $board budget total $(mib "$own_total")"
      fi
    fi
  done
  echo "(peak RSS: GNU time's maxrss of each process; goals in decimal MB: 512 MB = 488.3 MiB, 384 MB = 366.2 MiB)"
  for name in "${names[@]}"; do
    echo
    echo "$name modules ($board budget; used at exit; high-water; '-' = not measured):"
    printf '  %-18s %12s %12s %12s\n' module budget used high-water
    while read -r module budget used high; do
      printf '  %-18s %12s %12s %12s\n' "$module" "$(mib "$budget")" "$(mib "$used")" "$(mib "$high")"
      if [ "$check" = 1 ] && [ "$high" -gt "$budget" ]; then
        fail_check "$name: module $module high-water $(mib "$high") exceeds its budget $(mib "$budget")"
      fi
    done < <(sed -n 's/^memory: \([a-z_.]*\) .*\[\(-\{0,1\}[0-9]*\) \(-\{0,1\}[0-9]*\) \(-\{0,1\}[0-9]*\)\]$/\1 \2 \3 \4/p' \
               "$work/$name.err")
    sed -n 's/^memory: \(peak RSS .*\)  \[.*$/  \1/p' "$work/$name.err"
  done
  merged=$(grep -h "^server: [0-9]* merge rounds" "$work/server.out" 2>/dev/null || true)
  echo
  echo "${merged:-server: no final line (it did not finish)}"
  exchange_table
} | tee "$work/summary.txt"
# The block above runs in a pipeline's subshell: its failed checks reach here through the summary's lines.
if grep -q '^CHECK FAILED' "$work/summary.txt"; then checks_failed=1; fi
if [ "$check" = 1 ] && [ -n "$bytes_budget_mb" ]; then
  total=$(summary_value total_bytes)
  records=$(keyframe_record_bytes)
  if [ -z "$total" ] || ! awk -v t="$total" -v r="$records" -v b="$bytes_budget_mb" 'BEGIN { exit !(t <= r + b * 1e6) }'; then
    echo "CHECK FAILED: the server received ${total:-?} B, more than the keyframe records ($records B) + $bytes_budget_mb MB"
    checks_failed=1
  fi
fi
[ "$checks_failed" = 0 ] || rc=1
exit "$rc"
