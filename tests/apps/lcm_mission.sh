#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# One LCM mission with separate processes (commerge server + one commerge robot per robot of the dataset) under a
# network fault, inside a private network namespace (udpm on loopback only, ttl=0; never a real interface). Used by
# the CTest tests "lcm mission: ..." (tests/apps/lcm_mission_tests.cmake) and runnable by hand:
#
#   tests/apps/lcm_mission.sh --commerge build-host/commerge --data SIMDIR --work /tmp/m --scenario loss50
#
# SIMDIR is a `commerge sim` dataset of N = 2..5 robots (robot_0 .. robot_<N-1>, start_transforms.txt with one row
# per robot); N is the number of robot_<i>/poses.txt, counted from robot_0. The server runs with --robots N and
# --exit-when-merged N, the robots with --exit-when-merged N. Scenarios:
#   clean           no fault
#   loss10 loss50   nftables drops 10 % / 50 % of the packets to the LCM multicast group, at random (ingress)
#   tbf2mbit        tc tbf limits loopback to 2 Mbit/s (robots capped at 800 kbit/s each)
#   delay2s         every process holds each outgoing message 2 s (application-level delay stage); robots
#                   re-announce after 5 s (--resend-timeout-s), longer than the 4 s round trip
#   dup-reorder     every process sends 20 % of its messages twice and holds each up to 300 ms at random
#   robot-restart   robot 1 is killed (SIGKILL) mid-mission and started again (a new session)
#   server-restart  the server is killed (SIGKILL) mid-mission and started again (a new session)
#   hostile         cm_lcm_sampler --hostile (give --sampler) publishes, during the mission, messages the daemons
#                   must refuse and count: truncated, foreign fingerprint, random, 100 kB random, another type, and
#                   keyframes / poses of robot 40 (not one of --robots N); server and robots must count all of them
#   live            robot 1 maps live input: `commerge feed` plays its directory as lidar_scan_t + odometry_t at
#                   20 Hz on the board-local input URL, and `commerge robot --live` synchronises and maps it
#   replay          a clean mission recorded with `commerge record` (complete by the senders' sequence numbers),
#                   then played back with lcm-logplayer into a fresh `commerge server --replay`, which must
#                   follow every recorded round step with the same requests and reproduce the recorded merge;
#                   then the same log without its round steps (lcm-logplayer -e), as a log from before them:
#                   the replay must say so and still run
#   replay-load     replay under CPU load: 3 busy loops (on 2 cores) run beside the recorded mission and beside
#                   3 replays of its log, each of which must follow every round step exactly
#   scan-context    robots and server with --descriptor scan-context (1226-byte Scan Context records, one per
#                   batch) and 10 % of the packets dropped as in loss10
#   attack          cm_lcm_sampler --attack (give --sampler) captures the daemons' signed messages and publishes
#                   them replayed, tampered, re-signed with another team's key, and signed as robot 40; server and
#                   robots must refuse and count every one (until the first merge result that places every robot:
#                   robots leave soon after, so each robot must refuse every kind, the server every message)
# Every scenario runs with message authentication on: a fresh team key (`commerge keygen`) and --auth-key for the
# server and the robots (CM_MISSION_AUTH=0 runs without).
# Passes (exit 0) when every final process exits 0 and
#   - each robot's descriptor digest line equals the server's line for that robot and session (every keyframe
#     and every descriptor delivered, bit for bit: 100 %),
#   - the T_world_map of every robot r >= 1 in transforms.txt is within 0.5 m / 2 deg of the truth from
#     start_transforms.txt, inv(T_gt_start0) * T_gt_start_r,
#   - the server wrote merged_map.pcd and .ply, readable by `commerge voxelize`, with at least 1000 points;
#   - with --checker CHECK (cm_check_exchange_outputs): its exchange_rounds.tsv, exchange_summary.tsv and
#     exchange_bytes.png read back consistent, the summary's total the bytes the server said it received.
# Prints one summary line with the bytes each robot sent, the share re-sent, what the server received against
# sending every stored scan and the raw scans (with --checker), and each robot's transform error.
set -euo pipefail

