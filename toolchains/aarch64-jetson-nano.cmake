# SPDX-License-Identifier: BSD-3-Clause
# Cross build for the Jetson Nano (4x Cortex-A57) from Debian 12 x86-64 with multiarch arm64 libraries.
# Prepare with `toolchains/install-deps.sh --cross`. Test binaries run under qemu-user (see
# CMAKE_CROSSCOMPILING_EMULATOR), so `ctest` works unchanged in the build tree.
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)
set(CMAKE_C_COMPILER   aarch64-linux-gnu-gcc)
set(CMAKE_CXX_COMPILER aarch64-linux-gnu-g++)
set(CMAKE_LIBRARY_ARCHITECTURE aarch64-linux-gnu)
set(CMAKE_C_FLAGS_INIT   "-mcpu=cortex-a57")
set(CMAKE_CXX_FLAGS_INIT "-mcpu=cortex-a57")

# LCM's arm64 packages conflict with the host's, so install-deps.sh extracts them into an overlay.
if(NOT DEFINED CM_ARM64_OVERLAY)
  if(DEFINED ENV{CM_ARM64_OVERLAY})
    set(CM_ARM64_OVERLAY "$ENV{CM_ARM64_OVERLAY}")
  else()
    set(CM_ARM64_OVERLAY "${CMAKE_CURRENT_LIST_DIR}/../.deps/sysroot-arm64-lcm")
  endif()
endif()
get_filename_component(CM_ARM64_OVERLAY "${CM_ARM64_OVERLAY}" ABSOLUTE)
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES CM_ARM64_OVERLAY)

# Multiarch: the "sysroot" is / itself plus the overlay; programs (lcm-gen, javac) come from the host.
set(CMAKE_FIND_ROOT_PATH "/;${CM_ARM64_OVERLAY};/usr/aarch64-linux-gnu")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)
set(ENV{PKG_CONFIG_LIBDIR} "/usr/lib/aarch64-linux-gnu/pkgconfig:/usr/share/pkgconfig:${CM_ARM64_OVERLAY}/usr/lib/aarch64-linux-gnu/pkgconfig")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-Wl,-rpath-link,/usr/lib/aarch64-linux-gnu -Wl,-rpath-link,${CM_ARM64_OVERLAY}/usr/lib/aarch64-linux-gnu")
set(CMAKE_SHARED_LINKER_FLAGS_INIT "${CMAKE_EXE_LINKER_FLAGS_INIT}")

# ctest and doctest_discover_tests run target binaries through qemu-user; -cpu cortex-a57 traps
# instructions the Nano does not have. -L / uses the multiarch loader and libc6:arm64.
set(CMAKE_CROSSCOMPILING_EMULATOR
    "/usr/bin/qemu-aarch64;-cpu;cortex-a57;-L;/;-E;LD_LIBRARY_PATH=${CM_ARM64_OVERLAY}/usr/lib/aarch64-linux-gnu"
    CACHE STRING "qemu-user wrapper for aarch64 test binaries")
