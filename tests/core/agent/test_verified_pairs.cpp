// SPDX-License-Identifier: BSD-3-Clause
// KeepVerifiedPairs: a pair registration verified in one round is kept, for the same two robot sessions, by a
// later round that lacked the scans to judge it; and only then. Reference: the rule written out per case (which
// result the pair must end with, its kept_from_round and its reason).
#include <doctest/doctest.h>

#include <string>
#include <vector>

#include "core/agent/server_link.hpp"

using namespace commerge;

namespace {

// A pair registration that ran: a success at T_alpha_beta = translation (x_m, 0, 0), or a refusal with
// `missing` of the selected scans absent.
PairMergeResult Registered(int alpha, int beta, RegistrationVerdict verdict, double x_m, std::size_t missing = 0) {
  PairMergeResult p;
  p.alpha = alpha;
  p.beta = beta;
  p.attempted = true;
  p.alpha_scans = 5;
  p.beta_scans = 6;
  p.alpha_missing = missing;
  p.registration.verdict = verdict;
  p.registration.T_target_source.translation().x() = x_m;
  if (verdict != RegistrationVerdict::kSuccess) p.reason = "too few points";
  return p;
}

PairMergeResult Success(int alpha, int beta, double x_m) {
  return Registered(alpha, beta, RegistrationVerdict::kSuccess, x_m);
}

PairMergeResult RefusedWithMissing(int alpha, int beta, std::size_t missing) {
  return Registered(alpha, beta, RegistrationVerdict::kTooFewPoints, 0.0, missing);
}

PairMergeResult NotAttempted(int alpha, int beta, std::size_t alpha_missing, std::size_t beta_missing) {
  PairMergeResult p;
  p.alpha = alpha;
  p.beta = beta;
  p.alpha_missing = alpha_missing;
  p.beta_missing = beta_missing;
  p.reason = alpha_missing + beta_missing > 0 ? "no selected scan was received" : "no loop selected";
  return p;
}

bool IsKept(const PairMergeResult& p, int round, double x_m) {
  return p.kept_from_round == round && p.attempted && p.registration.success() &&
         p.registration.T_target_source.translation().x() == x_m &&
         p.reason.rfind("kept from round " + std::to_string(round) + " (this round: ", 0) == 0;
}

}  // namespace

TEST_CASE("KeepVerifiedPairs: a round without the scans keeps the verified result, and only for the same sessions") {
  std::vector<VerifiedPair> verified;
  std::vector<std::int64_t> sessions = {100, 200, 300};
  const Span<const std::int64_t> s(sessions);

  // Round 1 verifies 0-1 and 0-2; 1-2 is refused with every selected scan present.
  std::vector<PairMergeResult> round1 = {Success(0, 1, 1.5), Success(0, 2, 2.5), RefusedWithMissing(1, 2, 0)};
  KeepVerifiedPairs(1, s, &verified, &round1);
  REQUIRE(verified.size() == 2);
  CHECK(round1[0].kept_from_round == 0);
  CHECK(round1[2].kept_from_round == 0);  // nothing to keep: left as it is
  CHECK_FALSE(round1[2].registration.success());

  // Round 2: 0-1 lacks scans (not attempted), 0-2 was refused with 2 selected scans missing, 1-2 lacks scans
  // but was never verified.
  std::vector<PairMergeResult> round2 = {NotAttempted(0, 1, 14, 0), RefusedWithMissing(0, 2, 2), NotAttempted(1, 2, 0, 3)};
  KeepVerifiedPairs(2, s, &verified, &round2);
  CHECK(IsKept(round2[0], 1, 1.5));
  CHECK(round2[0].reason.find("no selected scan was received") != std::string::npos);
  CHECK(IsKept(round2[1], 1, 2.5));
  CHECK(round2[1].reason.find("refused with 2 selected scans missing: too few points") != std::string::npos);
  CHECK(round2[2].kept_from_round == 0);
  CHECK_FALSE(round2[2].attempted);
  CHECK(verified.size() == 2);  // a kept result is not verified again

  // Round 3: nothing selected for 0-1 (no scan missing) and a refusal with all scans of 0-2: both stand.
  std::vector<PairMergeResult> round3 = {NotAttempted(0, 1, 0, 0), RefusedWithMissing(0, 2, 0)};
  KeepVerifiedPairs(3, s, &verified, &round3);
  CHECK(round3[0].kept_from_round == 0);
  CHECK_FALSE(round3[0].attempted);
  CHECK(round3[1].kept_from_round == 0);
  CHECK_FALSE(round3[1].registration.success());

  // Round 4 verifies 0-1 anew: a later round without scans keeps round 4's result.
  std::vector<PairMergeResult> round4 = {Success(0, 1, 1.7)};
  KeepVerifiedPairs(4, s, &verified, &round4);
  std::vector<PairMergeResult> round5 = {NotAttempted(0, 1, 1, 1)};
  KeepVerifiedPairs(5, s, &verified, &round5);
  CHECK(IsKept(round5[0], 4, 1.7));

  // Robot 1 restarted (a new session, a new map frame): 0-1 is not kept; 0-2 still is.
  sessions[1] = 201;
  std::vector<PairMergeResult> round6 = {NotAttempted(0, 1, 4, 0), NotAttempted(0, 2, 4, 0)};
  KeepVerifiedPairs(6, Span<const std::int64_t>(sessions), &verified, &round6);
  CHECK(round6[0].kept_from_round == 0);
  CHECK_FALSE(round6[0].attempted);
  CHECK(IsKept(round6[1], 1, 2.5));
  // A robot the sessions do not cover (never heard of) keeps nothing either.
  std::vector<PairMergeResult> round7 = {NotAttempted(0, 5, 1, 0)};
  verified.push_back(VerifiedPair{Success(0, 5, 9.0), 6, 100, 0});
  KeepVerifiedPairs(7, Span<const std::int64_t>(sessions), &verified, &round7);
  CHECK(round7[0].kept_from_round == 0);
}

TEST_CASE("KeepVerifiedPairs: the kept reason fits merge_result_t's 255-byte text") {
  std::vector<VerifiedPair> verified;
  const std::vector<std::int64_t> sessions = {1, 2};
  std::vector<PairMergeResult> round1 = {Success(0, 1, 0.5)};
  KeepVerifiedPairs(1, Span<const std::int64_t>(sessions), &verified, &round1);
  std::vector<PairMergeResult> round2 = {RefusedWithMissing(0, 1, 1)};
  round2[0].reason = std::string(400, 'x');
  KeepVerifiedPairs(2, Span<const std::int64_t>(sessions), &verified, &round2);
  CHECK(round2[0].kept_from_round == 1);
  CHECK(round2[0].reason.size() == 255);
}
