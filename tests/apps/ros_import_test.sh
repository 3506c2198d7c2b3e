#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# End to end: ROS 1 bags written by the official writer (tests/apps/ros1_bag_fixture.py on Debian's python3-rosbag)
# from KITTI-layout directories, converted back by `commerge import`, then merged by `commerge run`. Checks:
#   1. the listing names every topic with its type and count and proposes the scan and pose topics;
#   2. the imported directories hold the same points (float32 x y z, bit for bit) and the same poses (within 1e-9)
#      as the directories the bags were written from, the clouds' per-point times in point_times/, and --gt (a TUM
#      file on the stamps' clock) interpolated at the scans' stamps;
#   3. `commerge run` on the imports gives the transforms of `commerge run` on the original directories (within
#      1e-6), for a generated two-robot world (PointCloud2 in the Velodyne driver's layout: lz4 chunks and
#      Odometry; bz2 chunks and PoseStamped) and, when ../shared/data is present, the real hku2 sequence in halves
#      (uncompressed PointCloud2, and livox_ros_driver/CustomMsg in lz4 chunks);
#   4. bad input is a clear error: a truncated bag, a corrupt chunk, a missing topic, a topic of the wrong type.
# Usage: ros_import_test.sh COMMERGE FIXTURE_WRITER WORK [SHARED_DATA_DIR]
set -euo pipefail
bin=$1
fixture=$2
work=$3
shared=${4:-}
. "$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/import_checks.sh"

# Debian's python3-rosbag is installed by toolchains/install-deps.sh; without it this test fails, it does not skip.
"$py" -c 'import rosbag, roslz4, genpy, sensor_msgs.msg, nav_msgs.msg, geometry_msgs.msg' \
  || fail "$py cannot import rosbag / roslz4 / sensor_msgs (apt-get install python3-rosbag python3-roslz4 python3-sensor-msgs python3-nav-msgs python3-geometry-msgs)"

rm -rf "$work"
mkdir -p "$work"
cd "$work"



# --- 1-3: a generated two-robot world -------------------------------------------------------------------------
"$bin" sim --world urban --robots 2 --overlap complete --keyframes 80 --azimuth-steps 360 --direction same \
  --wobble-deg 0 --out sim >/dev/null
"$py" "$fixture" sim/robot_0 r0.bag --compression lz4 --extra-topic
"$py" "$fixture" sim/robot_1 r1.bag --compression bz2 --pose-type posestamped

"$bin" import r0.bag > list.txt
grep -Eq '^  /velodyne_points +sensor_msgs/PointCloud2 +80  scan \(PointCloud2\)$' list.txt || { cat list.txt; fail "listing: /velodyne_points"; }
grep -Eq '^  /odom +nav_msgs/Odometry +80  pose \(Odometry\)$' list.txt || { cat list.txt; fail "listing: /odom"; }
grep -Eq '^  /rosout_note +std_msgs/String +80  -$' list.txt || { cat list.txt; fail "listing: /rosout_note"; }
grep -q '^would take: --scan-topic /velodyne_points --pose-topic /odom$' list.txt || { cat list.txt; fail "listing: proposal"; }

"$bin" import r0.bag --scan-topic /velodyne_points --pose-topic /odom --out imp0 > imp0.txt
grep -q ': 80 scans with poses' imp0.txt || { cat imp0.txt; fail "import r0.bag: not 80 scans"; }
grep -q 'scans dropped by the synchroniser: 0 ' imp0.txt || { cat imp0.txt; fail "import r0.bag: scans dropped"; }
grep -q 'per-point times of 80 scans (field time) in point_times/\*.bin' imp0.txt || { cat imp0.txt; fail "import r0.bag: point times"; }
# The Velodyne layout's per-point "time" (the fixture writes 0.1 s * i / n for point i of n) is kept per scan.
"$py" - imp0/velodyne/000005.bin imp0/point_times/000005.bin <<'EOF' || fail "imp0/point_times/000005.bin: not the fixture's times"
import struct, sys
n = len(open(sys.argv[1], 'rb').read()) // 16
t = open(sys.argv[2], 'rb').read()
assert len(t) == 4 * n, (len(t), n)
for i, (v,) in enumerate(struct.iter_unpack('<f', t)):
    assert abs(v - 0.1 * i / n) < 1e-6, (i, v)
