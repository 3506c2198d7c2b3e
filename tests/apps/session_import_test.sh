#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# End to end: scan sessions as offline mergers store them (a folder of scans + a pose file), written by PCL's own
# tools (Debian's pcl-tools: pcl_convert_pcd_ascii_binary), converted by `commerge import DIR --poses FILE --out OUT`
# and merged by `commerge run`. Checks:
#   1. a generated two-robot world: robot 0 as NNNNNN.pcd in DATA binary_compressed with a TUM pose file and KITTI
#      ground truth, robot 1 as scan_N.pcd (N unpadded: numeric order, not name order) in DATA binary with a CSV pose
#      file and a roll/pitch/yaw CSV ground truth; the imports hold the same scans (bit for bit: x y z intensity),
#      poses, times and ground truth (within 1e-9) as the directories they were made from, and `commerge run` on them
#      gives the same transforms (within 1e-6);
#   2. when ../shared/data is present, the real hku2 sequence in halves: binary_compressed PCD + TUM, and KITTI .bin +
#      KITTI poses; the same transforms as `commerge run` on the original halves;
#   3. bad input is a clear error: scans of two kinds, counts that differ, a corrupt compressed scan, a bad pose line,
#      a non-empty --out without --force.
# Usage: session_import_test.sh COMMERGE WORK [SHARED_DATA_DIR]
set -euo pipefail
bin=$1
work=$2
shared=${3:-}
. "$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)/import_checks.sh"

# Debian's pcl-tools is installed by toolchains/install-deps.sh; without it this test fails, it does not skip.
command -v pcl_convert_pcd_ascii_binary >/dev/null || fail "no pcl_convert_pcd_ascii_binary (apt-get install pcl-tools)"

rm -rf "$work"
mkdir -p "$work"
cd "$work"

# KITTI .bin scans of DIR (velodyne/*.bin, scans FIRST..END-1) as ascii PCD files OUT/<name pattern % k>: float32 values
# printed with 9 significant digits, which read back as the same float.
bins_to_ascii_pcd() {  # DIR FIRST END OUT PATTERN
  "$py" - "$@" <<'EOF'
import os, struct, sys
src, first, end, out, pattern = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4], sys.argv[5]
files = sorted(f for f in os.listdir(os.path.join(src, 'velodyne')) if f.endswith('.bin'))[first:end]
os.makedirs(out, exist_ok=True)
for k, name in enumerate(files):
    data = open(os.path.join(src, 'velodyne', name), 'rb').read()
    n = len(data) // 16
    values = struct.unpack('<%df' % (4 * n), data)
    rows = ['%.9g %.9g %.9g %.9g' % values[4 * i:4 * i + 4] for i in range(n)]
    header = ('# .PCD v0.7\nVERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n'
              'WIDTH %d\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA ascii\n' % (n, n))
    with open(os.path.join(out, pattern % k), 'w') as f:
        f.write(header + ''.join(r + '\n' for r in rows))
EOF
}

