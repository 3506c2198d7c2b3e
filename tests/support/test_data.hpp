// SPDX-License-Identifier: BSD-3-Clause
// Test helpers: licensed shared data (skip when absent) and per-process scratch directories.
#pragma once

#include <string>

namespace commerge::test {

/// Root of ../shared/data: $COMMERGE_SHARED_DATA if set, else the CMake-configured path.
std::string SharedDataDir();

/// Absolute path of `relative` under SharedDataDir(). When it does not exist, prints one line
/// "CM-SKIP: <test> needs <path> (licensed test data, not in the repository)" to stdout, which CTest
/// reports as a skipped test, and returns an empty string.
std::string SharedDataPathOrSkip(const std::string& relative);

/// Whole contents of a file; aborts the test process with a message naming the file when it cannot be read.
std::string ReadTextFile(const std::string& path);

/// A fresh, empty directory for this test process (under $TMPDIR or /tmp), removed at exit.
std::string ScratchDir();

}  // namespace commerge::test

/// Use at the top of a TEST_CASE: binds `var` to the data path or returns (test skipped).
#define CM_SHARED_DATA_OR_SKIP(var, relative)                                  \
  const std::string var = ::commerge::test::SharedDataPathOrSkip(relative);   \
  if (var.empty()) return