usage() { sed -n '3,/^set -euo/p' "$0" | sed '$d'; exit 2; }
bin="" data="" work="" scenario="" sampler="" checker=""
while [ $# -gt 0 ]; do
  case "$1" in
    --commerge) bin=$2; shift 2 ;;
    --data) data=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --scenario) scenario=$2; shift 2 ;;
    --sampler) sampler=$2; shift 2 ;;
    --checker) checker=$2; shift 2 ;;
    -h|--help) usage ;;
    *) echo "lcm_mission.sh: unknown argument '$1'" >&2; usage ;;
  esac
done
[ -n "$bin" ] && [ -n "$data" ] && [ -n "$work" ] && [ -n "$scenario" ] || usage
case "$scenario" in
  clean|loss10|loss50|tbf2mbit|delay2s|dup-reorder|robot-restart|server-restart|hostile|live|replay|replay-load|attack|\
  scan-context) ;;
  *) echo "lcm_mission.sh: unknown scenario '$scenario'" >&2; exit 2 ;;
esac
for f in "$data/robot_0/poses.txt" "$data/robot_1/poses.txt" "$data/start_transforms.txt"; do
  [ -f "$f" ] || { echo "lcm_mission.sh: missing $f (generate the dataset with commerge sim)" >&2; exit 2; }
done
n=0  # robots in the dataset
while [ -f "$data/robot_$n/poses.txt" ]; do n=$((n + 1)); done
if [ "$n" -gt 5 ]; then echo "lcm_mission.sh: $data holds $n robots; commerge sim writes 2..5" >&2; exit 2; fi
rows=$(awk 'NF == 12' "$data/start_transforms.txt" | wc -l)
if [ "$rows" != "$n" ]; then
  echo "lcm_mission.sh: $data/start_transforms.txt holds $rows 3x4 rows for $n robots" >&2
  exit 2
fi
ids=$(seq 0 $((n - 1)))

# Re-run inside a private network namespace: multicast must never reach a real interface.
if [ "${CM_MISSION_IN_NETNS:-0}" != 1 ]; then
  if ! command -v unshare >/dev/null; then echo "CM-SKIP: unshare (util-linux) is not installed"; exit 0; fi
  if ! unshare -n true 2>/dev/null; then
    echo "CM-SKIP: cannot create a private network namespace (unshare -n needs root or user namespaces)"; exit 0
  fi
  export CM_MISSION_IN_NETNS=1
  exec unshare -n bash "$0" --commerge "$bin" --data "$data" --work "$work" --scenario "$scenario" \
       ${sampler:+--sampler "$sampler"} ${checker:+--checker "$checker"}
fi

bin=$(readlink -f "$bin")
[ -z "$checker" ] || checker=$(readlink -f "$checker")
rm -rf "$work"
mkdir -p "$work"
cd "$work"
ip link set lo up
ip link set lo mtu 1500  # a WiFi-sized MTU: larger messages are IP-fragmented, and one lost fragment loses them
ip route add 224.0.0.0/4 dev lo
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"
# Kernel counters of this namespace (/proc/net/snmp): $1 = "Udp:" or "Ip:", $2 = the column.
snmp() {
  awk -v t="$1" -v c="$2" '$1 == t { if (!h) { for (i = 2; i <= NF; i++) col[$i] = i; h = 1 } else print $col[c] }' \
      /proc/net/snmp
}
udp_rcvbuf_errors() { snmp Udp: RcvbufErrors; }  # datagrams dropped because a socket's receive buffer was full
rcvbuf_note() {  # where a message may have been lost before a process could count it
  echo "(in this namespace the kernel dropped $(udp_rcvbuf_errors) datagrams at full receive buffers and failed" \
       "$(snmp Ip: ReasmFails) IP reassemblies; LCM itself drops silently beyond a subscription's queue" \
       "capacity of messages a process has not polled yet)"
}
auth=()
if [ "${CM_MISSION_AUTH:-1}" != 0 ]; then
  "$bin" keygen --out "$work/team.key" >/dev/null
  auth=(--auth-key "$work/team.key")
fi

pids=()
cleanup() {
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
}
trap cleanup EXIT

# Give-up times grow with the robots (more data, more pairs per round): 2 robots 240 s, 5 robots 330 s; the robots
# wait for the merge until 40 s before the server gives up.
max_runtime_s=$((180 + 30 * n))
server_args=(server --out "$work/server" --robots "$n" --tau-area 1000 --round-quiet-s 3 --exit-when-merged "$n"
             --max-runtime-s "$max_runtime_s" --linger-s 30 "${auth[@]}")
