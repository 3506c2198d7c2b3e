# SPDX-License-Identifier: BSD-3-Clause
# Checks shared by the import tests (ros_import_test.sh, ros2_import_test.sh, session_import_test.sh); sourced.
# Needs /usr/bin/python3. Every check prints FAIL: ... and exits 1 when it does not hold.
py=/usr/bin/python3
fail() { echo "FAIL: $*" >&2; exit 1; }

# Same scans (x y z of every point, bit for bit; intensity too unless $3 = xyz) and poses (1e-9) in two directories.
same_dataset() {
  local a=$1 b=$2 what=${3:-xyzi}
  local na nb
  na=$(ls "$a/velodyne" | wc -l)
  nb=$(ls "$b/velodyne" | wc -l)
  [ "$na" -eq "$nb" ] || fail "$b: $nb scans, $a has $na"
  for f in "$a"/velodyne/*.bin; do
    local g
    g="$b/velodyne/$(basename "$f")"
    if [ "$what" = xyzi ]; then
      cmp -s "$f" "$g" || fail "$g differs from $f"
    else
      "$py" - "$f" "$g" <<'EOF' || fail "$g: x y z differ from $f"
import struct, sys
a, b = (open(p, 'rb').read() for p in sys.argv[1:3])
assert len(a) == len(b), (len(a), len(b))
for i in range(0, len(a), 16):
    assert a[i:i + 12] == b[i:i + 12], i // 16
EOF
    fi
  done
  "$py" - "$a/poses.txt" "$b/poses.txt" <<'EOF' || fail "$b/poses.txt differs from $a/poses.txt by more than 1e-9"
import sys
a, b = ([[float(x) for x in l.split()] for l in open(p) if l.strip()] for p in sys.argv[1:3])
assert len(a) == len(b), (len(a), len(b))
worst = max(abs(x - y) for la, lb in zip(a, b) for x, y in zip(la, lb))
print('poses agree within %.1e' % worst)
assert worst < 1e-9
EOF
}

# The robots' lines of two transforms.txt agree: the same merged / unmerged, every number within 1e-6.
same_transforms() {
  "$py" - "$1" "$2" <<'EOF' || fail "transforms differ: $1 and $2"
import sys
def robots(p):
    return {l.split()[1]: l.split()[2:] for l in open(p) if l.startswith('robot ')}
a, b = robots(sys.argv[1]), robots(sys.argv[2])
assert a.keys() == b.keys(), (a.keys(), b.keys())
merged = 0
for r in a:
    assert a[r][0] == b[r][0], (r, a[r][0], b[r][0])
    merged += a[r][0] == 'merged'
    worst = max(abs(float(x) - float(y)) for x, y in zip(a[r][1:], b[r][1:]))
    assert worst < 1e-6, (r, worst)
assert merged == len(a), 'not every robot merged: %s' % a
print('%d robots merged, the same transforms' % merged)
EOF
}

# A command fails cleanly (exit 1..127, not a signal) with a message on stderr matching REGEX.
expect_error() {  # NAME REGEX COMMAND...
  local name=$1 regex=$2
  shift 2
  local rc=0
  "$@" > err.out 2> err.txt || rc=$?
  [ "$rc" -ne 0 ] || fail "$name: exit 0"
  [ "$rc" -lt 128 ] || fail "$name: killed by a signal ($rc)"
  grep -Eq -- "$regex" err.txt || { cat err.txt; fail "$name: no message matching '$regex'"; }
}
