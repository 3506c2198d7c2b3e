#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# commerge-ros1-bridge end to end with a real ROS 1 graph (Debian's ros-core), inside a private network namespace
# (loopback only: ROS's TCP and LCM's udpm, ttl=0, can reach no other address). CTest: "ros1 bridge: ..."
# (tests/apps/ros1_bridge_tests.cmake, label heavy). By hand:
#
#   tests/apps/ros1_bridge_test.sh --commerge build-host/commerge --bridge build-host/commerge-ros1-bridge \
#       --fixture tests/apps/ros1_bag_fixture.py --listener tests/apps/ros1_bridge_listener.py --work /tmp/rb
#
# 1. `commerge sim` writes a two-robot urban world (80 scans each); ros1_bag_fixture.py writes one bag per robot
#    (/robot_<r>/velodyne_points PointCloud2 in the Velodyne driver's layout, /robot_<r>/odom Odometry).
# 2. roscore; one `commerge server --exit-when-merged 2` on the team bus; per robot one `commerge robot --live`
#    and one bridge on that robot's own board-local LCM URL (port 7671 + r, ttl=0). Bridge 0 also plays the
#    server host's bridge (--server-out: tf and the merged map), bridge 1 publishes tf too (--results).
# 3. `rosbag play -r 2` of both bags at once (the robots drive at the same time, 15 m/s).
# Passes when the server and both robots exit 0 (merged, robot 1 within 0.5 m / 2 deg of the truth), each bridge
# forwarded all 80 scans and 80 odometry samples and dropped nothing, and a rospy subscriber
# (ros1_bridge_listener.py) receives /tf_static with world -> robot_1/map equal to the server's transforms.txt and
# the latched map with the points of the server's final merged_map.pcd. Without the ROS 1 tools it fails (the
# bridge is only built where toolchains/install-deps.sh installed them); it prints "CM-SKIP: ..." (CTest: skipped)
# only where no private network namespace can be made.
set -euo pipefail

usage() { sed -n '3,/^set -euo/p' "$0" | sed '$d'; exit 2; }
bin="" bridge="" fixture="" listener="" work=""
while [ $# -gt 0 ]; do
  case "$1" in
    --commerge) bin=$2; shift 2 ;;
    --bridge) bridge=$2; shift 2 ;;
    --fixture) fixture=$2; shift 2 ;;
    --listener) listener=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    -h|--help) usage ;;
    *) echo "ros1_bridge_test.sh: unknown argument '$1'" >&2; usage ;;
  esac
done
[ -n "$bin" ] && [ -n "$bridge" ] && [ -n "$fixture" ] && [ -n "$listener" ] && [ -n "$work" ] || usage

for tool in roscore rosbag; do
  # toolchains/install-deps.sh installs them wherever the bridge is built: missing is a failure, not a skip.
  command -v "$tool" >/dev/null || { echo "FAIL: $tool is not installed (Debian ros-core, librosbag-dev)" >&2; exit 1; }
done
if ! /usr/bin/python3 -c 'import rospy, rosbag, sensor_msgs.msg, tf2_msgs.msg' 2>/dev/null; then
  echo "FAIL: Debian's python3-rospy, python3-rosbag, python3-sensor-msgs or python3-tf2-msgs is missing" >&2; exit 1
fi
if [ "${CM_ROS1_BRIDGE_IN_NETNS:-0}" != 1 ]; then
  if ! command -v unshare >/dev/null; then echo "CM-SKIP: unshare (util-linux) is not installed"; exit 0; fi
  if ! unshare -n true 2>/dev/null; then
    echo "CM-SKIP: cannot create a private network namespace (unshare -n needs root or user namespaces)"; exit 0
  fi
  export CM_ROS1_BRIDGE_IN_NETNS=1
  exec unshare -n bash "$0" --commerge "$bin" --bridge "$bridge" --fixture "$fixture" --listener "$listener" \
       --work "$work"
fi