robot_args=(--lidar vlp-16 --keyframe-spacing-m 0.9 --rate-hz 40 --linger-s $((max_runtime_s - 40))
            --exit-when-merged "$n" "${auth[@]}")
fault=()
case "$scenario" in
  loss10|loss50|scan-context)
    pct=10
    [ "$scenario" = scan-context ] || pct=${scenario#loss}
    if [ "$scenario" = scan-context ]; then
      server_args+=(--descriptor scan-context)
      robot_args+=(--descriptor scan-context)
    fi
    # Match the destination address (non-first IP fragments carry no UDP header) on ingress (PLATFORM.md 4.5).
    nft add table ip cmloss
    nft add chain ip cmloss pre '{ type filter hook prerouting priority -300; }'
    nft add rule ip cmloss pre ip daddr 239.255.76.67 numgen random mod 100 '<' "$pct" counter drop
    ;;
  tbf2mbit)
    tc qdisc add dev lo root tbf rate 2mbit burst 131072 latency 400ms
    robot_args+=(--bandwidth-kbps 800)
    ;;
  delay2s)
    fault=(--delay-ms 2000)
    robot_args+=(--resend-timeout-s 5)  # the round trip is 4 s: re-announce only after a status could have come
    ;;
  dup-reorder) fault=(--duplicate-pct 20 --jitter-ms 300) ;;
esac

start_server() {  # $1 = log name
  "$bin" "${server_args[@]}" "${fault[@]}" >"$work/$1.out" 2>"$work/$1.err" &
  server_pid=$!
  pids+=("$server_pid")
}
wait_listening() {  # $@ = log names of daemons: waits (at most 60 s) until each has subscribed
  local name
  for name in "$@"; do
    for _ in $(seq 600); do grep -q ": session " "$work/$name.err" 2>/dev/null && continue 2; sleep 0.1; done
    echo "lcm_mission.sh: $name did not subscribe within 60 s:" >&2
    tail -n 5 "$work/$name.err" >&2 || true
    exit 1
  done
}
robot_pid=() robot_log=()  # by robot id: the final process and its log name
start_robot() {  # $1 = id, $2 = log name
  local input=(--data "$data/robot_$1")
  if [ "$scenario" = live ] && [ "$1" = 1 ]; then input=(--live --idle-finish-s 3); fi
  "$bin" robot --id "$1" "${input[@]}" "${robot_args[@]}" "${fault[@]}" >"$work/$2.out" 2>"$work/$2.err" &
  robot_pid[$1]=$!
  robot_log[$1]=$2
  pids+=("$!")
}

burners=()
start_burners() {  # $1 = seconds: 3 busy loops, each ending by itself
  local i
  for i in 1 2 3; do
    timeout "$1" bash -c 'while :; do :; done' &
    burners+=("$!")
    pids+=("$!")
  done
}
stop_burners() {
  local p
  for p in "${burners[@]}"; do kill "$p" 2>/dev/null || true; wait "$p" 2>/dev/null || true; done
  burners=()
}
is_replay=0
case "$scenario" in replay|replay-load) is_replay=1 ;; esac
[ "$scenario" = replay-load ] && start_burners "$max_runtime_s"

logger_pid=""
if [ "$is_replay" = 1 ]; then
  command -v lcm-logplayer >/dev/null ||
    { echo "CM-SKIP: lcm-logplayer (Debian liblcm-bin) is not installed"; exit 0; }
  # commerge record, not lcm-logger: lcm-logger keeps LCM's queue of 30 messages and lost scan chunks under CPU
  # load (apps/README.md, "Recording and replay").
  "$bin" record --out "$work/mission.lcmlog" --force --quiet >"$work/logger.out" 2>"$work/logger.err" &
  logger_pid=$!
  pids+=("$logger_pid")
  sleep 0.5
fi

