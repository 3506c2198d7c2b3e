# SPDX-License-Identifier: BSD-3-Clause
# Field bundle and systemd units (issue 8). The bundle (toolchains/cmake/Bundle.cmake) is built by a fixture test,
# then tests/apps/bundle_test.sh proves it runs in an otherwise EMPTY root (aarch64: under a static qemu-aarch64 inside
# the chroot) and tests/apps/deploy_test.sh checks apps/deploy/ (systemd-analyze verify; the units' command lines with
# the example environment files accepted by `commerge ... --check`). Host and jetson configs (under qemu, not `heavy`:
# about 20 s); not in CM_SANITIZE / CM_FUZZ builds, where Bundle.cmake defines no bundle. Included from
# tests/CMakeLists.txt.
if(NOT TARGET bundle)
  return()
endif()

set(CM_BUNDLE_TEST_WORK "${CMAKE_CURRENT_BINARY_DIR}/bundle")
add_test(NAME "bundle: cmake --build --target bundle writes ${CM_BUNDLE_NAME}.tar.gz"
         COMMAND "${CMAKE_COMMAND}" --build "${CMAKE_BINARY_DIR}" --target bundle)
# RUN_SERIAL: it may relink commerge, which other tests run.
set_tests_properties("bundle: cmake --build --target bundle writes ${CM_BUNDLE_NAME}.tar.gz" PROPERTIES
                     FIXTURES_SETUP cm_bundle RUN_SERIAL TRUE TIMEOUT 1800)

set(cm_bundle_emulator)
if(CM_BUNDLE_ARCH STREQUAL "aarch64")
  # Static: it runs inside the empty root, where there is no host library for a dynamic qemu.
  find_program(CM_QEMU_AARCH64_STATIC qemu-aarch64-static DOC "static qemu-user (Debian qemu-user-static) for the bundle tests")
  set(cm_bundle_emulator --emulator "${CM_QEMU_AARCH64_STATIC}")
endif()

set(cm_bundle_args --tarball "${CM_BUNDLE_TARBALL}" --arch ${CM_BUNDLE_ARCH} --version ${PROJECT_VERSION}
                   --work "${CM_BUNDLE_TEST_WORK}" ${cm_bundle_emulator})
foreach(step_name IN ITEMS
        "layout|has the launcher, the loader, the whole library closure, the units and a MANIFEST"
        "empty-root|runs --version, sim and a merging run in an empty chroot, and fails without one of its libraries"
        "launcher|bin/commerge runs from anywhere and through symlinks, passing arguments and exit status")
  string(REPLACE "|" ";" parts "${step_name}")
  list(GET parts 0 step)
  list(GET parts 1 what)
  set(name "bundle: ${CM_BUNDLE_ARCH} ${what}")
  add_test(NAME "${name}" COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/bundle_test.sh" ${cm_bundle_args} --step ${step})
  set_tests_properties("${name}" PROPERTIES FIXTURES_REQUIRED cm_bundle SKIP_REGULAR_EXPRESSION "CM-SKIP:" TIMEOUT 300)
endforeach()

# The units are the same for both boards; their checks run the host's bundle natively.
if(NOT CMAKE_CROSSCOMPILING)
  foreach(step_name IN ITEMS
          "verify|systemd-analyze verify accepts commerge-robot@.service and commerge-server.service"
          "check|each unit's ExecStartPre and ExecStart with the example env file pass --check within its MemoryMax")
    string(REPLACE "|" ";" parts "${step_name}")
    list(GET parts 0 step)
    list(GET parts 1 what)
    set(name "deploy: ${what}")
    add_test(NAME "${name}"
             COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/deploy_test.sh" --tarball "${CM_BUNDLE_TARBALL}"
                     --name ${CM_BUNDLE_NAME} --work "${CM_BUNDLE_TEST_WORK}/deploy-${step}" --step ${step})
    set_tests_properties("${name}" PROPERTIES FIXTURES_REQUIRED cm_bundle SKIP_REGULAR_EXPRESSION "CM-SKIP:" TIMEOUT 120)
  endforeach()
endif()
