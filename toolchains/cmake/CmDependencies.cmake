# SPDX-License-Identifier: BSD-3-Clause
# Debian 12 packages (toolchains/install-deps.sh). LCM and GLPK ship no CMake config: find_path/find_library
# (pkg-config's lcm.pc needs an arm64 glib-2.0.pc that the multiarch runtime package lacks when cross-compiling).

find_package(Eigen3 3.3 REQUIRED NO_MODULE)

find_path(GLPK_INCLUDE_DIR glpk.h REQUIRED)
find_library(GLPK_LIBRARY glpk REQUIRED)
if(NOT TARGET glpk::glpk)
  add_library(glpk::glpk UNKNOWN IMPORTED)
  set_target_properties(glpk::glpk PROPERTIES IMPORTED_LOCATION "${GLPK_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${GLPK_INCLUDE_DIR}")
endif()

find_path(LCM_INCLUDE_DIR lcm/lcm-cpp.hpp REQUIRED)
find_library(LCM_LIBRARY lcm REQUIRED)
if(NOT TARGET lcm::lcm)
  add_library(lcm::lcm UNKNOWN IMPORTED)
  set_target_properties(lcm::lcm PROPERTIES IMPORTED_LOCATION "${LCM_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${LCM_INCLUDE_DIR}")
endif()

# zlib (Debian zlib1g-dev): the deflate stream inside the report's PNG pictures (platform/report). A tested,
# everywhere-present compressor beats writing our own deflate; a PNG written with stored blocks would be ~3 MB.
find_path(ZLIB_INCLUDE_DIR zlib.h REQUIRED)
find_library(ZLIB_LIBRARY z REQUIRED)
if(NOT TARGET cm_zlib)
  add_library(cm_zlib UNKNOWN IMPORTED)
  set_target_properties(cm_zlib PROPERTIES IMPORTED_LOCATION "${ZLIB_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${ZLIB_INCLUDE_DIR}")
endif()

# libsodium (Debian libsodium-dev): HMAC-SHA-256, constant-time compare and the key generator's random bytes for
# the message MACs (platform/lcm/message_auth). Audited crypto beats writing our own HMAC.
find_path(SODIUM_INCLUDE_DIR sodium.h REQUIRED)
find_library(SODIUM_LIBRARY sodium REQUIRED)
if(NOT TARGET cm_sodium)
  add_library(cm_sodium UNKNOWN IMPORTED)
  set_target_properties(cm_sodium PROPERTIES IMPORTED_LOCATION "${SODIUM_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${SODIUM_INCLUDE_DIR}")
endif()

# liblz4 and libbz2 (Debian liblz4-dev, libbz2-dev): the compressed chunks of ROS 1 bags (platform/ros). The
# ROS bag library itself (librosbag-storage-dev) is not used: it pulls Boost, pluginlib, class_loader, gpgme and
# OpenSSL into the product.
find_path(LZ4_INCLUDE_DIR lz4frame.h REQUIRED)
find_library(LZ4_LIBRARY lz4 REQUIRED)
if(NOT TARGET cm_lz4)
  add_library(cm_lz4 UNKNOWN IMPORTED)
  set_target_properties(cm_lz4 PROPERTIES IMPORTED_LOCATION "${LZ4_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${LZ4_INCLUDE_DIR}")
endif()
find_path(BZIP2_INCLUDE_DIR bzlib.h REQUIRED)
find_library(BZIP2_LIBRARY bz2 REQUIRED)
if(NOT TARGET cm_bz2)
  add_library(cm_bz2 UNKNOWN IMPORTED)
  set_target_properties(cm_bz2 PROPERTIES IMPORTED_LOCATION "${BZIP2_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${BZIP2_INCLUDE_DIR}")
endif()

# libzstd and libsqlite3 (Debian libzstd-dev, libsqlite3-dev): zstd chunks of MCAP files and rosbag2 .db3
# recordings (platform/ros).
find_path(ZSTD_INCLUDE_DIR zstd.h REQUIRED)
find_library(ZSTD_LIBRARY zstd REQUIRED)
if(NOT TARGET cm_zstd)
  add_library(cm_zstd UNKNOWN IMPORTED)
  set_target_properties(cm_zstd PROPERTIES IMPORTED_LOCATION "${ZSTD_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${ZSTD_INCLUDE_DIR}")
endif()
find_path(SQLITE3_INCLUDE_DIR sqlite3.h REQUIRED)
find_library(SQLITE3_LIBRARY sqlite3 REQUIRED)
if(NOT TARGET cm_sqlite3)
  add_library(cm_sqlite3 UNKNOWN IMPORTED)
  set_target_properties(cm_sqlite3 PROPERTIES IMPORTED_LOCATION "${SQLITE3_LIBRARY}"
                        INTERFACE_INCLUDE_DIRECTORIES "${SQLITE3_INCLUDE_DIR}")
endif()

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
