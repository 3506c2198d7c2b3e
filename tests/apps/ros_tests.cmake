# SPDX-License-Identifier: BSD-3-Clause
# ROS input and scan sessions (platform/ros, platform/io/scan_session, `commerge import`): bags written by the official ROS 1 writer (Debian's python3-rosbag,
# installed by toolchains/install-deps.sh) from a generated world and, when ../shared/data is present, the real
# hku2 sequence; converted by `commerge import` and merged as the directories they came from. Host builds only
# (the writer is a host Python program; the readers' unit tests run under qemu too). Included from cli_tests.cmake.
if(CMAKE_CROSSCOMPILING)
  return()
endif()
add_test(NAME "import: ROS 1 bags by the official writer import to the directories they were written from and merge the same"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/ros_import_test.sh" $<TARGET_FILE:commerge>
                 "${CMAKE_CURRENT_SOURCE_DIR}/apps/ros1_bag_fixture.py" "${CM_CLI_OUT}/ros-import" "${CM_SHARED_DATA_DIR}")
set_tests_properties("import: ROS 1 bags by the official writer import to the directories they were written from and merge the same"
                     PROPERTIES TIMEOUT 600)
add_test(NAME "import: scan sessions written by PCL's tools (binary_compressed and binary PCD, TUM/CSV/KITTI poses) import to the directories they came from and merge the same"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/session_import_test.sh" $<TARGET_FILE:commerge>
                 "${CM_CLI_OUT}/session-import" "${CM_SHARED_DATA_DIR}")
set_tests_properties("import: scan sessions written by PCL's tools (binary_compressed and binary PCD, TUM/CSV/KITTI poses) import to the directories they came from and merge the same"
                     PROPERTIES TIMEOUT 600)
set(cm_ros2_import_test "import: ROS 2 recordings by independent writers (MCAP by @mcap/core, rosbag2 .db3) import to the directories they were written from and merge the same")
add_test(NAME "${cm_ros2_import_test}"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/ros2_import_test.sh" $<TARGET_FILE:commerge>
                 "${CMAKE_CURRENT_SOURCE_DIR}/apps/mcap_fixture.mjs" "${CMAKE_BINARY_DIR}/node-deps/ros2-fixtures"
                 "${CM_CLI_OUT}/ros2-import" "${CM_SHARED_DATA_DIR}")
set_tests_properties("${cm_ros2_import_test}" PROPERTIES TIMEOUT 900 SKIP_REGULAR_EXPRESSION "CM-SKIP:")
