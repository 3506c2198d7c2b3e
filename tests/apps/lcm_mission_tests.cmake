# SPDX-License-Identifier: BSD-3-Clause
# Network fault tests of the LCM daemons (issue "LCM runtime"): one mission each, with commerge server and one
# commerge robot process per robot of the dataset inside a private network namespace (tests/apps/lcm_mission.sh):
# every scenario on a two-robot dataset, and loss10 on a five-robot one. Host build only (separate processes under
# qemu would take minutes each); labelled `heavy`, which CI runs on the host. Included from tests/CMakeLists.txt.
if(CMAKE_CROSSCOMPILING)
  return()
endif()

# Reads back the server's exchange_rounds.tsv, exchange_summary.tsv and exchange_bytes.png after each mission.
cm_add_executable(cm_check_exchange_outputs "${CMAKE_CURRENT_SOURCE_DIR}/support/exchange_outputs_check.cpp"
                  "${CMAKE_CURRENT_SOURCE_DIR}/support/png_reader.cpp")
target_link_libraries(cm_check_exchange_outputs PRIVATE cm_zlib)

set(CM_MISSION_DATA "${CMAKE_CURRENT_BINARY_DIR}/lcm-mission/data")
add_test(NAME "lcm mission: generate the two-robot urban dataset"
         COMMAND $<TARGET_FILE:commerge> sim --world urban --robots 2 --overlap complete --keyframes 200 --lidar vlp16
                 --direction same --wobble-deg 0 --seed 11 --force --out "${CM_MISSION_DATA}")
set_tests_properties("lcm mission: generate the two-robot urban dataset"
                     PROPERTIES FIXTURES_SETUP lcm_mission_data LABELS heavy TIMEOUT 300)

foreach(scenario clean loss10 loss50 tbf2mbit delay2s dup-reorder robot-restart server-restart hostile live replay
                 replay-load attack scan-context)
  set(name "lcm mission: ${scenario} ends merged with every descriptor delivered")
  add_test(NAME "${name}"
           COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/lcm_mission.sh" --commerge $<TARGET_FILE:commerge>
                   --data "${CM_MISSION_DATA}" --work "${CMAKE_CURRENT_BINARY_DIR}/lcm-mission/${scenario}"
                   --scenario ${scenario} --sampler $<TARGET_FILE:cm_lcm_sampler>
                   --checker $<TARGET_FILE:cm_check_exchange_outputs>)
  set_tests_properties("${name}" PROPERTIES FIXTURES_REQUIRED lcm_mission_data LABELS heavy TIMEOUT 400
                                            SKIP_REGULAR_EXPRESSION "CM-SKIP:")
endforeach()

# Five robots (server --robots 5 --exit-when-merged 5), authenticated, 10 % of the packets dropped: every robot
# must be placed within 0.5 m / 2 deg and deliver every descriptor. 40-65 s on 2 busy cores; the script gives up
# after 330 s.
set(CM_MISSION_DATA5 "${CMAKE_CURRENT_BINARY_DIR}/lcm-mission/data5")
add_test(NAME "lcm mission: generate the five-robot urban dataset"
         COMMAND $<TARGET_FILE:commerge> sim --world urban --robots 5 --overlap complete --keyframes 200 --lidar vlp16
                 --direction same --wobble-deg 0 --seed 11 --force --out "${CM_MISSION_DATA5}")
set_tests_properties("lcm mission: generate the five-robot urban dataset"
                     PROPERTIES FIXTURES_SETUP lcm_mission_data5 LABELS heavy TIMEOUT 300)
set(name "lcm mission: 5 robots with 10 % loss end merged with every descriptor delivered")
add_test(NAME "${name}"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/lcm_mission.sh" --commerge $<TARGET_FILE:commerge>
                 --data "${CM_MISSION_DATA5}" --work "${CMAKE_CURRENT_BINARY_DIR}/lcm-mission/5-robots-loss10"
                 --scenario loss10 --checker $<TARGET_FILE:cm_check_exchange_outputs>)
set_tests_properties("${name}" PROPERTIES FIXTURES_REQUIRED lcm_mission_data5 LABELS heavy TIMEOUT 500
                                          SKIP_REGULAR_EXPRESSION "CM-SKIP:")

# LcmBus on real udpm (the unit tests use LCM's in-process memq://, which has no per-subscription limit): the test
# case skips itself outside the namespace the wrapper creates. Fast; not `heavy`, so the ASan build runs it too.
set(cm_udpm_test "lcm bus: udpm in a private network namespace, LCM's queue limit and the receive thread")
add_test(NAME "${cm_udpm_test}"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/in_private_netns.sh" $<TARGET_FILE:cm_test_platform_lcm>
                 "-tc=LcmBus udpm*")
set_tests_properties("${cm_udpm_test}" PROPERTIES TIMEOUT 120 SKIP_REGULAR_EXPRESSION "CM-SKIP:")
