#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Proof that the field bundle (toolchains/cmake/Bundle.cmake, `cmake --build <dir> --target bundle`) depends on
# nothing from the machine it runs on. Used by the CTest tests "bundle: ..." (tests/apps/bundle_tests.cmake) and
# runnable by hand:
#
#   tests/apps/bundle_test.sh --tarball build/commerge-0.1.0-aarch64.tar.gz --arch aarch64 --version 0.1.0 \
#       --work /tmp/bt --step empty-root --emulator /usr/bin/qemu-aarch64-static
#
# Steps (each unpacks the tarball afresh under --work):
#   layout      the tree: launcher, executable, loader, libraries, units, manual, MANIFEST, licences; every DT_NEEDED
#               of the executable and of every bundled library is in lib/; the executable's interpreter and RPATH
#               point into the bundle
#   empty-root  ROOT holds only the unpacked bundle (+ the static emulator for aarch64, + the outputs): under
#               `chroot ROOT` (as root; else `unshare -r chroot`) the bundle's loader runs `commerge --version`, the
#               executable starts directly as /opt/commerge/libexec/commerge (symlink /opt/commerge -> the bundle),
#               `commerge sim` writes a small two-robot dataset and `commerge run` merges it (exit 0, transforms.txt
#               with robot 1 connected). No /proc is mounted: the budget check must warn, not fail. Negative
#               control: with one library removed from lib/, the same start must fail (nothing leaks from the host).
#   launcher    bin/commerge on this machine (it needs /bin/sh, absent from the empty root): from another directory,
#               through a chain of symlinks, with a space in the unpack path; exit codes pass through; --argv0.
#               aarch64: COMMERGE_EMULATOR (the launcher's test hook) runs it under qemu-user.
# Prints "CM-SKIP: reason" and exits 0 when it cannot run (no chroot permission, no emulator).
set -euo pipefail

tarball='' arch='' version='' work='' step='' emulator=''
while [[ $# -gt 0 ]]; do
  case $1 in
    --tarball) tarball=$2; shift 2 ;;
    --arch) arch=$2; shift 2 ;;           # aarch64 | x86_64
    --version) version=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --step) step=$2; shift 2 ;;
    --emulator) emulator=$2; shift 2 ;;   # aarch64: a STATIC qemu-aarch64 (it runs inside the empty root)
    *) echo "bundle_test.sh: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
fail() { echo "FAIL: $*" >&2; exit 1; }
skip() { echo "CM-SKIP: $*"; exit 0; }
[[ -n $tarball && -n $arch && -n $version && -n $work && -n $step ]] ||
  fail "usage: bundle_test.sh --tarball T --arch aarch64|x86_64 --version V --work DIR --step layout|empty-root|launcher"
[[ -f $tarball ]] || fail "$tarball: no such file (the 'bundle: build' test makes it)"

name=commerge-$version-$arch
case $arch in
  aarch64) loader=ld-linux-aarch64.so.1 ;;
  x86_64) loader=ld-linux-x86-64.so.2 ;;
  *) fail "--arch $arch: expected aarch64 or x86_64" ;;
esac
cpu=()
if [[ $arch == aarch64 ]]; then
  [[ -n $emulator && -x $emulator ]] || skip "no static qemu-aarch64 (--emulator '$emulator'; Debian: qemu-user-static)"
  cpu=(-cpu cortex-a57)  # the Jetson Nano's cores: traps instructions the board does not have
fi

# unpack DIR: a fresh DIR holding only the unpacked bundle; sets b (the bundle directory).
unpack() {
  rm -rf "$1"
  mkdir -p "$1"
  tar -xzf "$tarball" -C "$1"
  b=$1/$name
  [[ -d $b ]] || fail "$tarball: no top directory $name/"
}

now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$(now)" 'BEGIN { printf "%.1f s", b - a }'; }

