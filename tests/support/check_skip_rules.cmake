# SPDX-License-Identifier: BSD-3-Clause
# cmake -DBIN=<emulator|...|cm_test_skip_selftest> -DCTEST=<ctest> -DSKIP_RETURN_CODE=<n> -DWORK=<dir>
#       -P check_skip_rules.cmake
# The skip rules of tests/support/test_skip.hpp, end to end. Each case of tests/support/skip_selftest.cpp runs
# alone, with COMMERGE_SHARED_DATA holding only present.txt, and must end with its expected exit code, print
# "CM-SKIP:" exactly when it is a clean skip, and name the late data request when it is one. Then the same cases
# run under a generated CTest file with the SKIP_RETURN_CODE of every doctest test (tests/CMakeLists.txt), and
# CTest must report each as skipped, passed or failed as expected: a skip after a check, a skip whose process
# fails otherwise and a skip that does not end its test case are failures, never skips.
cmake_minimum_required(VERSION 3.18)  # policies of the project (CMP0007: empty list elements are kept)
foreach(var BIN CTEST SKIP_RETURN_CODE WORK)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "check_skip_rules.cmake: -D${var}=... is required")
  endif()
endforeach()
string(REPLACE "|" ";" bin "${BIN}")
file(REMOVE_RECURSE "${WORK}")
file(WRITE "${WORK}/data/present.txt" "present\n")
set(ENV{COMMERGE_SHARED_DATA} "${WORK}/data")

# name|test case|exit code|CTest verdict|CM-SKIP printed|regex the output must match ("" = none)
set(cases
  "first|absent data requested first|${SKIP_RETURN_CODE}|Skipped|1|needs .*absent/cm-skip-selftest.bin"
  "after_check|absent data requested after a passed check|1|Failed|0|absent/cm-skip-selftest.bin was requested after 1 assertion.*before the first check"
  "after_failed_check|absent data requested after a failed check|1|Failed|0|absent/cm-skip-selftest.bin was requested after 1 assertion"
  "present_after_check|present data requested after a check|1|Failed|0|present.txt was requested after 1 assertion"
  "present_first|present data requested first|0|Passed|0|"
  "subcases|present data requested first in a case with subcases|0|Passed|0|"
  "fails_at_exit|skipped and then the process fails at exit|3|Failed|1|"
  "ran_on|skipped without returning and then checked|1|Failed|1|skipped .CM-SKIP. and then ran assertions")

set(errors "")
set(ctest_file "")
foreach(c IN LISTS cases)
  string(REPLACE "|" ";" f "${c}")
  list(GET f 0 name)
  list(GET f 1 tc)
  list(GET f 2 want_rc)
  list(GET f 3 verdict)
  list(GET f 4 want_skip)
  list(GET f 5 want_regex)
  execute_process(COMMAND ${bin} "--test-case=skip selftest: ${tc}" RESULT_VARIABLE rc OUTPUT_VARIABLE out
                  ERROR_VARIABLE err)
  set(all "${out}${err}")
  if(NOT rc STREQUAL "${want_rc}")
    string(APPEND errors "  ${name}: exit code ${rc}, expected ${want_rc}\n")
  endif()
  string(FIND "${all}" "CM-SKIP:" at)
  if(want_skip AND at EQUAL -1)
    string(APPEND errors "  ${name}: no CM-SKIP line\n")
  elseif(NOT want_skip AND NOT at EQUAL -1)
    string(APPEND errors "  ${name}: printed CM-SKIP although it must not be reported as a skip\n")
  endif()
  if(NOT want_regex STREQUAL "" AND NOT all MATCHES "${want_regex}")
    string(APPEND errors "  ${name}: output does not match '${want_regex}'\n")
  endif()
  message("---- ${name} (exit ${rc}) ----\n${all}")
  set(cmd "")
  foreach(a IN LISTS bin)
    string(APPEND cmd " \"${a}\"")
  endforeach()
  string(APPEND ctest_file "add_test(${name}${cmd} \"--test-case=skip selftest: ${tc}\")\n"
                           "set_tests_properties(${name} PROPERTIES SKIP_RETURN_CODE ${SKIP_RETURN_CODE}"
                           " ENVIRONMENT \"COMMERGE_SHARED_DATA=${WORK}/data\")\n")
endforeach()

# CTest's own verdicts, with the properties the real tests have.
file(WRITE "${WORK}/ctest/CTestTestfile.cmake" "${ctest_file}")
execute_process(COMMAND "${CTEST}" --test-dir "${WORK}/ctest" RESULT_VARIABLE ctest_rc OUTPUT_VARIABLE ctest_out
                ERROR_VARIABLE ctest_err)
message("---- ctest ----\n${ctest_out}${ctest_err}")
foreach(c IN LISTS cases)
  string(REPLACE "|" ";" f "${c}")
  list(GET f 0 name)
  list(GET f 3 verdict)
  if(verdict STREQUAL "Passed")
    set(re "Test +#[0-9]+: ${name} \\.+ +Passed")
  else()
    set(re "Test +#[0-9]+: ${name} \\.+\\*+${verdict}")
  endif()
  if(NOT ctest_out MATCHES "${re}")
    string(APPEND errors "  ctest: ${name} is not reported ${verdict}\n")
  endif()
endforeach()

if(errors)
  message(FATAL_ERROR "skip rules broken:\n${errors}")
endif()
message(STATUS "skip rules hold for every case")
