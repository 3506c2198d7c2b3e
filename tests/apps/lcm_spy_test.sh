#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# CTest "lcm-spy: finds every commerge type and decodes every channel" (tests/apps/lcm_spy_tests.cmake), headless.
# Inside a private network namespace (PLATFORM.md 4.1: udpm never reaches a real interface) it starts Xvfb, lcm-spy
# through our launcher (commerge-spy), and LcmSpyCheck.java (a second lcm.spy.Spy on the same class path that
# prints Spy's own type database and channel table), then publishes every commerge message with cm_lcm_sampler.
# It fails unless
#   (a) lcm-spy's type discovery found the class of every struct in lcmtypes/*.lcm (globbed: a new .lcm file is
#       required automatically) and no stale one; the launcher's Spy reports the same type count ("Found N LCM
#       types"); every channel the sampler published was matched by Spy to the class of its type, with the
#       fingerprint of the project's C++ encoder, and every message was decoded (0 undecodable);
#   (b) the launcher's lcm-spy ran under Xvfb and is still up after the traffic, without a Java exception.
# Prints "CM-SKIP:" (CTest: skipped) only when Xvfb, java or javac is absent. Whole run bounded to 60 s.
#
# Usage: lcm_spy_test.sh --launcher <commerge-spy> --sampler <cm_lcm_sampler> --lcmtypes <dir>
#                        --checker <LcmSpyCheck.java> --work <dir> [--count N]
set -euo pipefail

prog=lcm_spy_test
launcher="" sampler="" lcmtypes="" checker="" work="" count=5
args=("$@")
while [ $# -gt 0 ]; do
  case "$1" in
    --launcher) launcher=$2; shift 2 ;;
    --sampler) sampler=$2; shift 2 ;;
    --lcmtypes) lcmtypes=$2; shift 2 ;;
    --checker) checker=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --count) count=$2; shift 2 ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "$prog: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
for v in launcher sampler lcmtypes checker work; do
  [ -n "${!v}" ] || { echo "$prog: --$v is required (see --help)" >&2; exit 2; }
done
total_timeout_s=60

# ---- outside the namespace: prerequisites, then run this script again inside one ----
if [ "${CM_LCM_SPY_TEST_INNER:-}" != 1 ]; then
  if ! command -v Xvfb >/dev/null; then
    echo "CM-SKIP: Xvfb is not installed (apt-get install xvfb): lcm-spy cannot run headless"
    exit 0
  fi
  for tool in java javac; do
    if ! { [ -n "${JAVA_HOME:-}" ] && [ -x "$JAVA_HOME/bin/$tool" ]; } && ! command -v "$tool" >/dev/null; then
      echo "CM-SKIP: $tool is not installed (apt-get install default-jdk-headless)"
      exit 0
    fi
  done
  for tool in unshare ip timeout; do
    command -v "$tool" >/dev/null || { echo "$prog: FAIL: $tool not found (apt-get install iproute2 util-linux coreutils)" >&2; exit 1; }
  done
  for f in "$launcher" "$sampler" "$checker"; do
    [ -f "$f" ] || { echo "$prog: FAIL: $f does not exist (build the targets cm_lcmtypes_java and cm_lcm_sampler)" >&2; exit 1; }
  done
  exec timeout --kill-after=5 "$total_timeout_s" unshare -n env CM_LCM_SPY_TEST_INNER=1 bash "$0" "${args[@]}"
fi

# ---- inside the private network namespace ----
started=$(date +%s%N)
elapsed() { awk -v ns="$(( $(date +%s%N) - started ))" 'BEGIN { printf "%.1f", ns / 1e9 }'; }

java_bin() {
  if [ -n "${JAVA_HOME:-}" ] && [ -x "$JAVA_HOME/bin/$1" ]; then echo "$JAVA_HOME/bin/$1"; else command -v "$1"; fi
}

pids=()
cleanup() {
  local pid alive _
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null || true; done
  for _ in $(seq 30); do
    alive=0
    for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null && alive=1; done
    [ $alive -eq 1 ] || break
    sleep 0.1
  done
  for pid in "${pids[@]}"; do kill -KILL "$pid" 2>/dev/null || true; done
  for pid in "${pids[@]}"; do wait "$pid" 2>/dev/null || true; done
}
dump_logs() {
  local f
  for f in xvfb.log spy.log javac.log check.log check.err sampler.log; do
    if [ -s "$work/$f" ]; then
      echo "---- $work/$f ----"
      tail -n 40 "$work/$f"
    fi
  done
}
trap cleanup EXIT
trap 'echo "$prog: FAIL: timed out after ${total_timeout_s} s"; dump_logs; exit 124' TERM
trap 'exit 130' INT