step_layout() {
  unpack "$work/layout"
  local f
  for f in bin/commerge libexec/commerge "lib/$loader" lib/libc.so.6 lib/libm.so.6 lib/libstdc++.so.6 lib/libgcc_s.so.1 \
           lib/liblcm.so.1 lib/libglib-2.0.so.0 lib/libglpk.so.40 lib/libmimalloc.so.2 share/commerge/MANIFEST \
           share/doc/libc6/copyright share/doc/liblcm1/copyright share/doc/libglpk40/copyright \
           share/doc/commerge/README.md; do
    [[ -f $b/$f ]] || fail "$name/$f missing from the bundle"
  done
  [[ -x $b/bin/commerge && -x $b/libexec/commerge && -x $b/lib/$loader ]] || fail "bin/, libexec/ or the loader not executable"
  head -n1 "$b/bin/commerge" | grep -qx '#!/bin/sh' || fail "bin/commerge is not a /bin/sh launcher"
  ls "$b"/share/commerge/systemd/commerge-robot@.service "$b"/share/commerge/systemd/commerge-server.service \
     "$b"/share/commerge/systemd/robot.env.example "$b"/share/commerge/systemd/server.env.example >/dev/null ||
    fail "units or environment files missing from share/commerge/systemd/"
  # Every DT_NEEDED of the executable and of every library must be bundled (the closure is complete).
  local needed missing=0 n=0
  for f in "$b/libexec/commerge" "$b"/lib/*.so*; do
    while read -r needed; do
      n=$((n + 1))
      if [[ ! -f $b/lib/$needed ]]; then
        echo "  ${f#"$b"/} needs $needed: not in lib/" >&2
        missing=1
      fi
    done < <(LC_ALL=C readelf -d "$f" | sed -n 's/.*(NEEDED).*\[\(.*\)\]$/\1/p')
  done
  [[ $missing == 0 ]] || fail "incomplete library closure (above)"
  local nlibs
  nlibs=$(find "$b/lib" -type f | wc -l)
  grep -c '^lib/' "$b/share/commerge/MANIFEST" | grep -qx "$nlibs" || fail "MANIFEST does not list the $nlibs files of lib/"
  # Direct start at /opt/commerge: interpreter and RPATH into the bundle, no build-tree path left.
  LC_ALL=C readelf -l "$b/libexec/commerge" | grep -q "interpreter: /opt/commerge/lib/$loader]" ||
    fail "libexec/commerge: interpreter is not /opt/commerge/lib/$loader"
  local dyn
  dyn=$(LC_ALL=C readelf -d "$b/libexec/commerge" | grep -E '\((RPATH|RUNPATH)\)' || true)
  # shellcheck disable=SC2016  # a literal $ORIGIN
  [[ $dyn == *'(RPATH)'*'[$ORIGIN/../lib:/opt/commerge/lib]'* && $(wc -l <<<"$dyn") == 1 ]] ||
    fail "libexec/commerge: expected only RPATH \$ORIGIN/../lib:/opt/commerge/lib, got: $dyn"
  echo "layout OK: $nlibs files in lib/ ($(ls "$b/lib" | tr '\n' ' ')), $n DT_NEEDED entries all bundled;" \
       "tarball $(du -k "$tarball" | cut -f1) KiB"
}

# in_root CMD...: run CMD inside the empty root (chroot as root, else in a user namespace).
chroot_cmd=()
pick_chroot() {
  local probe=("/$name/lib/$loader" --version)
  [[ $arch == aarch64 ]] && probe=("/$(basename "$emulator")" -version)
  local err
  if err=$(chroot "$root" "${probe[@]}" 2>&1 >/dev/null); then
    chroot_cmd=(chroot "$root")
  elif [[ $err == *chroot:* ]] && command -v unshare >/dev/null &&
       err=$(unshare -r chroot "$root" "${probe[@]}" 2>&1 >/dev/null); then
    chroot_cmd=(unshare -r chroot "$root")
  elif [[ $err == *chroot:* || $err == *unshare:* ]]; then
    skip "cannot chroot into $root (not root, and no unprivileged user namespace): $err"
  else
    fail "the probe '${probe[*]}' does not start inside the empty root: $err"
  fi
}
in_root() { "${chroot_cmd[@]}" "${emu_in_root[@]}" "$@"; }

step_empty_root() {
  root=$work/empty-root
  unpack "$root"
  emu_in_root=()
  if [[ $arch == aarch64 ]]; then
    cp "$emulator" "$root/"
    emu_in_root=("/$(basename "$emulator")" "${cpu[@]}")
  fi
  mkdir "$root/opt"
  ln -s "../$name" "$root/opt/commerge"   # the install of apps/README.md: /opt/commerge -> commerge-<version>-<arch>
  pick_chroot
  echo "empty root $root holds: $(ls -A "$root" | tr '\n' ' ')(entered with ${chroot_cmd[*]})"

  # Exactly what bin/commerge does (there is no /bin/sh in the empty root to run it).
  local cm=("/$name/lib/$loader" --library-path "/$name/lib" --argv0 commerge "/$name/libexec/commerge")
  local t out
  t=$(now)
  out=$(in_root "${cm[@]}" --version 2>&1) || fail "commerge --version in the empty root: $out"
  [[ $out == "commerge $version" ]] || fail "commerge --version printed '$out', expected 'commerge $version'"
  echo "--version through the bundled loader: '$out' ($(elapsed "$t"))"
  out=$(in_root /opt/commerge/libexec/commerge --version 2>&1) || fail "direct start /opt/commerge/libexec/commerge: $out"
  [[ $out == "commerge $version" ]] || fail "direct start printed '$out'"
  echo "--version as /opt/commerge/libexec/commerge (interpreter /opt/commerge/lib/$loader, RPATH /opt/commerge/lib): OK"

  # A small two-robot world that merges (about 0.5 s natively, 15 s under qemu).
  t=$(now)
  out=$(in_root "${cm[@]}" sim --world urban --robots 2 --overlap complete --keyframes 100 --lidar vlp16 \
          --azimuth-steps 600 --direction same --wobble-deg 0 --seed 11 --force --out /data 2>&1) ||
    fail "commerge sim in the empty root:"$'\n'"$out"
  [[ -f $root/data/robot_1/velodyne/000099.bin ]] || fail "commerge sim wrote no robot_1/velodyne/000099.bin:"$'\n'"$out"
  echo "commerge sim: 2 robots x 100 scans ($(elapsed "$t"))"
  t=$(now)
  local rc=0
  out=$(in_root "${cm[@]}" run /data/robot_0 /data/robot_1 --lidar vlp-16 --keyframe-spacing-m 0.9 --modes A+B+C \
          --tau-area 1000 --board jetson-nano --scan-store-mb 16 --max-keyframes 300 --no-report --no-progress \
          --out /out 2>&1) || rc=$?
  [[ $rc == 0 ]] || fail "commerge run in the empty root exited $rc:"$'\n'"$out"
  grep -q '^robot 1 merged ' "$root/out/transforms.txt" ||
    fail "/out/transforms.txt does not connect robot 1:"$'\n'"$(cat "$root/out/transforms.txt")"
  [[ -s $root/out/merged_map.pcd ]] || fail "commerge run wrote no merged_map.pcd"
  echo "commerge run: $(grep -m1 -o 'robot 1: T_world_map.*' <<<"$out") ($(elapsed "$t"))"
  # No /proc: the budget check falls back to the board profile and says so; peak RSS is n/a. Nothing crashes.
  grep -q 'warning: no MemAvailable in /proc/meminfo (is /proc mounted?)' <<<"$out" ||
    fail "no warning about the missing /proc/meminfo in:"$'\n'"$(head -n3 <<<"$out")"
  echo "without /proc: $(grep -m1 -o 'memory budget of run fits.*' <<<"$out")"

  # Negative control: the empty root really is empty. Without one bundled library the start must fail.
  local victim=libglpk.so.40
  mv "$root/$name/lib/$victim" "$root/$victim.away"
  rc=0
  out=$(in_root "${cm[@]}" --version 2>&1) || rc=$?
  mv "$root/$victim.away" "$root/$name/lib/$victim"
  [[ $rc != 0 && $out == *"$victim"* ]] ||
    fail "with lib/$victim removed, commerge still started (rc $rc): a library comes from outside the bundle: $out"
  echo "negative control: without lib/$victim the start fails (rc $rc): $out"
}

step_launcher() {
  unpack "$work/launcher root"   # a space in the path
  local launch=$b/bin/commerge
  if [[ $arch == aarch64 ]]; then
    export COMMERGE_EMULATOR="$emulator ${cpu[*]}"
  fi
  mkdir -p "$work/links/sub"
  ln -sfn "$launch" "$work/links/commerge"          # absolute symlink
  ln -sfn ../commerge "$work/links/sub/cm"          # relative symlink to a symlink
  local out rc
  for l in "$launch" "$work/links/commerge" "$work/links/sub/cm"; do
    out=$(cd / && "$l" --version 2>&1) || fail "$l --version: $out"
    [[ $out == "commerge $version" ]] || fail "$l --version printed '$out'"
  done
  echo "launcher: --version from /, directly, through an absolute and a relative symlink chain, space in the path: OK"
  rc=0
  out=$("$work/links/sub/cm" fly 2>&1) || rc=$?
  [[ $rc == 2 ]] || fail "launcher: 'commerge fly' exited $rc, expected the usage error 2: $out"
  out=$("$work/links/sub/cm" --help 2>&1) || fail "launcher: --help: $out"
  grep -q "Usage: $work/links/sub/cm " <<<"$out" || fail "launcher: --argv0 not passed (usage line: $(grep -m1 Usage <<<"$out"))"
  # What reaches the loader: a fake emulator (the test hook) prints LD_PRELOAD, then runs the rest. The host's own
  # /bin/sh and tools complain about the bogus preload on stderr (discarded); the bundle's loader must not see it.
  printf '#!/bin/sh\necho "LD_PRELOAD=${LD_PRELOAD-unset}"\nexec "$@"\n' >"$work/show-env"
  chmod +x "$work/show-env"
  out=$(COMMERGE_EMULATOR="$work/show-env ${COMMERGE_EMULATOR:-}" LD_PRELOAD=/nonexistent/libhost-preload.so \
        "$launch" --version 2>/dev/null) || fail "launcher with LD_PRELOAD: $out"
  [[ $out == "LD_PRELOAD=unset"$'\n'"commerge $version" ]] || fail "launcher: a host LD_PRELOAD reached the bundle's loader: $out"
  echo "launcher: exit status passed through (2), argv[0] is the invoked path, host LD_PRELOAD dropped: OK"
}

mkdir -p "$work"
case $step in
  layout) step_layout ;;
  empty-root) step_empty_root ;;
  launcher) step_launcher ;;
  *) fail "--step $step: expected layout, empty-root or launcher" ;;
esac