start=$SECONDS
start_server server
sleep 0.5
for id in $ids; do start_robot "$id" "robot$id"; done
case "$scenario" in
  hostile)
    [ -x "$sampler" ] || { echo "lcm_mission.sh: hostile needs --sampler (cm_lcm_sampler)" >&2; exit 2; }
    # Every hostile message must reach a subscriber: wait until each daemon has subscribed (it names its session
    # right after). Under CPU load a robot's start-up once took over a second, and the 27 messages it published
    # before were counted by no robot (both robots 273 of 300, CI 270).
    wait_listening server "${robot_log[@]}"
    "$sampler" --hostile --count 20 --rate-hz 10 >"$work/sampler.out" 2>"$work/sampler.err" &
    sampler_pid=$!
    pids+=("$sampler_pid")
    ;;
  attack)
    [ -x "$sampler" ] || { echo "lcm_mission.sh: attack needs --sampler (cm_lcm_sampler)" >&2; exit 2; }
    [ ${#auth[@]} -gt 0 ] || { echo "lcm_mission.sh: attack needs authentication (CM_MISSION_AUTH=1)" >&2; exit 2; }
    "$sampler" --attack "$work/team.key" --attack-s 15 --attack-per-s 5 >"$work/sampler.out" 2>"$work/sampler.err" &
    sampler_pid=$!
    pids+=("$sampler_pid")
    ;;
  live)
    # The robot's map frame is its first mapped scan: start the feed once the robot listens.
    for _ in $(seq 100); do grep -q "live input" "$work/robot1.err" 2>/dev/null && break; sleep 0.1; done
    # 1 m between scans at 20 Hz = 20 m/s, under the robot's 30 m/s odometry plausibility limit.
    "$bin" feed --data "$data/robot_1" --rate-hz 20 --quiet >"$work/feed.out" 2>"$work/feed.err" &
    feed_pid=$!
    pids+=("$feed_pid")
    ;;
  robot-restart)
    sleep 2.5
    kill -9 "${robot_pid[1]}"
    wait "${robot_pid[1]}" 2>/dev/null || true
    echo "lcm_mission.sh: killed robot 1 after 2.5 s, starting it again" >&2
    start_robot 1 robot1-restarted
    ;;
  server-restart)
    sleep 3
    kill -9 "$server_pid"
    wait "$server_pid" 2>/dev/null || true
    echo "lcm_mission.sh: killed the server after 3 s, starting it again" >&2
    start_server server-restarted
    ;;
esac

rc=0
wait_for() {  # $1 = pid, $2 = name
  local code=0
  wait "$1" || code=$?
  [ "$code" = 0 ] && return 0
  echo "lcm_mission.sh: $2 exited $code:" >&2
  tail -n 5 "$work/$2.err" "$work/$2.out" >&2 || true
  rc=1
}
server_log=server
[ "$scenario" = server-restart ] && server_log=server-restarted
for id in $ids; do wait_for "${robot_pid[$id]}" "${robot_log[$id]}"; done
wait_for "$server_pid" "$server_log"
[ "$scenario" = live ] && wait_for "$feed_pid" feed
[ "$scenario" = hostile ] || [ "$scenario" = attack ] && wait_for "$sampler_pid" sampler
elapsed=$((SECONDS - start))
[ "$rc" = 0 ] || { echo "lcm_mission.sh: $scenario: a process failed" >&2; exit 1; }

# Every keyframe and descriptor of each robot's final session is at the server, bit for bit.
for id in $ids; do
  robot_line=$(grep "^robot $id session " "$work/${robot_log[$id]}.out" | sed "s/^robot $id //")
  server_line=$(grep "^server: robot $id session " "$work/$server_log.out" | sed "s/^server: robot $id //")
  if [ -z "$robot_line" ] || [ "$robot_line" != "$server_line" ]; then
    echo "lcm_mission.sh: robot $id: descriptors not all delivered:" >&2
    echo "  robot : ${robot_line:-<none>}" >&2
    echo "  server: ${server_line:-<none>}" >&2
    exit 1
  fi
  case "$robot_line" in
    *"descriptors 0,"*) echo "lcm_mission.sh: robot $id made no descriptor at all" >&2; exit 1 ;;
  esac
done