bin=$(readlink -f "$bin") bridge=$(readlink -f "$bridge") fixture=$(readlink -f "$fixture")
listener=$(readlink -f "$listener")
rm -rf "$work"
mkdir -p "$work"
cd "$work"
ip link set lo up
ip route add 224.0.0.0/4 dev lo
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"
input_url() { echo "udpm://239.255.76.67:$((7671 + $1))?ttl=0&recv_buf_size=16777216"; }  # robot $1's board
export ROS_MASTER_URI=http://127.0.0.1:11311 ROS_IP=127.0.0.1 ROS_HOME="$work/ros" ROS_LOG_DIR="$work/ros/log"
unset ROS_HOSTNAME
start=$SECONDS

pids=() roscore_pid=""
cleanup() {
  local p
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null || true; done
  # roscore (roslaunch) runs rosmaster and rosout as children: end its whole process group (its own, by setsid),
  # first with SIGINT so roslaunch stops them itself.
  if [ -n "$roscore_pid" ]; then
    kill -INT -- "-$roscore_pid" 2>/dev/null || true
    for _ in $(seq 50); do kill -0 -- "-$roscore_pid" 2>/dev/null || break; sleep 0.1; done
    kill -9 -- "-$roscore_pid" 2>/dev/null || true
  fi
}
trap cleanup EXIT
fail() {  # $1 = message; the logs' tails follow
  echo "ros1_bridge_test.sh: $1" >&2
  local f
  for f in "$work"/*.err "$work"/*.out; do
    [ -s "$f" ] || continue
    echo "--- $f" >&2
    tail -n 6 "$f" >&2
  done
  exit 1
}
wait_line() {  # $1 = log, $2 = pattern, $3 = what: waits at most 30 s
  for _ in $(seq 300); do grep -q "$2" "$1" 2>/dev/null && return 0; sleep 0.1; done
  fail "$3: no '$2' in $1 within 30 s"
}

# 1. The fixture.
"$bin" sim --world urban --robots 2 --overlap complete --keyframes 80 --azimuth-steps 360 --direction same \
       --wobble-deg 0 --seed 11 --out sim >sim.out 2>sim.err || fail "commerge sim failed"
for r in 0 1; do
  /usr/bin/python3 "$fixture" "sim/robot_$r" "robot_$r.bag" --scan-topic "/robot_$r/velodyne_points" \
                   --pose-topic "/robot_$r/odom" >"bag$r.out" 2>"bag$r.err" || fail "ros1_bag_fixture.py failed"
done

# 2. roscore, the server, the robots and their bridges.
setsid roscore -p 11311 >roscore.out 2>roscore.err &
roscore_pid=$!
for _ in $(seq 300); do rostopic list >/dev/null 2>&1 && break; sleep 0.1; done
rostopic list >/dev/null 2>&1 || fail "roscore did not come up within 30 s"

"$bin" server --out server --robots 2 --tau-area 1000 --round-quiet-s 3 --exit-when-merged 2 --max-runtime-s 100 \
       --linger-s 20 >server.out 2>server.err &
server_pid=$!
pids+=("$server_pid")
robot_pid=()
for r in 0 1; do
  "$bin" robot --id "$r" --live --input-lcm-url "$(input_url "$r")" --idle-finish-s 3 --lidar vlp-16 \
         --keyframe-spacing-m 0.9 --exit-when-merged 2 --linger-s 80 >"robot$r.out" 2>"robot$r.err" &
  robot_pid[$r]=$!
  pids+=("$!")
done
bridge_pid=()
for r in 0 1; do
  results=(--results)
  [ "$r" = 0 ] && results=(--server-out "$work/server" --map-poll-s 0.5)
  "$bridge" --scan-topic "/robot_$r/velodyne_points" --odom-topic "/robot_$r/odom" --lcm-url "$(input_url "$r")" \
            "${results[@]}" --report-s 5 >"bridge$r.out" 2>"bridge$r.err" &
  bridge_pid[$r]=$!
  pids+=("$!")
done
wait_line server.err ": session " server
for r in 0 1; do
  wait_line "robot$r.err" "live input" "robot $r"
  wait_line "bridge$r.err" "running as ROS node" "bridge $r"
done

# 3. Both bags at once, twice the recorded rate, after 1 s for the subscribers to connect.
rosbag play -q -d 1 -r 2 robot_0.bag robot_1.bag >play.out 2>play.err || fail "rosbag play failed"

rc=0
wait_for() {  # $1 = pid, $2 = name
  local code=0
  wait "$1" || code=$?
  [ "$code" = 0 ] || { echo "ros1_bridge_test.sh: $2 exited $code" >&2; rc=1; }
}
for r in 0 1; do wait_for "${robot_pid[$r]}" "robot $r"; done
wait_for "$server_pid" server
[ "$rc" = 0 ] || fail "a commerge process failed"
# Robot 1's placement against the truth, inv(T_gt_start0) * T_gt_start1 (as tests/apps/lcm_mission.sh checks it).
placement=$(awk '
  NR == FNR { if (NF == 12) { n++; for (i = 1; i <= 12; i++) s[n, i] = $i }; next }
  $1 == "robot" && $2 == 1 && $3 == "merged" { for (i = 1; i <= 12; i++) e[i] = $(i + 3); found = 1 }
  END {
    if (!found) { print "unmerged"; exit }
    for (r = 0; r < 3; r++) for (c = 0; c < 4; c++) { a[r, c] = s[1, 4 * r + c + 1]; b[r, c] = s[2, 4 * r + c + 1] }
    for (r = 0; r < 3; r++) {
      for (c = 0; c < 3; c++) { R[r, c] = 0; for (k = 0; k < 3; k++) R[r, c] += a[k, r] * b[k, c] }
      t[r] = 0; for (k = 0; k < 3; k++) t[r] += a[k, r] * (b[k, 3] - a[k, 3])
    }
    dx = e[4] - t[0]; dy = e[8] - t[1]; dz = e[12] - t[2]
    d = (atan2(e[5], e[1]) - atan2(R[1, 0], R[0, 0])) * 180 / 3.141592653589793
    while (d > 180) d -= 360; while (d < -180) d += 360
    printf "%.3f %.2f\n", sqrt(dx * dx + dy * dy + dz * dz), (d < 0 ? -d : d)
  }' sim/start_transforms.txt server/transforms.txt)
case "$placement" in
  unmerged) fail "server/transforms.txt does not place robot 1" ;;
esac
awk -v p="$placement" 'BEGIN { split(p, v, " "); exit !(v[1] <= 0.5 && v[2] <= 2.0) }' ||
  fail "robot 1 placed $placement (m, deg) from the truth; more than 0.5 m / 2 deg"

# 4. What rviz would see: tf and the final map (latched; bridge 0 re-reads merged_map.pcd within 1 s).
map_points=$(awk '$1 == "POINTS" { print $2; exit }' server/merged_map.pcd)
[ "${map_points:-0}" -gt 0 ] || fail "server/merged_map.pcd has no points"
/usr/bin/python3 "$listener" --child robot_1/map --robot 1 --transforms server/transforms.txt \
                 --map-points "$map_points" --timeout-s 30 >listener.out 2>listener.err ||
  fail "the ROS subscriber did not receive the tf and the map"

# 5. The bridges' summaries: every scan and odometry sample forwarded, nothing dropped.
for r in 0 1; do
  kill -INT "${bridge_pid[$r]}"
  wait_for "${bridge_pid[$r]}" "bridge $r"
  line=$(grep "^ros1-bridge: scans " "bridge$r.out" || true)
  want_scans="scans 80 received, 80 published"
  want_rest="dropped scans: none; odometry 80 received, 80 published; dropped odometry: none; LCM publish errors 0"
  case "$line" in
    *"$want_scans"*"$want_rest"*) ;;
    *) fail "bridge $r did not forward every message: ${line:-no summary}" ;;
  esac
done
[ "$rc" = 0 ] || fail "a bridge failed"
grep -q "tf updates ([1-9]" bridge1.out || fail "bridge 1 published no tf"
echo "ros1 bridge: merged in $((SECONDS - start)) s, robot 1 placed ${placement% *} m / ${placement#* } deg from" \
     "the truth; $(tail -n 1 listener.out)"
echo "bridge 0: $(grep '^ros1-bridge: scans ' bridge0.out)"
