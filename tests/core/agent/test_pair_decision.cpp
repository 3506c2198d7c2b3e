// SPDX-License-Identifier: BSD-3-Clause
// The three decisions about a robot pair (pair_decision.hpp), branch by branch, on hand-made evidence: each case
// changes one fact from a pair that every decision accepts and checks the one stop that fact must give.
#include <doctest/doctest.h>

#include <cmath>
#include <limits>
#include <set>
#include <string>

#include "core/agent/pair_decision.hpp"

namespace commerge {
namespace {

// A pair every decision says yes to: the cascade passed a policy on, the cluster is not ambiguous, no chain
// contradicts it, registration passed its gates, and the descriptors agree (chance 0.1 over 30 keyframes).
PairEvidence Good() {
  PairEvidence e;
  e.consensus_measured = true;
  e.consensus_support = 150.0;
  e.placement.valid = true;
  e.placement.place_beta_m = Eigen::Vector3d(10.0, 0.0, 0.0);
  e.registered = true;
  e.verdict = RegistrationVerdict::kSuccess;
  e.colocation_measured = true;
  e.colocated_keyframes = 30;
  e.colocated_chance = 0.1;
  return e;
}

PlaceConsensusParams Agreement() {
  PlaceConsensusParams p;
  p.agree_m = 8.0;
  p.agree_deg = 20.0;
  return p;
}

TEST_CASE("PairStop and WidenStop: every value has its own name") {
  std::set<std::string> names;
  for (int s = 0; s < kNumPairStops; ++s) names.insert(PairStopName(static_cast<PairStop>(s)));
  CHECK(names.size() == static_cast<std::size_t>(kNumPairStops));
  CHECK(names.count("unknown") == 0);
  CHECK(std::string(PairStopName(PairStop::kNone)) == "merged");
  CHECK(std::string(PairStopName(static_cast<PairStop>(kNumPairStops))) == "unknown");
  std::set<std::string> widen;
  for (int s = 0; s <= static_cast<int>(WidenStop::kAmbiguousPlace); ++s) {
    widen.insert(WidenStopName(static_cast<WidenStop>(s)));
  }
  CHECK(widen.size() == 4);
  CHECK(widen.count("unknown") == 0);
}

TEST_CASE("CascadeEvidence: the stage that stopped the cascade, from its results") {
  ExchangeCascadeResult c;
  CHECK(CascadeEvidence(c).cascade_stop == PairStop::kStageA);  // stage A found nothing
  c.stage_a.found = true;
  CHECK(CascadeEvidence(c).cascade_stop == PairStop::kNone);  // awaits stage B: not stopped
  c.outcome = CascadeOutcome::kSolverFailure;
  c.stage_b_vertices_alpha = 3;
  CHECK(CascadeEvidence(c).cascade_stop == PairStop::kStageB);
  c.outcome = CascadeOutcome::kNoCandidate;  // stage B had a cover, stage C selected nothing
  CHECK(CascadeEvidence(c).cascade_stop == PairStop::kStageC);
  c.outcome = CascadeOutcome::kPolicy;
  c.verification = true;
  c.ambiguous = true;
  c.consensus_measured = true;
  c.consensus_support_chosen = 42.0;
  c.consensus_placement.valid = true;
  const PairEvidence e = CascadeEvidence(c);
  CHECK(e.cascade_stop == PairStop::kNone);
  CHECK(e.below_tau_area);
  CHECK(e.ambiguous);
  CHECK(e.consensus_measured);
  CHECK(e.consensus_support == 42.0);
  CHECK(e.placement.valid);
  CHECK_FALSE(e.registered);
}

TEST_CASE("DecideRequest: the cascade's stop, an unconfirmed ambiguous place, the chains") {
  const PairDecisionParams params;  // min_ambiguous_support 40
  CHECK(DecideRequest(Good(), params).yes);
  CHECK(DecideRequest(Good(), params).stop == PairStop::kNone);
  for (PairStop s : {PairStop::kStageA, PairStop::kStageB, PairStop::kStageC}) {
    PairEvidence e = Good();
    e.cascade_stop = s;
    CHECK_FALSE(DecideRequest(e, params).yes);
    CHECK(DecideRequest(e, params).stop == s);
  }
  PairEvidence ambiguous = Good();
  ambiguous.ambiguous = true;
  ambiguous.consensus_support = 40.0;  // at the threshold: requested
  CHECK(DecideRequest(ambiguous, params).yes);
  ambiguous.consensus_support = 39.0;  // below it
  CHECK(DecideRequest(ambiguous, params).stop == PairStop::kAmbiguousUnconfirmed);
  PairDecisionParams off = params;
  off.min_ambiguous_support = 0.0;  // off
  CHECK(DecideRequest(ambiguous, off).yes);
  ambiguous.consensus_measured = false;  // no support measured: the rule cannot apply
  CHECK(DecideRequest(ambiguous, params).yes);
  PairEvidence plain = Good();
  plain.consensus_support = 1.0;  // not ambiguous: support is not asked for
  CHECK(DecideRequest(plain, params).yes);

  PairEvidence chained = Good();
  chained.chains.checked = true;
  chained.chains.chains = 2;
  chained.chains.agreeing = 1;  // one chain agrees
  CHECK(DecideRequest(chained, params).yes);
  chained.chains.agreeing = 0;  // chains, none agrees
  CHECK(DecideRequest(chained, params).stop == PairStop::kPlaceCheck);
  chained.chains.chains = 0;  // no chain: nothing contradicts it
  CHECK(DecideRequest(chained, params).yes);
  // The cascade's stop comes first.
  chained.chains.chains = 2;
  chained.cascade_stop = PairStop::kStageC;
  CHECK(DecideRequest(chained, params).stop == PairStop::kStageC);
}

TEST_CASE("DecideRequest: descriptors that look like strangers' at stage A's placement, as odds") {
  const PairDecisionParams params;  // agree_chance 0.05, true_agree_fraction 0.25, disagree_odds 100
  // ln odds = k ln(0.25 / 0.05) + (n - k) ln(0.75 / 0.95), by hand: 60 ranked, 3 agree -> -8.65 (refused);
  // 34 ranked, 3 agree -> -2.50 (not); 20 ranked, 0 agree -> -4.73 (refused); 19 ranked, 0 agree -> -4.49 (not).
  const auto with = [](std::size_t ranked, std::size_t agreeing) {
    PairEvidence e = Good();
    e.placement_agreement.measured = true;
    e.placement_agreement.colocated = ranked;
    e.placement_agreement.ranked = ranked;
    e.placement_agreement.agreeing = agreeing;
    return e;
  };
  CHECK(PlacementLogOdds(with(60, 3), params) == doctest::Approx(-8.6458).epsilon(1e-4));
  CHECK(DecideRequest(with(60, 3), params).stop == PairStop::kPlacementDisagrees);
  CHECK(PlacementLogOdds(with(34, 3), params) == doctest::Approx(-2.4997).epsilon(1e-4));
  CHECK(DecideRequest(with(34, 3), params).yes);
  CHECK(DecideRequest(with(20, 0), params).stop == PairStop::kPlacementDisagrees);
  CHECK(DecideRequest(with(19, 0), params).yes);
  CHECK(DecideRequest(with(200, 40), params).yes);  // a true place's share agrees
  CHECK(DecideRequest(with(0, 0), params).yes);     // nothing co-located: no evidence either way
  PairEvidence unmeasured = with(60, 3);
  unmeasured.placement_agreement.measured = false;
  CHECK(PlacementLogOdds(unmeasured, params) == 0.0);
  CHECK(DecideRequest(unmeasured, params).yes);
  PairDecisionParams off = params;
  off.disagree_odds = 0.0;  // off (the paper)
  CHECK(DecideRequest(with(60, 3), off).yes);
  PairDecisionParams lax = params;
  lax.disagree_odds = 10000.0;  // e^-8.65 = 1 / 5680: not 10 000 times likelier among strangers
  CHECK(DecideRequest(with(60, 3), lax).yes);
  // The cascade's stop and an unconfirmed ambiguous place come first; the chains after.
  PairEvidence first = with(60, 3);
  first.cascade_stop = PairStop::kStageA;
  CHECK(DecideRequest(first, params).stop == PairStop::kStageA);
  first = with(60, 3);
  first.ambiguous = true;
  first.consensus_support = 10.0;
  CHECK(DecideRequest(first, params).stop == PairStop::kAmbiguousUnconfirmed);
  first = with(60, 3);
  first.chains.checked = true;
  first.chains.chains = 1;
  CHECK(DecideRequest(first, params).stop == PairStop::kPlacementDisagrees);
}

TEST_CASE("AmbiguousPlaceConfirmed and DecideWiden: joined elsewhere, below tau_area, an ambiguous place") {
  const PairDecisionParams params;  // widen_ambiguous_support 100
  PairEvidence refused = Good();
  refused.verdict = RegistrationVerdict::kOverlapTooLow;
  CHECK(DecideWiden(refused, params).yes);
  CHECK(DecideWiden(refused, params).stop == WidenStop::kNone);

  PairEvidence joined = refused;
  joined.joined_elsewhere = true;
  joined.below_tau_area = true;  // joined elsewhere is said first
  CHECK(DecideWiden(joined, params).stop == WidenStop::kJoinedElsewhere);

  PairEvidence small = refused;
  small.below_tau_area = true;
  CHECK(DecideWiden(small, params).stop == WidenStop::kBelowTauArea);

  PairEvidence ambiguous = refused;
  ambiguous.ambiguous = true;
  ambiguous.consensus_support = 99.0;
  CHECK_FALSE(AmbiguousPlaceConfirmed(ambiguous, params));
  CHECK(DecideWiden(ambiguous, params).stop == WidenStop::kAmbiguousPlace);
  ambiguous.consensus_support = 100.0;  // confirmed at exactly the support asked
  CHECK(AmbiguousPlaceConfirmed(ambiguous, params));
  CHECK(DecideWiden(ambiguous, params).yes);
  ambiguous.consensus_measured = false;
  CHECK_FALSE(AmbiguousPlaceConfirmed(ambiguous, params));
  CHECK(DecideWiden(ambiguous, params).stop == WidenStop::kAmbiguousPlace);
  ambiguous.consensus_measured = true;
  PairDecisionParams off = params;
  off.widen_ambiguous_support = 0.0;  // off: an ambiguous place is never widened
  CHECK_FALSE(AmbiguousPlaceConfirmed(ambiguous, off));
  CHECK(DecideWiden(ambiguous, off).stop == WidenStop::kAmbiguousPlace);
  PairEvidence plain = refused;
  plain.consensus_support = 100.0;
  CHECK_FALSE(AmbiguousPlaceConfirmed(plain, params));  // not ambiguous: nothing to confirm
}

TEST_CASE("DecideAccept: the gates, the confirmed placement, the descriptors where the transform joins the robots") {
  const PairDecisionParams params;  // max_colocated_chance 0.2 over at least 20 keyframes
  const PlaceConsensusParams agreement = Agreement();
  CHECK(DecideAccept(Good(), params, agreement).yes);

  PairEvidence not_run = Good();
  not_run.registered = false;
  CHECK(DecideAccept(not_run, params, agreement).stop == PairStop::kRegistration);
  PairEvidence gates = Good();
  gates.verdict = RegistrationVerdict::kDegenerate;
  CHECK(DecideAccept(gates, params, agreement).stop == PairStop::kRegistration);

  // A confirmed ambiguous place: within agree_m and agree_deg of the placement, inclusive.
  PairEvidence placed = Good();
  placed.ambiguous = true;
  placed.consensus_support = 100.0;
  placed.gap_measured = true;
  placed.gap.distance_m = 8.0;
  placed.gap.yaw_deg = 20.0;
  CHECK(DecideAccept(placed, params, agreement).yes);
  placed.gap.distance_m = 8.01;
  CHECK(DecideAccept(placed, params, agreement).stop == PairStop::kOffConfirmedPlace);
  placed.gap.distance_m = 1.0;
  placed.gap.yaw_deg = 20.5;
  CHECK(DecideAccept(placed, params, agreement).stop == PairStop::kOffConfirmedPlace);
  placed.gap.yaw_deg = 180.0;
  PairEvidence unmeasured = placed;
  unmeasured.gap_measured = false;  // no gap measured: not checked
  CHECK(DecideAccept(unmeasured, params, agreement).yes);
  PairEvidence invalid = placed;
  invalid.placement.valid = false;  // no placement to be at
  CHECK(DecideAccept(invalid, params, agreement).yes);
  PairEvidence unconfirmed = placed;
  unconfirmed.consensus_support = 99.0;  // not confirmed: not widened, so not checked against the placement
  CHECK(DecideAccept(unconfirmed, params, agreement).yes);
  PairEvidence plain = placed;
  plain.ambiguous = false;
  CHECK(DecideAccept(plain, params, agreement).yes);

  // The descriptors under the transform.
  PairEvidence strangers = Good();
  strangers.colocated_chance = 0.2;  // at the threshold: refused
  CHECK(DecideAccept(strangers, params, agreement).stop == PairStop::kDescriptorsDisagree);
  strangers.colocated_chance = 0.19;
  CHECK(DecideAccept(strangers, params, agreement).yes);
  strangers.colocated_chance = 0.5;
  strangers.colocated_keyframes = 19;  // too few keyframes to judge
  CHECK(DecideAccept(strangers, params, agreement).yes);
  strangers.colocated_keyframes = 20;
  CHECK(DecideAccept(strangers, params, agreement).stop == PairStop::kDescriptorsDisagree);
  strangers.colocation_measured = false;
  CHECK(DecideAccept(strangers, params, agreement).yes);
  strangers.colocation_measured = true;
  PairDecisionParams off = params;
  off.max_colocated_chance = 0.0;
  CHECK(DecideAccept(strangers, off, agreement).yes);
  // The placement is checked before the descriptors.
  PairEvidence both = placed;
  both.colocated_chance = 0.5;
  CHECK(DecideAccept(both, params, agreement).stop == PairStop::kOffConfirmedPlace);
}

TEST_CASE("ValidatePairDecisionParams names the field") {
  CHECK(ValidatePairDecisionParams(PairDecisionParams{}).ok());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (double v : {-1.0, nan, inf}) {
    PairDecisionParams p;
    p.min_ambiguous_support = v;
    CHECK(ValidatePairDecisionParams(p).message().find("min_ambiguous_support") != std::string::npos);
    p = PairDecisionParams{};
    p.widen_ambiguous_support = v;
    CHECK(ValidatePairDecisionParams(p).message().find("widen_ambiguous_support") != std::string::npos);
    p = PairDecisionParams{};
    p.chain_check_support = v;
    CHECK(ValidatePairDecisionParams(p).message().find("chain_check_support") != std::string::npos);
  }
  for (double v : {0.0, 1.0, 0.3, nan}) {  // 0.3: not below true_agree_fraction 0.25
    PairDecisionParams p;
    p.agree_chance = v;
    CHECK(ValidatePairDecisionParams(p).message().find("agree_chance") != std::string::npos);
    p = PairDecisionParams{};
    p.true_agree_fraction = v == 0.3 ? 0.05 : v;  // at agree_chance
    CHECK(ValidatePairDecisionParams(p).message().find("true_agree_fraction") != std::string::npos);
  }
  for (double v : {0.5, -1.0, nan, inf}) {
    PairDecisionParams p;
    p.disagree_odds = v;
    CHECK(ValidatePairDecisionParams(p).message().find("disagree_odds") != std::string::npos);
  }
  {
    PairDecisionParams p;
    p.disagree_odds = 1.0;
    CHECK(ValidatePairDecisionParams(p).ok());
  }
  for (double v : {-0.1, 1.1, nan}) {
    PairDecisionParams p;
    p = PairDecisionParams{};
    p.max_colocated_chance = v;
    CHECK(ValidatePairDecisionParams(p).message().find("max_colocated_chance") != std::string::npos);
  }
}

}  // namespace
}  // namespace commerge
