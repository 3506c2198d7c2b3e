# SPDX-License-Identifier: BSD-3-Clause
# CI smoke version of the peak-RAM profiling run (profiling/profile_town.sh, issue 8 item 3): a small generated
# mission (3 robots x 150 keyframes) with commerge server and three commerge robot processes in a private network
# namespace on the jetson-nano profile. Passes when every process exits 0 (the server placed every robot), each
# process's peak RSS (GNU time) is within its own jetson-nano budget total and below its goal (server 512 MB,
# robot 384 MB), and each module's measured high-water mark is within its budget. Host build only (peak RSS is
# measured on native builds; qemu inflates it): labelled `heavy`. Included from profiling/CMakeLists.txt.
if(CMAKE_CROSSCOMPILING OR NOT CM_BUILD_TESTS)
  return()
endif()

set(name "profile town: a 3-robot mission stays within every jetson-nano memory budget (smoke)")
add_test(NAME "${name}"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/profile_town.sh" --commerge $<TARGET_FILE:commerge>
                 --work "${CMAKE_CURRENT_BINARY_DIR}/profile-town-smoke" --keyframes 150 --robots 3
                 --board jetson-nano --check --max-runtime-s 150)
set_tests_properties("${name}" PROPERTIES LABELS heavy TIMEOUT 300 SKIP_REGULAR_EXPRESSION "CM-SKIP:")
