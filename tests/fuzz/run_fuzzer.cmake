# SPDX-License-Identifier: BSD-3-Clause
# CTest driver of one fuzz target (tests/fuzz/CMakeLists.txt): runs the target once on each largest legal
# message in LARGEST (under the same limits), copies the seed corpus into a fresh, writable corpus directory
# under the build tree (libFuzzer adds the inputs it finds there; the seeds stay as written), then fuzzes it for
# the bounded time in ARGS. A crash, leak, timeout or oversized allocation fails the test; the input that caused
# it is saved in ARTIFACTS.
#   cmake -DFUZZER=<exe> -DSEEDS=<dir> -DLARGEST=<dir> -DCORPUS=<dir> -DARTIFACTS=<dir> -DARGS="<libFuzzer flags>"
#         -P run_fuzzer.cmake
foreach(var FUZZER SEEDS LARGEST CORPUS ARTIFACTS ARGS)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_fuzzer.cmake: -D${var}=... is missing")
  endif()
endforeach()

file(GLOB seeds LIST_DIRECTORIES false "${SEEDS}/*")
if(NOT seeds)
  message(FATAL_ERROR "no seeds in ${SEEDS}: build the target cm_fuzz_seed_corpus (part of `all`)")
endif()
file(REMOVE_RECURSE "${CORPUS}")
file(MAKE_DIRECTORY "${CORPUS}" "${ARTIFACTS}")
file(COPY ${seeds} DESTINATION "${CORPUS}")

separate_arguments(args UNIX_COMMAND "${ARGS}")
# ASan keeps freed blocks in a 256 MB quarantine by default: alone half of -rss_limit_mb. Later options win.
set(ENV{ASAN_OPTIONS} "$ENV{ASAN_OPTIONS}:quarantine_size_mb=32")

file(GLOB largest LIST_DIRECTORIES false "${LARGEST}/*")
if(largest)
  execute_process(COMMAND "${FUZZER}" ${args} "-artifact_prefix=${ARTIFACTS}/" ${largest} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${FUZZER} failed (exit ${rc}) on a largest legal message (${largest}): the limits are "
                        "too tight for legal traffic, or the target has a bug")
  endif()
endif()

execute_process(COMMAND "${FUZZER}" ${args} "-artifact_prefix=${ARTIFACTS}/" "${CORPUS}"
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "${FUZZER} failed (exit ${rc}); the failing input is in ${ARTIFACTS}/ (crash-*, leak-*, "
                      "timeout-*, oom-*). Reproduce: ${FUZZER} <that file>")
endif()
