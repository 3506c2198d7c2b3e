# SPDX-License-Identifier: BSD-3-Clause
# Debian 12 packages (toolchains/install-deps.sh). LCM and GLPK ship no CMake config: find_path/find_library
# (pkg-config's lcm.pc needs an arm64 glib-2.0.pc that the multiarch runtime package lacks when cross-compiling).

# cm_import_library(<target> <VAR> <header> <library>): finds the header and the library (REQUIRED; <VAR>_INCLUDE_DIR,
# <VAR>_LIBRARY in the cache) and makes the imported target.
function(cm_import_library target var header library)
  find_path(${var}_INCLUDE_DIR ${header} REQUIRED)
  find_library(${var}_LIBRARY ${library} REQUIRED)
  if(NOT TARGET ${target})
    add_library(${target} UNKNOWN IMPORTED GLOBAL)
    set_target_properties(${target} PROPERTIES IMPORTED_LOCATION "${${var}_LIBRARY}"
                          INTERFACE_INCLUDE_DIRECTORIES "${${var}_INCLUDE_DIR}")
  endif()
endfunction()

find_package(Eigen3 3.3 REQUIRED NO_MODULE)

cm_import_library(glpk::glpk GLPK glpk.h glpk)

cm_import_library(lcm::lcm LCM lcm/lcm-cpp.hpp lcm)

# zlib (Debian zlib1g-dev): the deflate stream inside the report's PNG pictures (platform/report). A tested,
# everywhere-present compressor beats writing our own deflate; a PNG written with stored blocks would be ~3 MB.
cm_import_library(cm_zlib ZLIB zlib.h z)

# libsodium (Debian libsodium-dev): HMAC-SHA-256, constant-time compare and the key generator's random bytes for
# the message MACs (platform/lcm/message_auth). Audited crypto beats writing our own HMAC.
cm_import_library(cm_sodium SODIUM sodium.h sodium)

# liblz4 and libbz2 (Debian liblz4-dev, libbz2-dev): the compressed chunks of ROS 1 bags (platform/ros). The
# ROS bag library itself (librosbag-storage-dev) is not used: it pulls Boost, pluginlib, class_loader, gpgme and
# OpenSSL into the product.
cm_import_library(cm_lz4 LZ4 lz4frame.h lz4)
cm_import_library(cm_bz2 BZIP2 bzlib.h bz2)

# libzstd and libsqlite3 (Debian libzstd-dev, libsqlite3-dev): zstd chunks of MCAP files and rosbag2 .db3
# recordings (platform/ros).
cm_import_library(cm_zstd ZSTD zstd.h zstd)
cm_import_library(cm_sqlite3 SQLITE3 sqlite3.h sqlite3)

# Header-only, from Debian: CLI11 (subcommands, --help, validation), nanoflann (k-d tree, used by registration).
find_path(CLI11_INCLUDE_DIR CLI/CLI.hpp REQUIRED)
if(NOT TARGET cm_cli11)
  add_library(cm_cli11 INTERFACE)
  target_include_directories(cm_cli11 SYSTEM INTERFACE "${CLI11_INCLUDE_DIR}")
endif()

# mimalloc interposes malloc process-wide when linked. Not with the sanitizers (CM_SANITIZE, CM_FUZZ): ASan must
# own malloc.
if(CM_SANITIZE OR CM_FUZZ)
  set(CM_WITH_MIMALLOC OFF)
else()
  find_package(mimalloc 2.0 REQUIRED)
  set(CM_WITH_MIMALLOC ON)
endif()

if(CM_BUILD_TESTS)
  find_package(doctest REQUIRED)
  include(doctest)
endif()
