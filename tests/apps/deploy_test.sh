#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Checks of the systemd units shipped in the bundle (apps/deploy/ -> share/commerge/systemd/). Used by the CTest tests
# "deploy: ..." (tests/apps/bundle_tests.cmake, host build) and runnable by hand:
#
#   tests/apps/deploy_test.sh --tarball build/commerge-0.1.0-x86_64.tar.gz --name commerge-0.1.0-x86_64 \
#       --work /tmp/dt --step check
#
# Steps (each on a fresh unpack of the bundle under --work, which stands for /opt/commerge):
#   verify  `systemd-analyze verify` of copies of the units whose /opt/commerge/ paths point into the unpacked bundle
#           (verify insists that ExecStart's program exists; `--root` would need a whole unit tree with
#           sysinit.target); any message (unknown key, bad value) fails, because verify exits 0 on those.
#   check   for each unit: its ExecStartPre and ExecStart lines, with $VARS from the example environment file, %i = 1,
#           a key from `commerge keygen` for /etc/commerge/team.key and --check added where absent, run through the
#           bundle's launcher must exit 0 ("configuration OK") inside a fake cgroup v2 whose memory.max is the
#           unit's MemoryMax (the start-up budget check must fit it); then a missing key file must exit 2 and a
#           budget over MemoryMax exit 3, the statuses in the unit's RestartPreventExitStatus. Nothing opens the
#           network (--check).
# Prints "CM-SKIP: reason" and exits 0 when it cannot run (no systemd-analyze; a commerge without --check/keygen).
set -euo pipefail

tarball='' name='' work='' step=''
while [[ $# -gt 0 ]]; do
  case $1 in
    --tarball) tarball=$2; shift 2 ;;
    --name) name=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --step) step=$2; shift 2 ;;
    *) echo "deploy_test.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
fail() { echo "FAIL: $*" >&2; exit 1; }
skip() { echo "CM-SKIP: $*"; exit 0; }
[[ -n $tarball && -n $name && -n $work && -n $step ]] ||
  fail "usage: deploy_test.sh --tarball T --name commerge-<version>-<arch> --work DIR --step verify|check"
[[ -f $tarball ]] || fail "$tarball: no such file (the 'bundle: build' test makes it)"

rm -rf "$work"
mkdir -p "$work"
tar -xzf "$tarball" -C "$work"
b=$work/$name
units=$b/share/commerge/systemd
[[ -f $units/commerge-robot@.service && -f $units/commerge-server.service ]] || fail "$units: units missing"

# substitute FILE: the unit with the bundle in place of /opt/commerge/ and the test's state directory.
substitute() { sed -e "s|/opt/commerge/|$b/|g" -e "s|/var/lib/commerge|$work/state|g" -e "s|/etc/commerge/|$work/etc/|g" "$1"; }

step_verify() {
  command -v systemd-analyze >/dev/null || skip "systemd-analyze not installed (Debian: systemd)"
  mkdir -p "$work/units"
  substitute "$units/commerge-server.service" >"$work/units/commerge-server.service"
  substitute "$units/commerge-robot@.service" >"$work/units/commerge-robot@1.service"   # an instance of the template
  local out rc=0
  out=$(systemd-analyze verify "$work/units/commerge-server.service" "$work/units/commerge-robot@1.service" 2>&1) || rc=$?
  [[ $rc == 0 && -z $out ]] || fail "systemd-analyze verify (rc $rc):"$'\n'"$out"
  echo "systemd-analyze $(systemd-analyze --version | head -n1 | cut -d' ' -f2): both units verify without a message"
}

# value KEY FILE: the last KEY=value of a unit or environment file, surrounding double quotes removed.
value() {
  local line v=
  while IFS= read -r line; do
    if [[ $line =~ ^$1=(.*)$ ]]; then
      v=${BASH_REMATCH[1]}
      [[ $v =~ ^\"(.*)\"$ ]] && v=${BASH_REMATCH[1]}
    fi
  done <"$2"
  printf '%s' "$v"
}

# bytes 448M -> 469762048 (systemd's suffixes are powers of 1024).
bytes() {
  local n=${1%[KMGT]} mult=1
  case $1 in
    *K) mult=1024 ;; *M) mult=$((1024 ** 2)) ;; *G) mult=$((1024 ** 3)) ;; *T) mult=$((1024 ** 4)) ;;
  esac
  [[ $n =~ ^[0-9]+$ ]] || fail "MemoryMax=$1: not a plain size"
  echo $((n * mult))
}

