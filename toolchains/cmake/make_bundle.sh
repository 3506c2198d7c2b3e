#!/usr/bin/env bash
# SPDX-License-Identifier: BSD-3-Clause
# Field bundle of commerge (issue 8; called by the `bundle` target of toolchains/cmake/Bundle.cmake): a relocatable
# tarball with the executable, its whole shared-library closure and the dynamic loader, so that it runs on a board
# whose own glibc is too old (Jetson Nano, JetPack 4.6: glibc 2.27; ours need GLIBC_2.34) and uses nothing from the
# board's /lib. Layout (top directory NAME/):
#   bin/commerge               POSIX sh launcher: exec lib/<loader> --library-path lib libexec/commerge "$@"
#   libexec/commerge           the executable (debug info stripped; interpreter PREFIX/lib/<loader>, RPATH
#                              $ORIGIN/../lib: also runs directly once installed at PREFIX, e.g. /opt/commerge)
#   lib/                       the loader and every library the target's own loader lists (--list)
#   share/commerge/systemd/    the units and environment files of apps/deploy/
#   share/commerge/MANIFEST    version, build, and every bundled file with its source path and Debian package
#   share/doc/commerge/README.md  the operator manual (--doc, apps/README.md); the units' Documentation=
#   share/doc/<package>/       the Debian copyright file of every bundled library's package
#
# The closure is resolved by the target's loader itself (`<emulator> <loader> --library-path PATH --list exe`; for
# aarch64 under qemu-user with the LCM overlay on PATH): any "not found" fails the build.
set -euo pipefail

die() { echo "make_bundle.sh: error: $*" >&2; exit 1; }

exe='' name='' out='' emulator='' libpath='' strip='' patchelf='' prefix=/opt/commerge deploy_dir='' doc='' version='' work=''
while [[ $# -gt 0 ]]; do
  case $1 in
    --exe) exe=$2; shift 2 ;;
    --name) name=$2; shift 2 ;;           # commerge-<version>-<arch>
    --out) out=$2; shift 2 ;;             # the .tar.gz to write
    --emulator) emulator=$2; shift 2 ;;   # '|'-separated command prefix that runs target binaries ('' = native)
    --library-path) libpath=$2; shift 2 ;;  # ':'-separated directories searched before the default ones
    --strip) strip=$2; shift 2 ;;         # the target's strip ('' = keep debug info)
    --patchelf) patchelf=$2; shift 2 ;;   # '' = leave interpreter and RUNPATH as linked
    --prefix) prefix=$2; shift 2 ;;
    --deploy-dir) deploy_dir=$2; shift 2 ;;
    --doc) doc=$2; shift 2 ;;             # operator manual -> share/doc/commerge/README.md
    --version) version=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;           # staging directory (replaced)
    *) die "unknown argument '$1'" ;;
  esac
done
for v in exe name out deploy_dir doc version work; do
  [[ -n ${!v} ]] || die "--${v//_/-} is required"
done
[[ -x $exe ]] || die "$exe: not an executable (build the commerge target first)"
[[ -d $deploy_dir ]] || die "$deploy_dir: no such directory (the systemd units)"
[[ -f $doc ]] || die "$doc: no such file (the operator manual)"

emu=()
if [[ -n $emulator ]]; then
  IFS='|' read -r -a emu <<<"$emulator"
fi

# The loader: the executable's PT_INTERP (/lib/ld-linux-aarch64.so.1, /lib64/ld-linux-x86-64.so.2), which exists on the
# build machine (the host's own, or libc6:arm64 from multiarch).
interp=$(LC_ALL=C readelf -l "$exe" | sed -n 's/.*Requesting program interpreter: \(.*\)]$/\1/p')
[[ -n $interp ]] || die "$exe: no program interpreter (PT_INTERP) found by readelf -l (static or not an ELF executable?)"
[[ -e $interp ]] || die "$exe: its loader $interp does not exist on this machine (aarch64: apt-get install libc6:arm64)"
loader=$(basename "$interp")

