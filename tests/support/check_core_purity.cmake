# SPDX-License-Identifier: BSD-3-Clause
# cmake -DROOT=<repo> -P check_core_purity.cmake
# Fails when core/ includes a higher layer or LCM, or prints (core returns results; platform/apps report).
file(GLOB_RECURSE files "${ROOT}/core/*.hpp" "${ROOT}/core/*.cpp" "${ROOT}/core/*.h")
set(bad "")
foreach(f IN LISTS files)
  file(STRINGS "${f}" lines)
  set(n 0)
  foreach(line IN LISTS lines)
    math(EXPR n "${n} + 1")
    if(line MATCHES "^[ \t]*#[ \t]*include[ \t]*[<\"](platform/|apps/|lcm/|commerge/[a-z_]+_t\\.hpp)")
      string(APPEND bad "  ${f}:${n}: ${line}\n")
    elseif(line MATCHES "(std::cout|std::cerr|[^a-z_]printf[ \t]*\\(|fprintf|[^a-z_]puts[ \t]*\\()"
           AND NOT line MATCHES "^[ \t]*//")
      string(APPEND bad "  ${f}:${n}: ${line}\n")
    endif()
  endforeach()
endforeach()
list(LENGTH files count)
if(bad)
  message(FATAL_ERROR "core/ must stay pure (no platform/, apps/, LCM includes, no printing):\n${bad}")
endif()
message(STATUS "core/ is pure: ${count} files checked")