EOF
"$bin" import r1.bag --scan-topic /velodyne_points --pose-topic /pose --out imp1 > imp1.txt
same_dataset sim/robot_0 imp0
same_dataset sim/robot_1 imp1
# --gt: the simulator's ground truth as a TUM file on the stamps' clock (the fixture adds 1.7e9 s to times.txt),
# interpolated at each imported scan's stamp, must give back poses_gt.txt.
"$py" - sim/robot_0/poses_gt.txt sim/robot_0/times.txt gt0_tum.txt <<'EOF'
import math, sys
poses = [[float(x) for x in l.split()] for l in open(sys.argv[1]) if l.strip()]
times = [float(x) for x in open(sys.argv[2]).read().split()]
with open(sys.argv[3], 'w') as f:
    f.write('# t x y z qx qy qz qw\n')
    for t, v in zip(times, poses):
        r = [[v[0], v[1], v[2]], [v[4], v[5], v[6]], [v[8], v[9], v[10]]]
        w = math.sqrt(max(0.0, 1 + r[0][0] + r[1][1] + r[2][2])) / 2
        x = math.copysign(math.sqrt(max(0.0, 1 + r[0][0] - r[1][1] - r[2][2])) / 2, r[2][1] - r[1][2])
        y = math.copysign(math.sqrt(max(0.0, 1 - r[0][0] + r[1][1] - r[2][2])) / 2, r[0][2] - r[2][0])
        z = math.copysign(math.sqrt(max(0.0, 1 - r[0][0] - r[1][1] + r[2][2])) / 2, r[1][0] - r[0][1])
        f.write('%.9f %.17g %.17g %.17g %.17g %.17g %.17g %.17g\n' % (1700000000.0 + t, v[3], v[7], v[11], x, y, z, w))
EOF
"$bin" import r0.bag --scan-topic /velodyne_points --pose-topic /odom --gt gt0_tum.txt --out imp0gt > imp0gt.txt
"$py" - sim/robot_0/poses_gt.txt imp0gt/poses_gt.txt <<'EOF' || fail "imp0gt/poses_gt.txt: not the simulator's ground truth"
import sys
a, b = ([[float(x) for x in l.split()] for l in open(p) if l.strip()] for p in sys.argv[1:3])
assert len(a) == len(b), (len(a), len(b))
worst = max(abs(x - y) for la, lb in zip(a, b) for x, y in zip(la, lb))
print('ground truth at the scans\' stamps agrees within %.1e' % worst)
assert worst < 1e-4, worst
EOF
head -n 3 gt0_tum.txt > gt_short.txt
expect_error "ground truth too short" 'gt_short\.txt: scan [0-9]+ at [0-9.]+ s lies outside its times' \
  "$bin" import r0.bag --scan-topic /velodyne_points --pose-topic /odom --gt gt_short.txt --out imp0short
"$bin" run sim/robot_0 sim/robot_1 --lidar vlp16 --out run_dir > run_dir.txt
"$bin" run imp0 imp1 --lidar vlp16 --out run_bag > run_bag.txt
same_transforms run_dir/transforms.txt run_bag/transforms.txt

# --- 3: the real hku2 sequence in halves ------------------------------------------------------------------------
hku2=${shared:+$shared/real/hku2}
if [ -n "$hku2" ] && [ -f "$hku2/poses.txt" ]; then
  "$py" "$fixture" "$hku2:0-133" h0.bag --compression none
  "$py" "$fixture" "$hku2:133-266" h1.bag --compression lz4 --scan-type livox
  "$bin" import h0.bag --scan-topic /velodyne_points --pose-topic /odom --out himp0 > himp0.txt
  "$bin" import h1.bag --scan-topic /livox/lidar --pose-topic /odom --out himp1 > himp1.txt
  grep -q ': 133 scans with poses' himp1.txt || { cat himp1.txt; fail "import h1.bag: not 133 scans"; }
  "$bin" run "$hku2:0-133" "$hku2:133-266" --lidar avia --out hrun_dir > hrun_dir.txt
  "$bin" run himp0 himp1 --lidar avia --out hrun_bag > hrun_bag.txt
  same_transforms hrun_dir/transforms.txt hrun_bag/transforms.txt
else
  echo "real hku2 part not run: no ${hku2:-../shared/data}/real/hku2 (the generated world's checks ran)"
fi

# --- 4: bad input -----------------------------------------------------------------------------------------------
size=$(stat -c %s r0.bag)
head -c $((size / 2)) r0.bag > cut.bag
expect_error "truncated bag" 'cut\.bag: .*offset [0-9]+' "$bin" import cut.bag --scan-topic /velodyne_points --pose-topic /odom --out cut
# A corrupt lz4 chunk: the bytes 2000..2063 of the first chunk's data overwritten.
cp r0.bag corrupt.bag
printf '%064d' 0 | dd of=corrupt.bag bs=1 seek=6000 conv=notrunc status=none
expect_error "corrupt chunk" 'corrupt\.bag: .*chunk at offset [0-9]+' "$bin" import corrupt.bag --scan-topic /velodyne_points --pose-topic /odom --out corrupt
expect_error "missing topic" 'r0\.bag: no topic /points' "$bin" import r0.bag --scan-topic /points --pose-topic /odom --out missing
expect_error "wrong type" '--scan-topic /odom: type nav_msgs/Odometry is not a point cloud' "$bin" import r0.bag --scan-topic /odom --pose-topic /odom --out wrong
printf 'not a bag\n' > text.bag
expect_error "not a bag" 'text\.bag' "$bin" import text.bag
echo "ros import: all checks passed"