list_cmd=("${emu[@]}" "$interp")
[[ -n $libpath ]] && list_cmd+=(--library-path "$libpath")
list_cmd+=(--list "$exe")
listing=$("${list_cmd[@]}" 2>&1) || die "'${list_cmd[*]}' failed:"$'\n'"$listing"
if grep -q 'not found' <<<"$listing"; then
  die "$exe: libraries not found by $loader (library path: ${libpath:-none}):"$'\n'"$(grep 'not found' <<<"$listing")"
fi

rm -rf "$work"
stage=$work/$name
mkdir -p "$stage/bin" "$stage/libexec" "$stage/lib" "$stage/share/commerge/systemd"

manifest=$stage/share/commerge/MANIFEST
{
  echo "commerge $version ($name)"
  echo "built $(date -u +%Y-%m-%dT%H:%M:%SZ) on $(uname -n) from $exe"
  echo "loader: lib/$loader (run by bin/commerge; libexec/commerge also has the interpreter $prefix/lib/$loader)"
  echo
  echo "# bundled file <- source (Debian package and version, where dpkg knows the file)"
} >"$manifest"

pkg_of() {  # Debian package owning a library file, or '-' (e.g. the LCM arm64 overlay extracted with dpkg-deb -x)
  local f p
  command -v dpkg-query >/dev/null || { echo -; return; }
  for f in "$1" "$(readlink -f "$1")" "${1/#\/usr\/lib\//\/lib\/}" "${1/#\/lib\//\/usr\/lib\/}"; do
    p=$(dpkg-query -S "$f" 2>/dev/null | head -n1 | sed 's/: .*//') || true
    if [[ -n $p ]]; then
      echo "$p $(dpkg-query -W -f='${Version}' "$p" 2>/dev/null || true)"
      return
    fi
  done
  echo -
}

