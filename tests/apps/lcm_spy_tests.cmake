# SPDX-License-Identifier: BSD-3-Clause
# Monitoring with lcm-spy: cm_lcm_sampler (publishes one sample of every commerge message on its channel) and the
# headless test that lcm-spy, started through <build>/commerge-spy under Xvfb in a private network namespace,
# discovers every type of lcmtypes/*.lcm and decodes every channel. Included from tests/CMakeLists.txt.

cm_add_executable(cm_lcm_sampler "${CMAKE_CURRENT_SOURCE_DIR}/support/lcm_sampler.cpp")

# Host only: the type jar and commerge-spy exist only where javac ran (not when cross-compiling). Label `heavy`
# (two JVMs and an X server): tests/run.sh runs it in the host configuration.
if(NOT CMAKE_CROSSCOMPILING AND TARGET cm_lcmtypes_java)
  set(cm_spy_test "lcm-spy: finds every commerge type and decodes every channel")
  add_test(NAME "${cm_spy_test}"
           COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/lcm_spy_test.sh"
                   --launcher "${PROJECT_BINARY_DIR}/commerge-spy"
                   --sampler $<TARGET_FILE:cm_lcm_sampler>
                   --lcmtypes "${PROJECT_SOURCE_DIR}/lcmtypes"
                   --checker "${CMAKE_CURRENT_SOURCE_DIR}/apps/LcmSpyCheck.java"
                   --work "${CMAKE_CURRENT_BINARY_DIR}/lcm-spy")
  set_tests_properties("${cm_spy_test}" PROPERTIES LABELS heavy TIMEOUT 90 SKIP_REGULAR_EXPRESSION "CM-SKIP:")
endif()
