# SPDX-License-Identifier: BSD-3-Clause
# One place for compile settings: every commerge target calls cm_set_target_defaults().

set(CMAKE_CXX_STANDARD 17)
set(CMAKE_CXX_STANDARD_REQUIRED ON)
set(CMAKE_CXX_EXTENSIONS OFF)
set(CMAKE_POSITION_INDEPENDENT_CODE ON)

# CM_DEBUG_INFO=lines: Debug and RelWithDebInfo builds carry line tables only (-g1, after the build type's -g):
# backtraces and sanitizer and fuzzer reports keep function, file and line, and the compiler and linker skip the
# rest of the debug info, a large share of their work on this code base. tests/run.sh builds this way.
if(CM_DEBUG_INFO STREQUAL "lines")
  add_compile_options($<$<OR:$<CONFIG:Debug>,$<CONFIG:RelWithDebInfo>>:-g1>)
elseif(NOT CM_DEBUG_INFO STREQUAL "full")
  message(FATAL_ERROR "CM_DEBUG_INFO is full or lines, not '${CM_DEBUG_INFO}'")
endif()

if(CM_SANITIZE)
  if(CMAKE_CROSSCOMPILING)
    message(FATAL_ERROR "CM_SANITIZE is for host builds (qemu-user does not run ASan binaries reliably)")
  endif()
  set(CM_SANITIZE_FLAGS -fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  # A sanitized Debug build compiles at -O1, AddressSanitizer's recommended level: the tests run several times
  # faster than at -O0 (Eigen above all), and reports keep their stacks (frame pointers stay).
  add_compile_options($<$<CONFIG:Debug>:-O1>)
  # With ASan, GCC's -Wmaybe-uninitialized reports false positives at -O1 and above (in libstdc++'s <regex>,
  # for one). It never ran in this build at -O0; the optimised host builds keep checking it.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    add_compile_options($<$<CONFIG:Debug>:-Wno-maybe-uninitialized>)
  endif()
endif()

# CM_FUZZ (tests/fuzz): every target gets ASan + UBSan and libFuzzer's coverage instrumentation
# (-fsanitize=fuzzer-no-link: no libFuzzer main), so the fuzzers see and check the libraries' code too; the
# cm_fuzz_* executables add CM_FUZZ_TARGET_FLAGS, which link libFuzzer's driver. libFuzzer is clang's.
if(CM_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "CM_FUZZ needs clang (libFuzzer is part of clang's compiler-rt), not "
                        "${CMAKE_CXX_COMPILER_ID}: configure with CC=clang CXX=clang++ (Debian: apt-get install "
                        "clang libclang-rt-14-dev, or toolchains/install-deps.sh)")
  endif()
  if(CMAKE_CROSSCOMPILING)
    message(FATAL_ERROR "CM_FUZZ is for host builds")
  endif()
  set(CM_SANITIZE_FLAGS -fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer
                        -fno-sanitize-recover=all)
  set(CM_FUZZ_TARGET_FLAGS -fsanitize=fuzzer,address,undefined)
endif()

function(cm_set_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_17)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wshadow -Wdouble-promotion -Wnon-virtual-dtor
                         $<$<BOOL:${CM_WERROR}>:-Werror>)
  if(CM_SANITIZE OR CM_FUZZ)
    target_compile_options(${target} PRIVATE ${CM_SANITIZE_FLAGS})
    target_link_options(${target} PRIVATE ${CM_SANITIZE_FLAGS})
  endif()
endfunction()
