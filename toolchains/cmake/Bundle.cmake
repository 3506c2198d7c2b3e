# SPDX-License-Identifier: BSD-3-Clause
# Field bundle (issue 8): `cmake --build <dir> --target bundle` writes <dir>/commerge-<version>-<arch>.tar.gz with the
# commerge executable, every shared library it needs and the dynamic loader (toolchains/cmake/make_bundle.sh), so that
# it runs on a board without Debian 12's glibc (Jetson Nano, JetPack 4.6). arch: CMAKE_SYSTEM_PROCESSOR (aarch64 with
# toolchains/aarch64-jetson-nano.cmake, x86_64 on the host and with toolchains/x86_64-ipc6000.cmake).
# Not offered in CM_SANITIZE / CM_FUZZ builds (their binaries need the sanitizer runtimes and are not for boards).
# Sets CM_BUNDLE_NAME, CM_BUNDLE_TARBALL, CM_BUNDLE_ARCH and CM_BUNDLE_LOADER for tests/apps/bundle_tests.cmake.
if(CM_SANITIZE OR CM_FUZZ OR NOT TARGET commerge)
  return()
endif()

set(CM_BUNDLE_ARCH "${CMAKE_SYSTEM_PROCESSOR}")
if(CM_BUNDLE_ARCH MATCHES "^(arm64|ARM64|aarch64)$")
  set(CM_BUNDLE_ARCH aarch64)
  set(CM_BUNDLE_LOADER ld-linux-aarch64.so.1)
elseif(CM_BUNDLE_ARCH MATCHES "^(x86_64|AMD64|amd64)$")
  set(CM_BUNDLE_ARCH x86_64)
  set(CM_BUNDLE_LOADER ld-linux-x86-64.so.2)
else()
  message(STATUS "CM-SKIP: no field bundle for CMAKE_SYSTEM_PROCESSOR '${CMAKE_SYSTEM_PROCESSOR}' (aarch64, x86_64)")
  return()
endif()

# Install directory on a board: libexec/commerge gets the interpreter <prefix>/lib/<loader> so that it also starts
# directly there (bin/commerge, the launcher, runs from anywhere). The units of apps/deploy/ and the tests use it too.
# The operator manual apps/README.md ships as share/doc/commerge/README.md (the units' Documentation=).
set(CM_BUNDLE_PREFIX "/opt/commerge")
find_program(CM_PATCHELF patchelf DOC "patchelf (Debian): interpreter and RPATH of the bundled executable; optional")
if(NOT CM_PATCHELF)
  message(STATUS "patchelf not found: the bundle's libexec/commerge keeps its build interpreter and RUNPATH "
                 "(bin/commerge, the launcher, does not need it)")
endif()

# Where the target's loader finds the libraries when listing the closure: the directories of the libraries found at
# configure time (for aarch64 the LCM overlay .deps/sysroot-arm64-lcm comes first), then its default directories.
set(cm_bundle_dirs)
if(DEFINED CM_ARM64_OVERLAY AND CMAKE_LIBRARY_ARCHITECTURE)
  list(APPEND cm_bundle_dirs "${CM_ARM64_OVERLAY}/usr/lib/${CMAKE_LIBRARY_ARCHITECTURE}")
endif()
foreach(lib IN ITEMS "${LCM_LIBRARY}" "${GLPK_LIBRARY}" "${ZLIB_LIBRARY}")
  if(lib)
    get_filename_component(dir "${lib}" DIRECTORY)
    list(APPEND cm_bundle_dirs "${dir}")
  endif()
endforeach()
list(REMOVE_DUPLICATES cm_bundle_dirs)
list(JOIN cm_bundle_dirs ":" cm_bundle_default_path)
set(CM_BUNDLE_LIBRARY_PATH "${cm_bundle_default_path}" CACHE STRING
    "':'-separated directories the target's loader searches first when the bundle lists the executable's libraries")

set(CM_BUNDLE_NAME "commerge-${PROJECT_VERSION}-${CM_BUNDLE_ARCH}")
set(CM_BUNDLE_TARBALL "${PROJECT_BINARY_DIR}/${CM_BUNDLE_NAME}.tar.gz")
set(cm_bundle_script "${CMAKE_CURRENT_LIST_DIR}/make_bundle.sh")
file(GLOB cm_deploy_files CONFIGURE_DEPENDS "${PROJECT_SOURCE_DIR}/apps/deploy/*")
set(cm_emulator)
if(CMAKE_CROSSCOMPILING AND CMAKE_CROSSCOMPILING_EMULATOR)
  list(JOIN CMAKE_CROSSCOMPILING_EMULATOR "|" cm_emulator)
endif()
set(cm_strip)
if(CMAKE_STRIP)
  set(cm_strip "${CMAKE_STRIP}")
endif()
set(cm_patchelf)
if(CM_PATCHELF)
  set(cm_patchelf "${CM_PATCHELF}")
endif()

add_custom_command(
  OUTPUT "${CM_BUNDLE_TARBALL}"
  COMMAND bash "${cm_bundle_script}" --exe "$<TARGET_FILE:commerge>" --name "${CM_BUNDLE_NAME}"
          --out "${CM_BUNDLE_TARBALL}" --emulator "${cm_emulator}" --library-path "${CM_BUNDLE_LIBRARY_PATH}"
          --strip "${cm_strip}" --patchelf "${cm_patchelf}" --prefix "${CM_BUNDLE_PREFIX}"
          --deploy-dir "${PROJECT_SOURCE_DIR}/apps/deploy" --doc "${PROJECT_SOURCE_DIR}/apps/README.md"
          --version "${PROJECT_VERSION}"
          --work "${PROJECT_BINARY_DIR}/bundle-staging"
  DEPENDS commerge "${cm_bundle_script}" ${cm_deploy_files} "${PROJECT_SOURCE_DIR}/apps/README.md"
  COMMENT "Bundling commerge, its libraries and the loader into ${CM_BUNDLE_NAME}.tar.gz"
  VERBATIM)
add_custom_target(bundle DEPENDS "${CM_BUNDLE_TARBALL}")
