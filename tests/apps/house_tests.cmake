# SPDX-License-Identifier: BSD-3-Clause
# The house rules that keep the code readable, as tests (host only: they read the sources, not the binaries):
# no function in apps/ longer than 150 lines (core/ too, but for the named exceptions of
# apps/core_long_functions.txt), README.md an entry page of at most 300 lines, and `run` and
# `server` sharing the merge flags of one table. Included from cli_tests.cmake.
if(CMAKE_CROSSCOMPILING)
  return()
endif()
set(cm_lengths "${CMAKE_CURRENT_SOURCE_DIR}/apps/function_lengths.sh")
file(GLOB cm_app_sources CONFIGURE_DEPENDS "${PROJECT_SOURCE_DIR}/apps/*.cpp" "${PROJECT_SOURCE_DIR}/apps/*.hpp"
     "${PROJECT_SOURCE_DIR}/apps/ros1_bridge/*.cpp" "${PROJECT_SOURCE_DIR}/apps/ros1_bridge/*.hpp")
add_test(NAME "house: no function in apps/ is longer than 150 lines" COMMAND bash "${cm_lengths}" 150 ${cm_app_sources})
# The checker itself: a 151-line function is found and named, a 150-line one passes; braces in strings and
# comments do not count, and a lambda inside a function is part of it.
set(cm_long "${CMAKE_CURRENT_BINARY_DIR}/house/long_function.cpp")
set(body "namespace x {\nstruct S {\n  int f() const {\n")
foreach(i RANGE 1 149)
  string(APPEND body "    g(\"}\"); // {\n")
endforeach()
string(APPEND body "  }\n};\nint Outer(int a) {\n  auto l = [](int b) { return b; };\n  return l(a);\n}\n}  // namespace x\n")
file(WRITE "${cm_long}" "${body}")
add_test(NAME "house: the function-length check names a 151-line member function"
         COMMAND "${CMAKE_COMMAND}" "-DCMD=bash|${cm_lengths}|150|${cm_long}" -DEXPECT_RC=1
                 "-DEXPECT_REGEX=long_function.cpp:3 f 151 lines" -P "${CM_RUN_EXPECT}")
add_test(NAME "house: the function-length check accepts a function of exactly its limit"
         COMMAND "${CMAKE_COMMAND}" "-DCMD=bash|${cm_lengths}|151|${cm_long}" -DEXPECT_RC=0 -P "${CM_RUN_EXPECT}")
add_test(NAME "house: no function in core/ is longer than 150 lines but the named exceptions"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/core_function_lengths.sh" "${PROJECT_SOURCE_DIR}")
# Its self-test: a tree whose one core function has 151 lines, and a listed exception that is gone.
set(cm_core_long "${CMAKE_CURRENT_BINARY_DIR}/house/core-tree")
file(WRITE "${cm_core_long}/core/x/long.cpp" "${body}")
file(WRITE "${cm_core_long}/tests/apps/core_long_functions.txt" "core/x/gone.cpp Gone 200 a function since split\n")
configure_file("${cm_lengths}" "${cm_core_long}/tests/apps/function_lengths.sh" COPYONLY)
add_test(NAME "house: the core function-length check names a long function and a stale exception"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/core_function_lengths.sh" "${cm_core_long}")
set_tests_properties("house: the core function-length check names a long function and a stale exception"
                     PROPERTIES PASS_REGULAR_EXPRESSION "core/x/long.cpp:3 f is 151 lines.*core/x/gone.cpp Gone is listed")
add_test(NAME "house: README.md has at most 300 lines"
         COMMAND "${CMAKE_COMMAND}" -DFILE=${PROJECT_SOURCE_DIR}/README.md -DMAX=300
                 -P "${CMAKE_CURRENT_SOURCE_DIR}/apps/check_line_count.cmake")
add_test(NAME "cli: run and server share the merge flags: same help, range and default, the documented defaults"
         COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/shared_flags_test.sh" $<TARGET_FILE:commerge>)
if(NOT CMAKE_CROSSCOMPILING)
  add_test(NAME "bench: recall benchmark summarises tune and test seeds per world as worked out by hand"
           COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/recall_split_test.sh" "${PROJECT_SOURCE_DIR}/profiling/bench_recall.sh"
                   "${CMAKE_CURRENT_BINARY_DIR}/recall-split")
  add_test(NAME "bench: recall benchmark medians of the bytes by kind and their shares, as worked out by hand"
           COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/recall_kinds_test.sh" "${PROJECT_SOURCE_DIR}/profiling/bench_recall.sh"
                   "${CMAKE_CURRENT_BINARY_DIR}/recall-kinds")
  add_test(NAME "bench: placement evidence names why each unmerged pair stopped, as worked out by hand"
           COMMAND bash "${CMAKE_CURRENT_SOURCE_DIR}/apps/placement_pairs_test.sh"
                   "${PROJECT_SOURCE_DIR}/profiling/placement_evidence.sh" "${CMAKE_CURRENT_BINARY_DIR}/placement-pairs")
endif()
