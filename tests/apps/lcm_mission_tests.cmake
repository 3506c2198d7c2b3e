# SPDX-License-Identifier: BSD-3-Clause
# Network fault tests of the LCM daemons (issue "LCM runtime"): one mission each, with commerge server and two
# commerge robot processes inside a private network namespace (tests/apps/lcm_mission.sh). Host build only
# (separate processes under qemu would take minutes each); labelled `heavy`, which CI runs on the host.
# Included from tests/CMakeLists.txt.
if(CMAKE_CROSSCOMPILING)
  return()
endif()

set(CM_MISSION_DATA "${CMAKE_CURRENT_BINARY_DIR}/lcm-mission/data")
add_test(NAME "lcm mission: generate the two-robot urban dataset"
         COMMAND $<TARGET_FILE:commerge> sim --world urban --robots 2 --overlap complete --keyframes 200 --lidar vlp16
                 --direction same --wobble-deg 0 --seed 11 --force --out "${CM_MISSION_DATA}")
set_tests_properties("lcm mission: generate the two-robot urban dataset"
                     PROPERTIES FIXTURES_SETUP lcm_mission_data LABELS heavy TIMEOUT 300)

foreach(scenario clean loss10 loss50 tbf2mbit delay2s dup-reorder robot-restart server-restart hostile live replay attack
                 scan-context)
  set(name "lcm mission: ${scenario} ends merged with every descriptor delivered")
  add_test(NAME "${name}"
           COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/lcm_mission.sh" --commerge $<TARGET_FILE:commerge>
                   --data "${CM_MISSION_DATA}" --work "${CMAKE_CURRENT_BINARY_DIR}/lcm-mission/${scenario}"
                   --scenario ${scenario} --sampler $<TARGET_FILE:cm_lcm_sampler>)
  set_tests_properties("${name}" PROPERTIES FIXTURES_REQUIRED lcm_mission_data LABELS heavy TIMEOUT 400
                                            SKIP_REGULAR_EXPRESSION "CM-SKIP:")
endforeach()

# LcmBus on real udpm (the unit tests use LCM's in-process memq://, which has no per-subscription limit): the test
# case skips itself outside the namespace the wrapper creates. Fast; not `heavy`, so the ASan build runs it too.
set(cm_udpm_test "lcm bus: udpm in a private network namespace, LCM's queue limit and the receive thread")
add_test(NAME "${cm_udpm_test}"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/in_private_netns.sh" $<TARGET_FILE:cm_test_platform_lcm>
                 "-tc=LcmBus udpm*")
set_tests_properties("${cm_udpm_test}" PROPERTIES TIMEOUT 120 SKIP_REGULAR_EXPRESSION "CM-SKIP:")
