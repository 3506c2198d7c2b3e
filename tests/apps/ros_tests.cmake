# SPDX-License-Identifier: BSD-3-Clause
# ROS input (platform/ros, `commerge import`): bags written by the official ROS 1 writer (Debian's python3-rosbag,
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
