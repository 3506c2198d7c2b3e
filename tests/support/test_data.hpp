// SPDX-License-Identifier: BSD-3-Clause
// Test helpers: licensed shared data (skip when absent) and per-process scratch directories and files.
#pragma once

#include <string>

namespace commerge::test {

/// Root of ../shared/data: $COMMERGE_SHARED_DATA if set, else the CMake-configured path.
std::string SharedDataDir();

/// Absolute path of `relative` under SharedDataDir(). When it does not exist, skips the running test case
/// (tests/support/test_skip.hpp: prints "CM-SKIP: this test needs <path> ...", CTest reports it skipped) and
/// returns an empty string, on which the caller must return. Data must be requested before the first assertion
/// of the test case: after one, this fails the test case at `file`:`line` (present data or not), because a skip
/// there could hide a failed check.
std::string SharedDataPathOrSkip(const std::string& relative, const char* file = __builtin_FILE(),
                                 int line = __builtin_LINE());

/// Whole contents of a file; aborts the test process with a message naming the file when it cannot be read.
std::string ReadTextFile(const std::string& path);

/// A fresh, empty directory for this test process (under $TMPDIR or /tmp), removed at exit.
std::string ScratchDir();

/// ScratchDir() + "/" + name: a path in this process's scratch directory (the file is not created).
std::string ScratchFile(const std::string& name);

}  // namespace commerge::test

/// Use at the top of a TEST_CASE, before any assertion: binds `var` to the data path or returns (test skipped).
#define CM_SHARED_DATA_OR_SKIP(var, relative)                                                        \
  const std::string var = ::commerge::test::SharedDataPathOrSkip(relative, __FILE__, __LINE__);     \
  if (var.empty()) return