failures=0
fail() {
  echo "FAIL: $*"
  failures=$((failures + 1))
}
die() {
  echo "FAIL: $*"
  dump_logs
  exit 1
}
# Waits up to $1 s until file $2 has a line matching $3; fails early when process $4 has ended.
wait_for_line() {
  local _
  for _ in $(seq $(($1 * 10))); do
    grep -qE "$3" "$2" 2>/dev/null && return 0
    kill -0 "$4" 2>/dev/null || { grep -qE "$3" "$2" 2>/dev/null && return 0; return 1; }
    sleep 0.1
  done
  return 1
}

ip link set lo up
ip route add 224.0.0.0/4 dev lo
export LCM_DEFAULT_URL="udpm://239.255.76.67:7667?ttl=0"
unset CLASSPATH  # the class path is exactly what commerge-spy builds
rm -rf "$work"
mkdir -p "$work"

# 1. The types lcm-spy must find: every struct of every lcmtypes/*.lcm, as the Java class lcm-gen makes of it
#    (package.struct; lcm-gen's Java default package "lcmtypes" when the file has none).
declare -A expected=()  # class -> .lcm file
shopt -s nullglob
lcm_files=("$lcmtypes"/*.lcm)
shopt -u nullglob
[ ${#lcm_files[@]} -gt 0 ] || die "no .lcm files in $lcmtypes"
for f in "${lcm_files[@]}"; do
  pkg=$(sed -n 's/^[[:space:]]*package[[:space:]]\{1,\}\([A-Za-z0-9_.]\{1,\}\)[[:space:]]*;.*/\1/p' "$f" | head -n 1)
  structs=$(sed -n 's/^[[:space:]]*struct[[:space:]]\{1,\}\([A-Za-z0-9_]\{1,\}\).*/\1/p' "$f")
  [ -n "$structs" ] || die "$f: no struct"
  for s in $structs; do expected["${pkg:-lcmtypes}.$s"]=${f##*/}; done
done
echo "lcmtypes: ${#expected[@]} types in ${#lcm_files[@]} files ($lcmtypes)"

# 2. Xvfb on a free display chosen from our PID (the lock files in /tmp are shared with other namespaces).
display=$((100 + $$ % 400))
xvfb_pid=""
for attempt in 1 2 3 4 5; do
  while [ -e "/tmp/.X$display-lock" ] || [ -e "/tmp/.X11-unix/X$display" ]; do display=$((display + 1)); done
  : >"$work/xvfb.display"
  Xvfb ":$display" -screen 0 1280x800x24 -nolisten tcp -displayfd 3 3>"$work/xvfb.display" >"$work/xvfb.log" 2>&1 &
  xvfb_pid=$!
  pids+=("$xvfb_pid")
  for _ in $(seq 100); do
    [ -s "$work/xvfb.display" ] && break
    kill -0 "$xvfb_pid" 2>/dev/null || break
    sleep 0.1
  done
  [ -s "$work/xvfb.display" ] && break
  echo "Xvfb :$display did not start (attempt $attempt), trying the next display"
  display=$((display + 1))
  xvfb_pid=""
done
[ -n "$xvfb_pid" ] || die "Xvfb did not start"
export DISPLAY=":$display"
echo "Xvfb: display $DISPLAY (pid $xvfb_pid), ready after $(elapsed) s"

# 3. lcm-spy through our launcher, and the checker (a second Spy) on the class path the launcher reports.
"$launcher" >"$work/spy.log" 2>&1 &
spy_pid=$!
pids+=("$spy_pid")
classpath=$("$launcher" --print-classpath) || die "$launcher --print-classpath failed"
echo "class path: $classpath"
mkdir -p "$work/classes"
"$(java_bin javac)" -cp "$classpath" -d "$work/classes" "$checker" >"$work/javac.log" 2>&1 ||
  die "javac $checker failed"
"$(java_bin java)" -Djava.net.preferIPv4Stack=true -Xmx128m -cp "$classpath:$work/classes" \
  LcmSpyCheck "$work/done" 30 >"$work/check.log" 2>"$work/check.err" &
check_pid=$!
pids+=("$check_pid")
wait_for_line 30 "$work/spy.log" '^Found [0-9]+ plugins' "$spy_pid" ||
  die "lcm-spy (commerge-spy, pid $spy_pid) did not come up (no 'Found N plugins' line)"
wait_for_line 30 "$work/check.log" '^READY$' "$check_pid" || die "LcmSpyCheck did not come up"
spy_up=$(elapsed)
echo "lcm-spy: up under Xvfb after $spy_up s: $(grep -E '^Found [0-9]+ LCM types' "$work/spy.log" || echo '(no type count)')"

# 4. Traffic: every commerge message on its channel, $count rounds.
"$sampler" --count "$count" --rate-hz 20 >"$work/sampler.log" 2>&1 || die "cm_lcm_sampler failed"
grep -E '^cm_lcm_sampler: published' "$work/sampler.log" || true
sleep 1.2  # Spy refreshes its table once per second (for the screenshot)
if command -v import >/dev/null; then
  if import -window root "$work/spy.png" 2>/dev/null; then echo "screenshot: $work/spy.png"; fi
fi
touch "$work/done"
wait_for_line 15 "$work/check.log" '^END' "$check_pid" || die "LcmSpyCheck did not report its channel table"

# 5. Checks.
# (a) type discovery: the checker's Spy database against lcmtypes/, and the launcher's Spy count against it.
declare -A discovered=()  # class -> fingerprint
while read -r _ cls fp; do discovered["$cls"]=$fp; done < <(grep -E '^type ' "$work/check.log")
for cls in $(printf '%s\n' "${!expected[@]}" | sort); do
  if [ -n "${discovered[$cls]:-}" ]; then
    echo "ok: lcm-spy discovered $cls (${expected[$cls]}), fingerprint ${discovered[$cls]}"
  else
    fail "lcm-spy did not discover $cls (lcmtypes/${expected[$cls]}): is it missing from $classpath?"
  fi
done
declare -A packages=()
for cls in "${!expected[@]}"; do packages["${cls%.*}"]=1; done
for cls in "${!discovered[@]}"; do
  if [ -n "${packages[${cls%.*}]:-}" ] && [ -z "${expected[$cls]:-}" ]; then
    fail "lcm-spy discovered $cls, which no lcmtypes/*.lcm defines (a stale type jar?)"
  fi
done
spy_count=$(sed -n 's/^Found \([0-9]\{1,\}\) LCM types$/\1/p' "$work/spy.log" | head -n 1)
if [ -z "$spy_count" ]; then
  fail "lcm-spy (commerge-spy) printed no 'Found N LCM types' line"
elif [ "$spy_count" -ne ${#discovered[@]} ] || [ "$spy_count" -lt ${#expected[@]} ]; then
  fail "lcm-spy (commerge-spy) found $spy_count LCM types; expected ${#discovered[@]} (its type database) and at least ${#expected[@]} (lcmtypes/)"
else
  echo "ok: lcm-spy (commerge-spy) found $spy_count LCM types = ${#discovered[@]} in its type database, ${#expected[@]} from lcmtypes/"
fi

# (a) channels: each channel the sampler published, matched to its class and decoded every time.
declare -A sampled=()  # class -> channel
samples=0
while read -r _ channel cls fp bytes; do
  samples=$((samples + 1))
  sampled["$cls"]=$channel
  [ -n "${expected[$cls]:-}" ] || fail "the sampler publishes $cls on $channel, which no lcmtypes/*.lcm defines"
  if [ -n "${discovered[$cls]:-}" ] && [ "${discovered[$cls]}" != "$fp" ]; then
    fail "$cls: the Java class's fingerprint ${discovered[$cls]} differs from the C++ encoder's $fp"
  fi
  row=$(grep -E "^channel $channel " "$work/check.log" || true)
  want="channel $channel $cls $fp received $count undecodable 0 decoded $cls"
  if [ "$row" = "$want" ]; then
    echo "ok: $channel -> $cls ($fp, $bytes B): $count received, $count decoded"
  else
    fail "$channel: expected '$want', lcm-spy has '${row:-nothing}'"
  fi
done < <(grep -E '^sample ' "$work/sampler.log")
[ $samples -gt 0 ] || fail "the sampler printed no 'sample' lines"
while read -r _ channel cls fp _ received _ undecodable _; do
  if [ "$undecodable" != 0 ] || [ "$cls" = "?" ]; then
    fail "lcm-spy could not decode channel $channel (type $cls, fingerprint $fp): $undecodable of $received undecodable"
  fi
done < <(grep -E '^channel ' "$work/check.log")
for cls in $(printf '%s\n' "${!expected[@]}" | sort); do
  [ -n "${sampled[$cls]:-}" ] || fail "cm_lcm_sampler does not publish $cls (lcmtypes/${expected[$cls]}): add a sample, so its decoding is checked"
done

# (b) the launcher's lcm-spy ran under Xvfb, stayed up through the traffic, and threw nothing.
if kill -0 "$spy_pid" 2>/dev/null; then
  echo "ok: lcm-spy (commerge-spy, pid $spy_pid) is still running after the traffic"
else
  fail "lcm-spy (commerge-spy, pid $spy_pid) exited"
fi
for f in spy.log check.err check.log; do
  if grep -nE 'Exception|Error:|^[[:space:]]+at [A-Za-z_$.]+\(' "$work/$f"; then fail "a Java exception in $work/$f"; fi
done

echo "lcm-spy test: ${#expected[@]} types required, ${#discovered[@]} discovered, $samples channels x $count messages, $failures failures, $(elapsed) s"
if [ $failures -gt 0 ]; then
  dump_logs
  exit 1
fi