# argv_of LINE ENVFILE: the argv systemd builds from an Exec line (prefix chars dropped, %i = 1, $VAR split at
# whitespace, ${VAR} kept as one word) into the array argv. Quotes and other specifiers are not used by our units.
argv_of() {
  local line=$1 envfile=$2 tok val
  line=${line#*=}
  line=${line##[-@:+!]}
  [[ $line != *[\"\']* ]] || fail "unsupported quoting in: $line"
  argv=()
  set -f  # no globbing: URLs hold '?'
  for tok in $line; do
    tok=${tok//%i/1}
    [[ $tok != *%* ]] || fail "unsupported specifier in '$tok'"
    if [[ $tok =~ ^\$([A-Za-z_][A-Za-z0-9_]*)$ ]]; then
      val=$(value "${BASH_REMATCH[1]}" "$envfile")
      [[ -n $val ]] || fail "\$${BASH_REMATCH[1]} is not set in $envfile"
      # shellcheck disable=SC2206  # systemd splits $VAR at whitespace
      argv+=($val)
    elif [[ $tok =~ ^\$\{([A-Za-z_][A-Za-z0-9_]*)\}$ ]]; then
      argv+=("$(value "${BASH_REMATCH[1]}" "$envfile")")
    else
      argv+=("$tok")
    fi
  done
  set +f
}

# fake_cgroup DIR BYTES UNIT: /proc and cgroup v2 trees in which this process's service has memory.max = BYTES.
fake_cgroup() {
  rm -rf "$1"
  mkdir -p "$1/proc/self" "$1/cgroup/system.slice/$3"
  printf 'MemTotal: 8000000 kB\nMemFree: 7000000 kB\nMemAvailable: 7500000 kB\n' >"$1/proc/meminfo"
  echo "0::/system.slice/$3" >"$1/proc/self/cgroup"
  echo "$2" >"$1/cgroup/system.slice/$3/memory.max"
}

step_check() {
  local cm=$b/bin/commerge help
  help=$("$cm" robot --help 2>&1) || fail "$cm robot --help: $help"
  grep -q -- '--check' <<<"$help" || skip "this commerge has no 'robot --check' yet"
  "$cm" keygen --help >/dev/null 2>&1 || skip "this commerge has no 'keygen' yet"
  mkdir -p "$work/etc" "$work/state"
  "$cm" keygen --out "$work/etc/team.key" >/dev/null || fail "commerge keygen --out $work/etc/team.key"

  local unit envfile svc max maxb lines line kind out rc prevent
  for unit in commerge-robot@.service commerge-server.service; do
    substitute "$units/$unit" >"$work/$unit"
    # The first EnvironmentFile= is the required one (robot@%i.env is optional, '-'), filled from its .example.
    envfile=$(grep -m1 '^EnvironmentFile=/' "$units/$unit" | cut -d= -f2)
    [[ -f $units/$(basename "$envfile").example ]] || fail "$unit: no example environment file for $envfile"
    substitute "$units/$(basename "$envfile").example" >"$work/etc/$(basename "$envfile")"
    envfile=$work/etc/$(basename "$envfile")
    max=$(value MemoryMax "$units/$unit")
    [[ -n $max ]] || fail "$unit: no MemoryMax="
    maxb=$(bytes "$max")
    svc=${unit/@/@1}
    fake_cgroup "$work/fake-$svc" "$maxb" "$svc"
    local fake=(--proc-root "$work/fake-$svc/proc" --cgroup-root "$work/fake-$svc/cgroup")
    lines=$(grep -E '^ExecStart(Pre)?=' "$work/$unit")
    grep -q '^ExecStartPre=.* --check' <<<"$lines" || fail "$unit: no ExecStartPre=... --check"
    while IFS= read -r line; do
      kind=${line%%=*}
      argv_of "$line" "$envfile"
      [[ " ${argv[*]} " == *" --check "* ]] || argv+=(--check)
      rc=0
      out=$("${argv[@]}" "${fake[@]}" 2>&1) || rc=$?
      [[ $rc == 0 && $out == *"configuration OK"* ]] ||
        fail "$unit $kind with $(basename "$envfile") under MemoryMax=$max (rc $rc):"$'\n'"  ${argv[*]}"$'\n'"$out"
      echo "$unit $kind: exit 0 under MemoryMax=$max: ${out%%$'\n'*}"
    done <<<"$lines"

    # The statuses the unit does not restart are what configuration errors return.
    prevent=" $(value RestartPreventExitStatus "$units/$unit") "
    [[ $prevent == *" 2 "* && $prevent == *" 3 "* ]] || fail "$unit: RestartPreventExitStatus must list 2 and 3"
    argv_of "$(grep -m1 '^ExecStart=' "$work/$unit")" "$envfile"
    local i nokey=()
    for i in "${argv[@]}"; do
      [[ $i == "$work/etc/team.key" ]] && i=$work/etc/missing.key
      nokey+=("$i")
    done
    rc=0
    out=$("${nokey[@]}" --check "${fake[@]}" 2>&1) || rc=$?
    [[ $rc == 2 ]] || fail "$unit: a missing key file exited $rc, expected 2 (not restarted): $out"
    fake_cgroup "$work/fake-small" $((64 * 1024 * 1024)) "$svc"
    rc=0
    out=$("${argv[@]}" --check --proc-root "$work/fake-small/proc" --cgroup-root "$work/fake-small/cgroup" 2>&1) || rc=$?
    [[ $rc == 3 ]] || fail "$unit: a budget over a 64 MiB cgroup exited $rc, expected 3 (not restarted): $out"
    echo "$unit: missing key file -> exit 2, budget over the cgroup limit -> exit 3 (RestartPreventExitStatus=${prevent# })"
  done
}

case $step in
  verify) step_verify ;;
  check) step_check ;;
  *) fail "--step $step: expected verify or check" ;;
esac