# Each robot's placement against the truth: T_true(r) = inv(T_gt_start0) * T_gt_start_r.
transform_error() {  # $1 = transforms.txt, $2 = robot id r >= 1 -> "translation_m yaw_deg" or "unmerged"
  awk -v id="$2" '
    NR == FNR { if (NF == 12) { n++; for (i = 1; i <= 12; i++) s[n, i] = $i }; next }
    $1 == "robot" && $2 == id && $3 == "merged" { for (i = 1; i <= 12; i++) e[i] = $(i + 3); found = 1 }
    END {
      if (!found) { print "unmerged"; exit }
      # rows of the 3x4 matrices: a = start 0, b = start r (row r + 1 of start_transforms.txt)
      for (r = 0; r < 3; r++) for (c = 0; c < 4; c++) {
        a[r, c] = s[1, 4 * r + c + 1]; b[r, c] = s[id + 1, 4 * r + c + 1]
      }
      # T = inv(a) * b: R = a_R^T b_R, t = a_R^T (b_t - a_t)
      for (r = 0; r < 3; r++) {
        for (c = 0; c < 3; c++) { R[r, c] = 0; for (k = 0; k < 3; k++) R[r, c] += a[k, r] * b[k, c] }
        t[r] = 0; for (k = 0; k < 3; k++) t[r] += a[k, r] * (b[k, 3] - a[k, 3])
      }
      dx = e[4] - t[0]; dy = e[8] - t[1]; dz = e[12] - t[2]
      yaw_true = atan2(R[1, 0], R[0, 0]); yaw_est = atan2(e[5], e[1])
      d = (yaw_est - yaw_true) * 180 / 3.141592653589793
      while (d > 180) d -= 360; while (d < -180) d += 360
      printf "%.3f %.2f\n", sqrt(dx * dx + dy * dy + dz * dz), (d < 0 ? -d : d)
    }' "$data/start_transforms.txt" "$1"
}
errors_text=""
failed=0
for id in $ids; do
  [ "$id" = 0 ] && continue  # robot 0's map is the world frame
  err=$(transform_error "$work/server/transforms.txt" "$id")
  if [ "$err" = unmerged ]; then
    echo "lcm_mission.sh: robot $id is not merged in transforms.txt" >&2
    failed=1
    continue
  fi
  read -r err_m err_deg <<<"$err"
  if ! awk -v m="$err_m" -v d="$err_deg" 'BEGIN { exit !(m < 0.5 && d < 2.0) }'; then
    echo "lcm_mission.sh: wrong merge: robot $id is $err_m m / $err_deg deg from the truth" >&2
    failed=1
  fi
  errors_text+=" robot $id within $err_m m / $err_deg deg of the truth;"
done
[ "$failed" = 0 ] || exit 1

# The server's map files: the scans it holds of every robot, in the world frame (robot id per point).
for f in merged_map.pcd merged_map.ply; do
  [ -s "$work/server/$f" ] || { echo "lcm_mission.sh: the server wrote no $f" >&2; exit 1; }
done
map_points=$("$bin" voxelize "$work/server/merged_map.pcd" "$work/map_check.ply" --voxel-size-m 1 |
             sed -n 's/.*merged_map.pcd: \([0-9]*\) points.*/\1/p')
if [ -z "$map_points" ] || [ "$map_points" -lt 1000 ]; then
  echo "lcm_mission.sh: the server's merged_map.pcd holds ${map_points:-no} points" >&2
  exit 1
fi

# What the server received over the mission, read back from its exchange files (cm_check_exchange_outputs, given
# with --checker), against sending every stored scan and the raw scans (every .bin file of the dataset).
received=$(sed -n 's/^server: .*; \([0-9]*\) bytes received;.*/\1/p' "$work/$server_log.out" | tail -n 1)
exchange_text=""
if [ -n "$checker" ]; then
  check=$("$checker" "$work/server" "$n" "${received:-0}") ||
    { echo "lcm_mission.sh: $check" >&2; exit 1; }
  total=$(awk -F'\t' '$1 == "total_bytes" { print $2 }' "$work/server/exchange_summary.tsv")
  send_all=$(awk -F'\t' '$1 == "send_all_bytes" { print $2 }' "$work/server/exchange_summary.tsv")
  raw=$(find "$data" -name '*.bin' -printf '%s\n' | awk '{ s += $1 } END { printf "%.0f", s }')
  exchange_text=$(awk -v t="$total" -v a="$send_all" -v r="$raw" 'BEGIN {
    printf " the server received %.0f B: %.2f %% of every stored scan with the records (%.0f B), %.4f %% of the raw scans (%.0f B);",
           t, 100 * t / a, a, 100 * t / r, r }')
fi

