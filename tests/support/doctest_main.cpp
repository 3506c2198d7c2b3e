// SPDX-License-Identifier: BSD-3-Clause
// main() of every doctest binary, and the skip bookkeeping of tests/support/test_skip.hpp (this is the only
// translation unit with doctest's implementation, so the only one that can read its per-test-case counters).
// Exit code: doctest's (0 or 1), except kSkipExitCode when every test case that ran skipped and nothing failed,
// and 1 when a test case skipped and then went on to run assertions (a skip must end the test case).
#define DOCTEST_CONFIG_IMPLEMENT
#include <doctest/doctest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "tests/support/test_skip.hpp"

namespace commerge::test {
namespace {

struct SkipState {
  int assertions_before_pass = 0;  // doctest's counter at the start of the current pass (subcases re-run the case)
  bool current_skipped = false;
  int assertions_at_skip = 0;
  int cases_run = 0;
  int cases_skipped = 0;
  std::vector<std::string> ran_on_after_skip;  // names of test cases that asserted after skipping
};

SkipState& State() {
  static SkipState state;
  return state;
}

int RawAssertionsInCurrentTestCase() {
  const doctest::detail::ContextState* cs = doctest::detail::g_cs;
  return cs != nullptr && cs->currentTest != nullptr ? static_cast<int>(cs->numAssertsCurrentTest_atomic) : 0;
}

// Sees every test case start, re-enter (one pass per subcase) and end; reports nothing itself.
class SkipListener : public doctest::IReporter {
 public:
  explicit SkipListener(const doctest::ContextOptions&) {}
  void report_query(const doctest::QueryData&) override {}
  void test_run_start() override {}
  void test_run_end(const doctest::TestRunStats&) override {}
  void test_case_start(const doctest::TestCaseData&) override {
    SkipState& s = State();
    ++s.cases_run;
    s.current_skipped = false;
    s.assertions_before_pass = 0;
  }
  void test_case_reenter(const doctest::TestCaseData&) override {
    State().assertions_before_pass = RawAssertionsInCurrentTestCase();
  }
  void test_case_end(const doctest::CurrentTestCaseStats& stats) override {
    SkipState& s = State();
    if (!s.current_skipped) return;
    ++s.cases_skipped;
    if (stats.numAssertsCurrentTest > s.assertions_at_skip) {
      const doctest::TestCaseData* tc = doctest::detail::g_cs->currentTest;
      s.ran_on_after_skip.push_back(tc != nullptr ? tc->m_name : "?");
    }
  }
  void test_case_exception(const doctest::TestCaseException&) override {}
  void subcase_start(const doctest::SubcaseSignature&) override {}
  void subcase_end() override {}
  void log_assert(const doctest::AssertData&) override {}
  void log_message(const doctest::MessageData&) override {}
  void test_case_skipped(const doctest::TestCaseData&) override {}
};

}  // namespace

int AssertionsInCurrentTestCase() { return RawAssertionsInCurrentTestCase() - State().assertions_before_pass; }

void RequireNoAssertionYet(const std::string& what, const char* file, int line) {
  const int n = AssertionsInCurrentTestCase();
  if (n == 0) return;
  const std::string message = what + " was requested after " + std::to_string(n) +
                              " assertion(s) of this test case: data and skip conditions must be requested "
                              "before the first check (at the top of the TEST_CASE), or a skip would hide a failure";
  DOCTEST_ADD_FAIL_AT(file, line, message);
}

void SkipTestCase(const std::string& reason, const char* file, int line) {
  RequireNoAssertionYet("the skip \"" + reason + "\"", file, line);
  SkipState& s = State();
  s.current_skipped = true;
  s.assertions_at_skip = RawAssertionsInCurrentTestCase();
  std::printf("CM-SKIP: %s\n", reason.c_str());
  std::fflush(stdout);
}

}  // namespace commerge::test

DOCTEST_REGISTER_LISTENER("cm_skip", 1, commerge::test::SkipListener);

int main(int argc, char** argv) {
  doctest::Context context(argc, argv);
  const int result = context.run();
  if (context.shouldExit()) return result;  // --help, --list-test-cases, ...
  const commerge::test::SkipState& s = commerge::test::State();
  for (const std::string& name : s.ran_on_after_skip) {
    std::fprintf(stderr, "cm-test: \"%s\" skipped (CM-SKIP) and then ran assertions: a skip must end the test case\n",
                 name.c_str());
  }
  if (!s.ran_on_after_skip.empty()) return 1;
  if (result == 0 && s.cases_run > 0 && s.cases_skipped == s.cases_run) return commerge::test::kSkipExitCode;
  return result;
}