# add_copyright PKG SOURCE: the Debian copyright file of a library's package as share/doc/<package>/copyright (the
# licences of what the bundle redistributes: glibc LGPL, GLPK GPL-3, LCM LGPL-2.1, ...). A library dpkg does not know
# (the LCM overlay, extracted with dpkg-deb -x) brings the copyright files of its own tree.
add_copyright() {
  local pkg=${1%% *} doc docs=()
  pkg=${pkg%%:*}
  if [[ $pkg != - ]]; then
    docs=("/usr/share/doc/$pkg/copyright")
  else
    docs=("$(dirname "$2")"/../../share/doc/*/copyright)
  fi
  for doc in "${docs[@]}"; do
    if [[ -f $doc ]]; then
      pkg=$(basename "$(dirname "$doc")")
      install -D -m 0644 "$doc" "$stage/share/doc/$pkg/copyright"
    fi
  done
}

add_lib() {  # add_lib NAME SOURCE: copy SOURCE (dereferenced) as lib/NAME
  local dest=$stage/lib/$1 pkg
  [[ -e $dest ]] && return
  [[ -f $2 ]] || die "$2 (for $1): no such file"
  cp -L "$2" "$dest"
  chmod 0755 "$dest"
  pkg=$(pkg_of "$2")
  printf 'lib/%-28s <- %s (%s)\n' "$1" "$(readlink -f "$2")" "$pkg" >>"$manifest"
  add_copyright "$pkg" "$2"
}

add_lib "$loader" "$interp"
nlibs=0
while IFS= read -r line; do
  # "\tlibfoo.so.1 => /path/libfoo.so.1 (0x...)"; the loader and the vDSO have no "=>" and are skipped here.
  if [[ $line =~ ^[[:space:]]*([^[:space:]]+)[[:space:]]+=\>[[:space:]]+(/[^[:space:]]+)[[:space:]]+\( ]]; then
    add_lib "${BASH_REMATCH[1]}" "${BASH_REMATCH[2]}"
    nlibs=$((nlibs + 1))
  fi
done <<<"$listing"
[[ $nlibs -gt 0 ]] || die "no library in the --list output of $loader (unexpected format?):"$'\n'"$listing"

cp "$exe" "$stage/libexec/commerge"
chmod 0755 "$stage/libexec/commerge"
if [[ -n $strip ]]; then
  "$strip" --strip-debug "$stage/libexec/commerge" || die "$strip --strip-debug failed"
fi
if [[ -n $patchelf ]]; then
  # Interpreter and RPATH for a direct start at PREFIX. DT_RPATH, not RUNPATH: it is searched before LD_LIBRARY_PATH
  # (a board's LD_LIBRARY_PATH must not pull in its older libraries) and applies to the libraries' dependencies too.
  # $ORIGIN first (the launcher's loader derives it from the path it is given, so a bundle unpacked elsewhere uses its
  # own lib/); PREFIX/lib second: for the executable started directly, glibc derives $ORIGIN from /proc/self/exe,
  # which a chroot without /proc lacks (it then skips that entry).
  "$patchelf" --set-interpreter "$prefix/lib/$loader" --force-rpath --set-rpath "\$ORIGIN/../lib:$prefix/lib" \
    "$stage/libexec/commerge" || die "$patchelf failed on libexec/commerge"
fi
printf 'libexec/commerge <- %s\n' "$(readlink -f "$exe")" >>"$manifest"

sed "s|@LOADER@|$loader|g; s|@VERSION@|$version|g" >"$stage/bin/commerge" <<'LAUNCHER'
#!/bin/sh
# SPDX-License-Identifier: BSD-3-Clause
# commerge @VERSION@ launcher: runs ../libexec/commerge through the bundled glibc loader with the bundled libraries
# only (../lib), so nothing from the board's /lib is used (JetPack 4.6 has glibc 2.27; commerge needs 2.34).
# Relocatable: works from any directory and through symlinks (e.g. /usr/local/bin/commerge).
# Test hook: COMMERGE_EMULATOR is put in front of the loader, word-split (e.g. "qemu-aarch64-static -cpu cortex-a57"
# runs the aarch64 bundle on an x86-64 machine without binfmt_misc). Leave it unset on the board.
self=$0
while [ -L "$self" ]; do
  link=$(readlink "$self") || break
  case $link in
    /*) self=$link ;;
    *) self=$(dirname "$self")/$link ;;
  esac
done
root=$(cd "$(dirname "$self")/.." && pwd -P) || exit 127
# Host libraries must not be preloaded into a process with another glibc.
unset LD_PRELOAD
# shellcheck disable=SC2086  # COMMERGE_EMULATOR is a command with arguments
exec ${COMMERGE_EMULATOR:-} "$root/lib/@LOADER@" --library-path "$root/lib" --argv0 "$0" "$root/libexec/commerge" "$@"
LAUNCHER
chmod 0755 "$stage/bin/commerge"

shopt -s nullglob
units=("$deploy_dir"/*)
[[ ${#units[@]} -gt 0 ]] || die "$deploy_dir: empty (expected the systemd units)"
for f in "${units[@]}"; do
  [[ -f $f ]] && install -m 0644 "$f" "$stage/share/commerge/systemd/"
done
install -D -m 0644 "$doc" "$stage/share/doc/commerge/README.md"
printf 'share/doc/commerge/README.md <- %s\n' "$(readlink -f "$doc")" >>"$manifest"

mkdir -p "$(dirname "$out")"
tmp=$out.tmp
tar --sort=name --owner=0 --group=0 --numeric-owner --mtime="@${SOURCE_DATE_EPOCH:-$(date +%s)}" \
  -C "$work" -cf - "$name" | gzip -n -9 >"$tmp"
mv -f "$tmp" "$out"
echo "make_bundle.sh: wrote $out ($(du -k "$out" | cut -f1) KiB): libexec/commerge, $loader and $nlibs libraries"
