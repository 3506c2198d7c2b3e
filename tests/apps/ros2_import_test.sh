#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# End to end: ROS 2 recordings written by writers that are not commerge's (tests/apps/mcap_fixture.mjs: the
# official MCAP writer @mcap/core, Foxglove's ROS 2 CDR serializer; Python's sqlite3 for rosbag2 .db3) from
# KITTI-layout directories, converted back by `commerge import`, then merged by `commerge run`. Checks:
#   1. the listing names every topic with its ROS 2 type and count and proposes the scan and pose topics;
#   2. the imported directories hold the same points (float32 x y z intensity, bit for bit) and the same poses
#      (within 1e-9) as the directories the recordings were written from;
#   3. `commerge run` on the imports gives the transforms of `commerge run` on the original directories (within
#      1e-6), for a generated two-robot world (MCAP with lz4 chunks and Odometry, MCAP with zstd chunks and
#      PoseStamped, rosbag2 .db3 with Odometry) and, when ../shared/data is present, the real hku2 sequence in
#      halves (MCAP PointCloud2, and MCAP livox_ros_driver2/CustomMsg);
#   4. bad input is a clear error: a truncated MCAP file, a corrupt chunk, a file that is not a .db3.
# Step 0 installs the writers' npm packages (pinned in tests/apps/package.json and package-lock.json) with npm ci
# into NODE_DEPS when they are missing or the lockfile changed; without node or npm, or when the install fails
# with the registry reachable, the test fails and says why. Only where `npm ping` cannot reach the registry does it
# print "CM-SKIP: ..." (the writers cannot be fetched; the readers' unit tests still run).
# Usage: ros2_import_test.sh COMMERGE FIXTURE_WRITER NODE_DEPS WORK [SHARED_DATA_DIR]
set -euo pipefail
bin=$1
fixture=$2
deps=$3
work=$4
shared=${5:-}
. "$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/import_checks.sh"

# --- 0: the writers' packages ---------------------------------------------------------------------------------
src=$(cd "$(dirname "$fixture")" && pwd)
command -v node >/dev/null || fail "node is not installed (the ROS 2 fixtures are written by Node.js: apt-get install nodejs npm, Node >= 20)"
command -v npm >/dev/null || fail "npm is not installed (apt-get install npm)"
node_major=$(node -p 'process.versions.node.split(".")[0]')
[ "$node_major" -ge 18 ] || fail "node $(node --version) is too old: the fixture writers need Node >= 18"
mkdir -p "$deps"
if [ ! -d "$deps/node_modules" ] || ! cmp -s "$src/package-lock.json" "$deps/package-lock.json"; then
  echo "installing the fixture writers' npm packages into $deps (npm ci)"
  rm -rf "$deps/node_modules"
  cp "$src/package.json" "$src/package-lock.json" "$deps/"
  if ! npm ci --prefix "$deps" --no-audit --no-fund > "$deps/npm-ci.log" 2>&1; then
    rm -rf "$deps/node_modules"
    # Only an unreachable registry is a skip (the machine cannot fetch the writers); any other failure fails.
    if ! npm ping > "$deps/npm-ping.log" 2>&1; then
      echo "CM-SKIP: the npm registry is unreachable from this machine (npm ping failed: $deps/npm-ping.log), so the official MCAP writer cannot be installed; the MCAP and db3 readers' unit tests ran"
      exit 0
    fi
    tail -30 "$deps/npm-ci.log" >&2
    fail "npm ci in $deps failed with the registry reachable (log above: $deps/npm-ci.log)"
  fi
fi
node -e 'const r = require("module").createRequire(process.argv[1] + "/package.json");
         for (const p of ["@mcap/core", "@foxglove/rosmsg", "@foxglove/rosmsg2-serialization", "@foxglove/wasm-zstd",
                          "lz4js"]) r(p);' "$deps" \
  || fail "the packages in $deps/node_modules do not load (remove $deps/node_modules to reinstall)"
export COMMERGE_NODE_DEPS=$deps
write() { node "$fixture" "$@" || fail "mcap_fixture.mjs $* failed"; }

rm -rf "$work"
mkdir -p "$work"
cd "$work"



# --- 1-3: a generated two-robot world -------------------------------------------------------------------------
"$bin" sim --world urban --robots 2 --overlap complete --keyframes 80 --azimuth-steps 360 --direction same \
  --wobble-deg 0 --out sim >/dev/null
write sim/robot_0 r0.mcap --compression lz4 --extra-topic
write sim/robot_1 r1.mcap --compression zstd --pose-type posestamped
write sim/robot_1 r1.db3 --format db3

