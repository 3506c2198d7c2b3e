# SPDX-License-Identifier: BSD-3-Clause
# commerge-ros1-bridge (apps/ros1_bridge) against a real ROS 1 graph: roscore, rosbag play of a two-robot fixture
# into two bridges, two `commerge robot --live`, one `commerge server`, and a rospy subscriber receiving the tf and
# the merged map, in a private network namespace (tests/apps/ros1_bridge_test.sh). Host builds only, and only where
# the bridge is built (Debian's ROS 1 packages found); labelled heavy. Included from cli_tests.cmake.
if(CMAKE_CROSSCOMPILING OR NOT TARGET commerge-ros1-bridge)
  return()
endif()
set(cm_ros1_bridge_test "ros1 bridge: rosbag play into two bridges and robots ends merged; rviz gets tf and the map")
add_test(NAME "${cm_ros1_bridge_test}"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/ros1_bridge_test.sh" --commerge $<TARGET_FILE:commerge>
                 --bridge $<TARGET_FILE:commerge-ros1-bridge>
                 --fixture "${CMAKE_CURRENT_SOURCE_DIR}/apps/ros1_bag_fixture.py"
                 --listener "${CMAKE_CURRENT_SOURCE_DIR}/apps/ros1_bridge_listener.py"
                 --work "${CMAKE_CURRENT_BINARY_DIR}/ros1-bridge")
set_tests_properties("${cm_ros1_bridge_test}" PROPERTIES LABELS heavy TIMEOUT 240 SKIP_REGULAR_EXPRESSION "CM-SKIP:")
