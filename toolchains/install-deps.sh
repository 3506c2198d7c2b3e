#!/usr/bin/env bash
# Installs everything commerge needs on Debian 12 (bookworm), idempotently.
#   toolchains/install-deps.sh            host build + tests (x86-64), with clang + libFuzzer (tests/run.sh fuzz),
#                                         nftables + iproute2 (network fault tests), Xvfb + jchart2d (lcm-spy)
#   toolchains/install-deps.sh --cross    also the aarch64 (Jetson Nano) cross toolchain, arm64 libraries,
#                                         qemu-user, and the LCM arm64 overlay in .deps/sysroot-arm64-lcm
#   toolchains/install-deps.sh --tools    also profiling tools (valgrind, heaptrack, hyperfine, ImageMagick)
#   toolchains/install-deps.sh --ros      also Debian's ROS 1 (the optional commerge-ros1-bridge and its test) and the
#                                         official writers of the import tests' fixtures (python3-rosbag, pcl-tools);
#                                         tests/run.sh passes it, the Quickstart's first line does not
# Runs apt-get as root (or through sudo). Safe to run again: installed packages are skipped by apt,
# and the LCM overlay is only extracted when missing.
set -euo pipefail

cross=0
tools=0
ros=0
for arg in "$@"; do
  case "$arg" in
    --cross) cross=1 ;;
    --tools) tools=1 ;;
    --ros) ros=1 ;;
    -h|--help) sed -n '2,12p' "$0"; exit 0 ;;
    *) echo "install-deps.sh: unknown option '$arg' (see --help)" >&2; exit 2 ;;
  esac
done

repo=$(cd "$(dirname "$0")/.." && pwd)
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
apt_install() { $SUDO apt-get install -y --no-install-recommends "$@"; }

# libsodium: the message MACs (platform/lcm/message_auth). patchelf: the field bundle (`--target bundle`).
# systemd: `systemd-analyze verify` of the units in apps/deploy.
# ccache: tests/run.sh compiles through it (cache outside the clone, so a later CI run or build tree reuses it).
# ninja-build: tests/run.sh builds with Ninja (its scheduling keeps both cores busy through the link steps).
# clang (14): the fuzz configuration (CM_FUZZ). libclang-rt-14-dev holds libFuzzer and clang's sanitizer runtimes
# (-fsanitize=fuzzer,address,undefined); clang only reaches it through a Recommends, which apt_install skips.
# liblz4, libbz2, libzstd, libsqlite3: the ROS recordings `commerge import` reads (platform/ros: bag chunks, MCAP
# chunks, rosbag2 .db3).
# python3-rosbag, -roslz4, -sensor-msgs, -nav-msgs, -geometry-msgs: the official ROS 1 bag writer and message
# classes, which write the bag fixtures of the import tests (tests/apps/ros1_bag_fixture.py); tests only.
# libroscpp-dev, libtopic-tools-dev and the message packages: the optional commerge-ros1-bridge (host builds only);
# ros-core (roscore), librosbag-dev (rosbag play), python3-rospy, python3-tf2-msgs: its end-to-end test.
# pcl-tools: PCL's own PCD writer (binary, binary_compressed) for the scan-session import test; tests only.
host_pkgs=(cmake make ninja-build g++ pkg-config ca-certificates ccache
           liblcm-dev liblcm-bin liblcm-java default-jdk-headless
           libeigen3-dev libglpk-dev doctest-dev libmimalloc-dev libnanoflann-dev
           libcli11-dev zlib1g-dev libsodium-dev liblz4-dev libbz2-dev libzstd-dev libsqlite3-dev time
           clang libclang-rt-14-dev
           nftables iproute2 xvfb libjchart2d-java default-jre
           patchelf systemd)
ros_pkgs=(python3-rosbag python3-roslz4 python3-sensor-msgs python3-nav-msgs python3-geometry-msgs
          libroscpp-dev libtopic-tools-dev libsensor-msgs-dev libgeometry-msgs-dev libtf2-msgs-dev
          ros-core librosbag-dev python3-rospy python3-tf2-msgs
          pcl-tools)
if [ $ros -eq 1 ]; then host_pkgs+=("${ros_pkgs[@]}"); fi
missing=()
for p in "${host_pkgs[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done

need_update=1
if [ ${#missing[@]} -gt 0 ] || [ $cross -eq 1 ] || [ $tools -eq 1 ]; then
  $SUDO apt-get update -q
  need_update=0
fi
if [ ${#missing[@]} -gt 0 ]; then apt_install "${missing[@]}"; fi

if [ $tools -eq 1 ]; then
  apt_install valgrind heaptrack hyperfine imagemagick
fi

if [ $cross -eq 1 ]; then
  if ! dpkg --print-foreign-architectures | grep -qx arm64; then
    $SUDO dpkg --add-architecture arm64
    $SUDO apt-get update -q
  fi
  # glpk, mimalloc and glib are Multi-Arch: same; apt may upgrade matching amd64 packages to keep lock-step.
  # qemu-user-static: a static emulator that runs inside a chroot holding nothing but the aarch64 bundle.
  apt_install g++-aarch64-linux-gnu qemu-user qemu-user-static libc6-dev:arm64 \
              libglpk-dev:arm64 libmimalloc-dev:arm64 libglib2.0-0:arm64 zlib1g-dev:arm64 libsodium-dev:arm64 \
              liblz4-dev:arm64 libbz2-dev:arm64 libzstd-dev:arm64 libsqlite3-dev:arm64
  # LCM has no Multi-Arch field: installing liblcm1:arm64 would remove the host LCM (and make lcm-gen an
  # aarch64 binary). Extract the arm64 packages into a private overlay instead (PLATFORM.md 3.2).
  overlay="$repo/.deps/sysroot-arm64-lcm"
  if [ ! -f "$overlay/usr/lib/aarch64-linux-gnu/liblcm.so" ]; then
    debs="$repo/.deps/debs"
    mkdir -p "$debs"
    (cd "$debs" && rm -f liblcm*_arm64.deb && apt-get download liblcm1:arm64 liblcm-dev:arm64)
    rm -rf "$overlay.tmp"
    for d in "$debs"/liblcm1_*_arm64.deb "$debs"/liblcm-dev_*_arm64.deb; do dpkg-deb -x "$d" "$overlay.tmp"; done
    rm -rf "$overlay" && mv "$overlay.tmp" "$overlay"
  fi
fi
: "$need_update"
echo "install-deps.sh: dependencies present (cross=$cross tools=$tools ros=$ros)"
