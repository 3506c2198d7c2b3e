// SPDX-License-Identifier: BSD-3-Clause
// cm_test_skip_selftest: test cases that request data or skip in every order that matters, for
// tests/support/check_skip_rules.cmake, which runs each one alone (--test-case=...) with COMMERGE_SHARED_DATA
// pointing at a directory holding only present.txt, and checks the exit code, the output and CTest's verdict.
// Several cases fail on purpose, so this binary is not registered as a test of its own.
#include <doctest/doctest.h>

#include <cstdlib>
#include <string>

#include "tests/support/test_data.hpp"
#include "tests/support/test_skip.hpp"

namespace {

constexpr const char* kAbsent = "absent/cm-skip-selftest.bin";
constexpr const char* kPresent = "present.txt";

// The process exits with 3 at exit(), whatever main() returned.
void ExitWith3() { std::_Exit(3); }

}  // namespace

TEST_CASE("skip selftest: absent data requested first") {  // skipped: exit 77, CM-SKIP printed
  CM_SHARED_DATA_OR_SKIP(path, kAbsent);
  CHECK(path.empty());  // not reached
}

TEST_CASE("skip selftest: absent data requested after a passed check") {  // failed, no CM-SKIP
  CHECK(std::string(kAbsent).size() > 0);
  CM_SHARED_DATA_OR_SKIP(path, kAbsent);
  CHECK(path.empty());
}

TEST_CASE("skip selftest: absent data requested after a failed check") {  // failed, no CM-SKIP
  CHECK(std::string(kAbsent).empty());
  CM_SHARED_DATA_OR_SKIP(path, kAbsent);
  CHECK(path.empty());
}

TEST_CASE("skip selftest: present data requested after a check") {  // failed: the order is wrong with data too
  CHECK(std::string(kPresent).size() > 0);
  CM_SHARED_DATA_OR_SKIP(path, kPresent);
  CHECK(commerge::test::ReadTextFile(path) == "present\n");
}

TEST_CASE("skip selftest: present data requested first") {  // passed
  CM_SHARED_DATA_OR_SKIP(path, kPresent);
  CHECK(commerge::test::ReadTextFile(path) == "present\n");
}

TEST_CASE("skip selftest: present data requested first in a case with subcases") {  // passed (one pass a subcase)
  CM_SHARED_DATA_OR_SKIP(path, kPresent);
  SUBCASE("first") { CHECK(commerge::test::ReadTextFile(path).size() == 8); }
  SUBCASE("second") { CHECK(commerge::test::ReadTextFile(path).back() == '\n'); }
}

TEST_CASE("skip selftest: skipped and then the process fails at exit") {  // failed (exit 3) although CM-SKIP printed
  std::atexit(ExitWith3);
  CM_SKIP_TEST_IF(true, "skip selftest: the process exits with 3 after this skip");
}

TEST_CASE("skip selftest: skipped without returning and then checked") {  // failed: a skip must end the test case
  commerge::test::SkipTestCase("skip selftest: this test case does not return after its skip");
  CHECK(std::string(kPresent).size() > 0);
}