# Every ascii PCD of DIR rewritten by PCL in MODE (1 binary, 2 binary_compressed), in place.
pcl_convert_all() {  # DIR MODE
  local f
  for f in "$1"/*.pcd; do
    pcl_convert_pcd_ascii_binary "$f" "$f.tmp" "$2" > pcl.log 2>&1 || { cat pcl.log; fail "pcl_convert_pcd_ascii_binary $f"; }
    mv "$f.tmp" "$f"
  done
  local kind=binary
  [ "$2" = 2 ] && kind=binary_compressed
  grep -aq "^DATA $kind\$" "$f" || fail "$f: PCL did not write DATA $kind"
}

# Pose files from DIR/poses.txt (KITTI-12; scans FIRST..END-1) and DIR/times.txt: tum | csv (t,x,y,z,q + an ignored
# column) | rpy (whitespace CSV with roll pitch yaw) | kitti.
poses_to() {  # FORMAT DIR FIRST END OUT [POSES_FILE]
  "$py" - "$@" <<'EOF'
import math, os, sys
fmt, src, first, end, out = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
name = sys.argv[6] if len(sys.argv) > 6 else 'poses.txt'
poses = [[float(x) for x in l.split()] for l in open(os.path.join(src, name)) if l.strip()][first:end]
times = [float(l) for l in open(os.path.join(src, 'times.txt')) if l.strip()][first:end]
def quat(p):  # row-major 3x4 -> (qx, qy, qz, qw), Shepperd's method
    r = [[p[0], p[1], p[2]], [p[4], p[5], p[6]], [p[8], p[9], p[10]]]
    tr = r[0][0] + r[1][1] + r[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return ((r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, 0.25 * s)
    i = max(range(3), key=lambda k: r[k][k])
    j, k = (i + 1) % 3, (i + 2) % 3
    s = math.sqrt(1.0 + r[i][i] - r[j][j] - r[k][k]) * 2
    q = [0.0] * 3
    q[i] = 0.25 * s
    q[j] = (r[j][i] + r[i][j]) / s
    q[k] = (r[k][i] + r[i][k]) / s
    return (q[0], q[1], q[2], (r[k][j] - r[j][k]) / s)
with open(out, 'w') as f:
    if fmt == 'tum':
        f.write('# timestamp tx ty tz qx qy qz qw\n')
    elif fmt == 'csv':
        f.write('index,timestamp,x,y,z,qx,qy,qz,qw\n')
    elif fmt == 'rpy':
        f.write('time x y z roll pitch yaw\n')
    for k, (p, t) in enumerate(zip(poses, times)):
        x, y, z = p[3], p[7], p[11]
        if fmt == 'tum':
            f.write(' '.join(repr(v) for v in (t, x, y, z) + quat(p)) + '\n')
        elif fmt == 'csv':
            f.write(','.join([str(k)] + [repr(v) for v in (t, x, y, z) + quat(p)]) + '\n')
        elif fmt == 'rpy':
            roll, pitch, yaw = math.atan2(p[9], p[10]), math.asin(max(-1.0, min(1.0, -p[8]))), math.atan2(p[4], p[0])
            f.write(' '.join(repr(v) for v in (t, x, y, z, roll, pitch, yaw)) + '\n')
        else:
            f.write(' '.join(repr(v) for v in p) + '\n')
EOF
}

# Numbers of two text files agree within TOL (same line count, same count per line).
same_numbers() {  # A B TOL [FIRST END] (lines FIRST..END-1 of A)
  "$py" - "$@" <<'EOF' || fail "$2 differs from $1 by more than $3"
import sys
a, b = ([[float(x) for x in l.split()] for l in open(p) if l.strip()] for p in sys.argv[1:3])
if len(sys.argv) > 5:
    a = a[int(sys.argv[4]):int(sys.argv[5])]
assert len(a) == len(b), (len(a), len(b))
worst = max(abs(x - y) for la, lb in zip(a, b) for x, y in zip(la, lb))
assert all(len(la) == len(lb) for la, lb in zip(a, b))
print('%s: agrees within %.1e' % (sys.argv[2], worst))
assert worst <= float(sys.argv[3])
EOF
}

# Scans FIRST..END-1 of A/velodyne and all of B/velodyne are the same files, byte for byte.
same_scans() {  # A B [FIRST END]
  "$py" - "$@" <<'EOF' || fail "$2/velodyne differs from $1/velodyne"
import os, sys
a, b = sys.argv[1], sys.argv[2]
fa = sorted(f for f in os.listdir(os.path.join(a, 'velodyne')) if f.endswith('.bin'))
if len(sys.argv) > 3:
    fa = fa[int(sys.argv[3]):int(sys.argv[4])]
fb = sorted(os.listdir(os.path.join(b, 'velodyne')))
assert len(fa) == len(fb), (len(fa), len(fb))
for x, y in zip(fa, fb):
    da = open(os.path.join(a, 'velodyne', x), 'rb').read()
    db = open(os.path.join(b, 'velodyne', y), 'rb').read()
    assert da == db, (x, y, len(da), len(db))
print('%s: %d scans, the same bytes' % (b, len(fb)))
EOF
}


# --- 1: a generated two-robot world ---------------------------------------------------------------------------
"$bin" sim --world urban --robots 2 --overlap complete --keyframes 80 --azimuth-steps 360 --direction same \
  --wobble-deg 0 --out sim >/dev/null
bins_to_ascii_pcd sim/robot_0 0 80 s0 '%06d.pcd'
bins_to_ascii_pcd sim/robot_1 0 80 s1 'scan_%d.pcd'
pcl_convert_all s0 2
pcl_convert_all s1 1
poses_to tum sim/robot_0 0 80 s0/poses_tum.txt
poses_to csv sim/robot_1 0 80 poses1.csv
poses_to rpy sim/robot_1 0 80 gt1.csv poses_gt.txt
printf 'calibration notes\n' > s1/notes.txt

"$bin" import s0 --poses s0/poses_tum.txt --gt sim/robot_0/poses_gt.txt --out imp0 > imp0.txt
grep -q '^s0 -> imp0: 80 scans (.pcd, ordered by the number in the file name)' imp0.txt || { cat imp0.txt; fail "import s0"; }
grep -q 'poses: s0/poses_tum.txt (TUM, 80 poses)' imp0.txt || { cat imp0.txt; fail "import s0: poses"; }
grep -q 'skipped, not .pcd scans: 1 (poses_tum.txt)' imp0.txt || { cat imp0.txt; fail "import s0: skipped"; }
"$bin" import s1 --poses poses1.csv --gt gt1.csv --out imp1 > imp1.txt
grep -q '^s1 -> imp1: 80 scans (.pcd, ordered by the number in the file name)' imp1.txt || { cat imp1.txt; fail "import s1"; }
grep -q 'poses: poses1.csv (CSV, 80 poses)' imp1.txt || { cat imp1.txt; fail "import s1: poses"; }
grep -q 'non-finite points dropped: 0 in 0 files' imp1.txt || { cat imp1.txt; fail "import s1: drops"; }
for r in 0 1; do
  same_scans sim/robot_$r imp$r
  same_numbers sim/robot_$r/poses.txt imp$r/poses.txt 1e-9
  same_numbers sim/robot_$r/times.txt imp$r/times.txt 0
  same_numbers sim/robot_$r/poses_gt.txt imp$r/poses_gt.txt 1e-9
done
"$bin" run sim/robot_0 sim/robot_1 --lidar vlp16 --out run_dir > run_dir.txt
"$bin" run imp0 imp1 --lidar vlp16 --out run_imp > run_imp.txt
same_transforms run_dir/transforms.txt run_imp/transforms.txt

# --- 2: the real hku2 sequence in halves ------------------------------------------------------------------------
hku2=${shared:+$shared/real/hku2}
if [ -n "$hku2" ] && [ -f "$hku2/poses.txt" ]; then
  bins_to_ascii_pcd "$hku2" 0 133 h0 '%06d.pcd'
  pcl_convert_all h0 2
  poses_to tum "$hku2" 0 133 h0_poses.txt
  mkdir -p h1
  "$py" - "$hku2" <<'EOF'
import os, shutil, sys
files = sorted(f for f in os.listdir(os.path.join(sys.argv[1], 'velodyne')) if f.endswith('.bin'))[133:266]
for f in files:
    shutil.copy(os.path.join(sys.argv[1], 'velodyne', f), os.path.join('h1', f))
EOF
  poses_to kitti "$hku2" 133 266 h1_poses.txt
  "$bin" import h0 --poses h0_poses.txt --out himp0 > himp0.txt
  "$bin" import h1 --poses h1_poses.txt --out himp1 > himp1.txt
  grep -q 'poses: h1_poses.txt (KITTI 3x4, 133 poses, no times)' himp1.txt || { cat himp1.txt; fail "import h1"; }
  same_scans "$hku2" himp0 0 133
  same_scans "$hku2" himp1 133 266
  # hku2's rotations are printed with 6 digits (orthonormal to ~1e-6): commerge writes the nearest rotation (KITTI)
  # or the rotation of the normalised quaternion (TUM), which agree with the file to what its digits hold.
  same_numbers "$hku2/poses.txt" himp0/poses.txt 1e-5 0 133
  same_numbers "$hku2/poses.txt" himp1/poses.txt 1e-5 133 266
  same_numbers "$hku2/times.txt" himp0/times.txt 0 0 133
  "$bin" run "$hku2:0-133" "$hku2:133-266" --lidar avia --out hrun_dir > hrun_dir.txt
  "$bin" run himp0 himp1 --lidar avia --out hrun_imp > hrun_imp.txt
  same_transforms hrun_dir/transforms.txt hrun_imp/transforms.txt
else
  echo "real hku2 part not run: no ${hku2:-../shared/data}/real/hku2 (the generated world's checks ran)"
fi

# --- 3: bad input -----------------------------------------------------------------------------------------------
expect_error "non-empty --out" 'imp0: exists and is not empty \(--force' "$bin" import s0 --poses s0/poses_tum.txt --out imp0
"$bin" import s0 --poses s0/poses_tum.txt --out imp0 --force > /dev/null || fail "--force: a second import into imp0"
[ ! -e imp0/poses_gt.txt ] || fail "--force left the earlier import's poses_gt.txt"
same_scans sim/robot_0 imp0

mkdir -p mixed
cp s0/000000.pcd s0/000001.pcd mixed/
printf 'ply\nformat ascii 1.0\nelement vertex 0\nproperty float x\nproperty float y\nproperty float z\nend_header\n' > mixed/000002.ply
expect_error "two kinds" 'mixed: holds 2 \.pcd and 1 \.ply files' "$bin" import mixed --poses s0/poses_tum.txt --out bad1
head -n 40 s0/poses_tum.txt > short_tum.txt
expect_error "counts differ" 'short_tum\.txt: 39 poses for the 80 \.pcd scans in s0' "$bin" import s0 --poses short_tum.txt --out bad2
sed '5s/.*/1,2,3/' poses1.csv > bad_row.csv
expect_error "bad csv row" 'bad_row\.csv: line 5: expected 9 values, found 3' "$bin" import s1 --poses bad_row.csv --out bad3
mkdir -p cut
cp s0/*.pcd cut/
size=$(stat -c %s cut/000007.pcd)
head -c $((size / 3)) s0/000007.pcd > cut/000007.pcd
expect_error "truncated compressed scan" 'cut/000007\.pcd: truncated: DATA binary_compressed' \
  "$bin" import cut --poses s0/poses_tum.txt --out bad4
echo "session import: all checks passed"