bytes_text=""
for id in $ids; do
  line=$(grep "^robot $id: " "$work/${robot_log[$id]}.out")
  sent=$(sed -n 's/.*bytes sent \([0-9]*\), resent \([0-9]*\).*/\1/p' <<<"$line")
  resent=$(sed -n 's/.*bytes sent \([0-9]*\), resent \([0-9]*\).*/\2/p' <<<"$line")
  pct=$(awk -v s="$sent" -v r="$resent" 'BEGIN { printf "%.1f", (s > 0) ? 100 * r / s : 0 }')
  bytes_text+=" robot $id sent $sent B ($resent B = $pct % re-sent);"
done
dropped=""
if [ "$scenario" = loss10 ] || [ "$scenario" = loss50 ] || [ "$scenario" = scan-context ]; then
  dropped=" nftables dropped $(nft list table ip cmloss | sed -n 's/.*counter packets \([0-9]*\).*/\1/p') packets;"
fi

if [ "$scenario" = hostile ] || [ "$scenario" = attack ]; then
  expected=$(sed -n 's/.*'"$scenario"': \([0-9]*\) messages the server must refuse.*/\1/p' "$work/sampler.out")
  counted=$(sed -n 's/.*; \([0-9]*\) messages rejected.*/\1/p' "$work/$server_log.out")
  if [ -z "$expected" ] || [ -z "$counted" ] || [ "$counted" -lt "$expected" ]; then
    echo "lcm_mission.sh: the server counted ${counted:-?} rejected messages, fewer than the ${expected:-?} hostile" \
         "ones $(rcvbuf_note)" >&2
    exit 1
  fi
  expected_robot=$(sed -n 's/.*, \([0-9]*\) each robot must refuse.*/\1/p' "$work/sampler.out")
  # attack: a robot may leave right after the merge result that ends the attack, before the attacker's last copies
  # of it arrive; each reason is checked below.
  [ "$scenario" = attack ] && expected_robot=$((expected_robot > 12 ? expected_robot - 12 : 0))
  # hostile: each robot must count every one of the 300 (the sampler starts once every daemon listens).
  robot_counts=""
  for id in $ids; do
    k=$(sed -n 's/.*rejected messages \([0-9]*\).*/\1/p' "$work/${robot_log[$id]}.out")
    if [ -z "$k" ] || [ -z "$expected_robot" ] || [ "$k" -lt "$expected_robot" ]; then
      echo "lcm_mission.sh: robot $id counted ${k:-?} rejected messages, fewer than the ${expected_robot:-?} hostile" \
           "ones $(rcvbuf_note)" >&2
      exit 1
    fi
    robot_counts+=" $k"
  done
  dropped+=" $scenario: server rejected $counted (>= $expected sent), robots rejected$robot_counts"
  [ "$scenario" = hostile ] && dropped+=" of $expected_robot sent"
  dropped+=";"
