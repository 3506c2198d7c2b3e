# SPDX-License-Identifier: BSD-3-Clause
# cmake -DFILE=<path> -DMAX=<n> -P check_line_count.cmake: fails when FILE has more than MAX lines.
file(READ "${FILE}" text)
string(REGEX MATCHALL "\n" newlines "${text}")
list(LENGTH newlines n)
if(n GREATER MAX)
  message(FATAL_ERROR "${FILE} has ${n} lines, more than ${MAX}")
endif()
message("${FILE}: ${n} lines (at most ${MAX})")