"$bin" import r0.mcap > list.txt
grep -q '^r0\.mcap (MCAP): 3 topics, 240 messages$' list.txt || { cat list.txt; fail "listing: header"; }
grep -Eq '^  /velodyne_points +sensor_msgs/msg/PointCloud2 +80  scan \(PointCloud2\)$' list.txt || { cat list.txt; fail "listing: /velodyne_points"; }
grep -Eq '^  /odom +nav_msgs/msg/Odometry +80  pose \(Odometry\)$' list.txt || { cat list.txt; fail "listing: /odom"; }
grep -Eq '^  /rosout_note +std_msgs/msg/String +80  -$' list.txt || { cat list.txt; fail "listing: /rosout_note"; }
grep -q '^would take: --scan-topic /velodyne_points --pose-topic /odom$' list.txt || { cat list.txt; fail "listing: proposal"; }
"$bin" import r1.db3 > list_db3.txt
grep -q '^r1\.db3 (rosbag2 sqlite3): 2 topics, 160 messages$' list_db3.txt || { cat list_db3.txt; fail "db3 listing: header"; }
grep -q '^would take: --scan-topic /velodyne_points --pose-topic /odom$' list_db3.txt || { cat list_db3.txt; fail "db3 listing: proposal"; }

import_ok() {  # FILE POSE_TOPIC OUT
  "$bin" import "$1" --scan-topic /velodyne_points --pose-topic "$2" --out "$3" > "$3.txt" || { cat "$3.txt"; fail "import $1"; }
  grep -q ': 80 scans with poses' "$3.txt" || { cat "$3.txt"; fail "import $1: not 80 scans"; }
  grep -q 'scans dropped by the synchroniser: 0 ' "$3.txt" || { cat "$3.txt"; fail "import $1: scans dropped"; }
}
import_ok r0.mcap /odom imp0
import_ok r1.mcap /pose imp1
import_ok r1.db3 /odom imp1db
same_dataset sim/robot_0 imp0
same_dataset sim/robot_1 imp1
same_dataset sim/robot_1 imp1db
"$bin" run sim/robot_0 sim/robot_1 --lidar vlp16 --out run_dir > run_dir.txt
"$bin" run imp0 imp1 --lidar vlp16 --out run_mcap > run_mcap.txt
"$bin" run imp0 imp1db --lidar vlp16 --out run_db3 > run_db3.txt
same_transforms run_dir/transforms.txt run_mcap/transforms.txt
same_transforms run_dir/transforms.txt run_db3/transforms.txt

# --- 3: the real hku2 sequence in halves ------------------------------------------------------------------------
hku2=${shared:+$shared/real/hku2}
if [ -n "$hku2" ] && [ -f "$hku2/poses.txt" ]; then
  write "$hku2:0-133" h0.mcap --compression zstd
  write "$hku2:133-266" h1.mcap --compression lz4 --scan-type livox
  "$bin" import h0.mcap --scan-topic /velodyne_points --pose-topic /odom --out himp0 > himp0.txt
  "$bin" import h1.mcap --scan-topic /livox/lidar --pose-topic /odom --out himp1 > himp1.txt
  grep -q ': 133 scans with poses' himp1.txt || { cat himp1.txt; fail "import h1.mcap: not 133 scans"; }
  "$bin" run "$hku2:0-133" "$hku2:133-266" --lidar avia --out hrun_dir > hrun_dir.txt
  "$bin" run himp0 himp1 --lidar avia --out hrun_mcap > hrun_mcap.txt
  same_transforms hrun_dir/transforms.txt hrun_mcap/transforms.txt
else
  echo "real hku2 part not run: no ${hku2:-../shared/data}/real/hku2 (the generated world's checks ran)"
fi

# --- 4: bad input -----------------------------------------------------------------------------------------------
size=$(stat -c %s r0.mcap)
head -c $((size / 2)) r0.mcap > cut.mcap
expect_error "truncated MCAP" 'cut\.mcap: .*offset [0-9]+' "$bin" import cut.mcap --scan-topic /velodyne_points --pose-topic /odom --out cut
head -c $((size - 3)) r0.mcap > cut_end.mcap
expect_error "MCAP without its last bytes" 'cut_end\.mcap: .*offset [0-9]+' "$bin" import cut_end.mcap
# A corrupt lz4 chunk: 64 bytes in the middle of the first chunk's compressed records overwritten.
cp r0.mcap corrupt.mcap
printf '%064d' 0 | dd of=corrupt.mcap bs=1 seek=6000 conv=notrunc status=none
expect_error "corrupt chunk" 'corrupt\.mcap: chunk at offset [0-9]+ \(lz4\)' "$bin" import corrupt.mcap --scan-topic /velodyne_points --pose-topic /odom --out corrupt
printf 'SQLite format 3\0' > fake.db3
head -c 8192 /dev/zero | tr '\0' 'x' >> fake.db3
expect_error "not a db3" 'fake\.db3: .*sqlite: ' "$bin" import fake.db3
printf 'not a recording\n' > text.db3
expect_error "not a recording" 'text\.db3' "$bin" import text.db3
expect_error "missing topic" 'r1\.db3: no topic /points' "$bin" import r1.db3 --scan-topic /points --pose-topic /odom --out missing
echo "ros2 import: all checks passed"