fi
if [ "$scenario" = attack ]; then
  # Each kind of attack reached the server's verifier and was refused for its own reason.
  whos=(server)
  for id in $ids; do whos+=("robot $id"); done
  for who in "${whos[@]}"; do
    [ "$who" = server ] && log=$server_log || log=${robot_log[${who#robot }]}
    summary=$(grep "^$who auth: " "$work/$log.out")
    for reason in "replayed" "bad MAC" "unknown sender"; do
      case "$summary" in
        *"$reason "[1-9]*) ;;
        *) echo "lcm_mission.sh: attack: $who refused nothing as '$reason': $summary" >&2; exit 1 ;;
      esac
    done
  done
  dropped+=" $(sed -n 's/.*attack: .*(\(.*\))$/\1/p' "$work/sampler.out");"
fi
if [ ${#auth[@]} -gt 0 ]; then
  overhead=$(sed -n 's/^robot 0 auth: \([0-9]*\) messages signed, \([0-9]*\) B each = [^(]*(\([0-9.]*\) %.*/\1 messages x \2 B = \3 %/p' \
             "$work/robot0.out")
  dropped+=" auth on (robot 0: ${overhead:-?} of its bytes);"
fi

# $1 = name, $2 = lcm-logplayer channel regex ("" = every channel): plays the log into a fresh replay server.
replay_log() {
  server_args=(server --out "$work/$1" --robots "$n" --tau-area 1000 --round-quiet-s 3 --exit-when-merged "$n"
               --max-runtime-s "$max_runtime_s" --linger-s 0 --replay "${auth[@]}")
  start_server "$1"
  sleep 0.5
  lcm-logplayer ${2:+-e "$2"} "$work/mission.lcmlog" >"$work/$1-logplayer.out" 2>&1 &
  player_pid=$!
  pids+=("$player_pid")
  rc=0
  wait_for "$server_pid" "$1"
  kill "$player_pid" 2>/dev/null || true
}
# $1 = name: the replay followed every round step exactly and reproduced the recorded transforms.txt.
check_exact_replay() {
  [ "$rc" = 0 ] || { echo "lcm_mission.sh: $1: the replay server did not merge or differed" >&2; exit 1; }
  local line
  line=$(grep "^server: replay followed " "$work/$1.out" || true)
  case "$line" in
    *" round steps of recording server session "*": 0 differed; "*" compared, 0 differed "*) ;;
    *) echo "lcm_mission.sh: $1: the replay did not follow the recorded round steps: ${line:-<no summary>}" >&2
       grep "MISMATCH" "$work/$1.err" >&2 || true
       exit 1 ;;
  esac
  # Every robot's line: merged or not and T_world_map (a robot missing from one file differs by its matrix).
  diff_m=$(awk 'FNR == 1 { f++ }
                $1 == "robot" { r[$2] = 1; st[f, $2] = $3; for (i = 4; i <= 15; i++) v[f, $2, i] = $i }
                END { m = 0
                      for (id in r) {
                        if (st[1, id] != st[2, id]) m = 1e9
                        for (i = 4; i <= 15; i++) {
                          d = v[1, id, i] - v[2, id, i]; if (d < 0) d = -d; if (d > m) m = d
                        }
                      }
                      printf "%.6f", m }' "$work/server/transforms.txt" "$work/$1/transforms.txt")
  if ! awk -v d="$diff_m" 'BEGIN { exit !(d < 0.001) }'; then
    echo "lcm_mission.sh: $1: the replayed merge differs from the recorded one by $diff_m (largest matrix entry)" \
         "$(rcvbuf_note)" >&2
    exit 1
  fi
  steps=$(echo "$line" | sed -n 's/^server: replay followed \([0-9]*\) round steps.*/\1/p')
}

if [ "$is_replay" = 1 ]; then
  kill -INT "$logger_pid"
  rc=0
  wait "$logger_pid" 2>/dev/null || rc=$?
  [ "$rc" = 0 ] && [ -s "$work/mission.lcmlog" ] ||
    { echo "lcm_mission.sh: commerge record failed (exit $rc): $(cat "$work/logger.err")" >&2; exit 1; }
  # The recording must be complete by the senders' sequence numbers, or no replay could reproduce the merge.
  grep -q "; 0 missing by the senders' sequence numbers" "$work/logger.out" ||
    { echo "lcm_mission.sh: the recording is incomplete: $(cat "$work/logger.out") $(rcvbuf_note)" >&2; exit 1; }
  replays=1
  [ "$scenario" = replay-load ] && replays=3
  summary=""
  for i in $(seq "$replays"); do
    name=replay
    [ "$replays" = 1 ] || name=replay$i
    replay_log "$name" ""
    check_exact_replay "$name"
    summary+=" $name: $steps steps, requests as recorded, largest difference $diff_m;"
  done
  stop_burners
  if [ "$scenario" = replay ]; then
    # A log from before round steps: the same log without COMMERGE_ROUND replays as before, with a warning.
    replay_log replay-old 'COMMERGE_(KEYFRAMES|POSES|POLICY|SCANS|TRANSFER_STATUS|MERGE_RESULT|ROBOT_STATUS|SERVER_STATUS)'
    grep -q "replay: warning: the log shows .* before any round step" "$work/replay-old.err" &&
      grep -q "^server: replay without round steps" "$work/replay-old.out" ||
      { echo "lcm_mission.sh: a log without round steps was not replayed with the warning" >&2; exit 1; }
    summary+=" the log without round steps replayed with the warning (exit $rc);"
  fi
  echo "lcm mission $scenario: $(stat -c %s "$work/mission.lcmlog") B log replayed into fresh servers;$summary" \
       "$(sed 's/^record: //' "$work/logger.out")"
fi

dropped+=" kernel receive-buffer drops $(udp_rcvbuf_errors);"
echo "lcm mission $scenario, $n robots: merged in ${elapsed} s; descriptors delivered 100 % (digests equal);" \
     "${bytes_text# }$dropped${exchange_text} ${errors_text# } server map $map_points points"
