// SPDX-License-Identifier: BSD-3-Clause
// Skipping a doctest case (licensed data absent, no private network namespace, ...) without ever hiding a failure.
//
// A skip is only honest before the test case has checked anything: a skip after a failed CHECK would report the
// failure as "skipped". So SkipTestCase() fails the test case instead when an assertion already ran, and the test
// binary (tests/support/doctest_main.cpp) reports a skip through its exit code kSkipExitCode, which CTest maps to
// "skipped" (SKIP_RETURN_CODE, tests/CMakeLists.txt): any other failure of the process - a failed check, a crash,
// a leak found at exit - changes the exit code and stays a failure. The binary exits with kSkipExitCode only when
// every test case it ran skipped and nothing failed; each skip also prints "CM-SKIP: <reason>" for the logs.
#pragma once

#include <string>

namespace commerge::test {

/// Exit code of a test binary whose test cases all skipped (CTest property SKIP_RETURN_CODE).
inline constexpr int kSkipExitCode = 77;

/// CHECK/REQUIRE-family assertions (not WARN) evaluated so far in the running test case (in the current pass,
/// for a case with SUBCASEs, which doctest runs once per subcase). 0 outside a test case.
int AssertionsInCurrentTestCase();

/// Fails the running test case (doctest FAIL at file:line, which ends it) when an assertion already ran in it:
/// `what` names what was requested too late, e.g. the data path. Returns normally otherwise.
void RequireNoAssertionYet(const std::string& what, const char* file, int line);

/// Marks the running test case skipped and prints "CM-SKIP: <reason>"; the caller must return at once (use
/// CM_SKIP_TEST_IF). After an assertion it fails the test case instead (RequireNoAssertionYet).
void SkipTestCase(const std::string& reason, const char* file = __builtin_FILE(), int line = __builtin_LINE());

}  // namespace commerge::test

/// At the top of a TEST_CASE: skips it (and returns) when `condition` holds.
#define CM_SKIP_TEST_IF(condition, reason)                       \
  if (condition) {                                               \
    ::commerge::test::SkipTestCase(reason, __FILE__, __LINE__); \
    return;                                                      \
  }                                                              \
  static_assert(true, "")
