// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/pair_decision.hpp"

#include <cmath>
#include <string>

namespace commerge {

const char* PairStopName(PairStop stop) noexcept {
  switch (stop) {
    case PairStop::kNone: return "merged";
    case PairStop::kIncomparable: return "descriptor ids differ";
    case PairStop::kStageA: return "stage A";
    case PairStop::kAmbiguousUnconfirmed: return "ambiguous place";
    case PairStop::kPlacementDisagrees: return "descriptors disagree at stage A's placement";
    case PairStop::kStageB: return "stage B";
    case PairStop::kStageC: return "stage C";
    case PairStop::kPlaceCheck: return "place check";
    case PairStop::kNothingSelected: return "nothing selected";
    case PairStop::kNotThisRound: return "not registered this round";
    case PairStop::kScansMissing: return "scans missing";
    case PairStop::kRegistration: return "registration";
    case PairStop::kOffConfirmedPlace: return "off the confirmed place";
    case PairStop::kDescriptorsDisagree: return "descriptors disagree where it joins the robots";
    case PairStop::kInconsistent: return "frame solver (inconsistent)";
  }
  return "unknown";
}

Status ValidatePairDecisionParams(const PairDecisionParams& params) {
  const auto support = [](const char* name, double v) {
    return std::isfinite(v) && v >= 0.0
               ? Status::Ok()
               : InvalidArgument(std::string(name) + " = " + std::to_string(v) + " must be finite and >= 0");
  };
  if (Status s = support("min_ambiguous_support", params.min_ambiguous_support); !s.ok()) return s;
  if (Status s = support("widen_ambiguous_support", params.widen_ambiguous_support); !s.ok()) return s;
  if (Status s = support("chain_check_support", params.chain_check_support); !s.ok()) return s;
  if (!(params.agree_chance > 0.0) || params.agree_chance >= 1.0) {
    return InvalidArgument("agree_chance = " + std::to_string(params.agree_chance) + " must be in (0, 1)");
  }
  if (!(params.true_agree_fraction > params.agree_chance) || params.true_agree_fraction >= 1.0) {
    return InvalidArgument("true_agree_fraction = " + std::to_string(params.true_agree_fraction) +
                           " must be above agree_chance (" + std::to_string(params.agree_chance) + ") and below 1");
  }
  if (!std::isfinite(params.disagree_odds) || (params.disagree_odds != 0.0 && !(params.disagree_odds >= 1.0))) {
    return InvalidArgument("disagree_odds = " + std::to_string(params.disagree_odds) + " must be 0 (off) or >= 1");
  }
  if (!(params.max_colocated_chance >= 0.0) || params.max_colocated_chance > 1.0) {
    return InvalidArgument("max_colocated_chance = " + std::to_string(params.max_colocated_chance) +
                           " must be in [0, 1] (0 = off)");
  }
  return Status::Ok();
}

PairEvidence CascadeEvidence(const ExchangeCascadeResult& cascade) {
  PairEvidence e;
  if (!cascade.stage_a.found) {
    e.cascade_stop = PairStop::kStageA;
  } else if (cascade.outcome == CascadeOutcome::kSolverFailure) {
    e.cascade_stop = PairStop::kStageB;
  } else if (cascade.outcome != CascadeOutcome::kPolicy &&
             cascade.stage_b_vertices_alpha + cascade.stage_b_vertices_beta > 0) {
    e.cascade_stop = PairStop::kStageC;  // stage B ran and had a cover: stage C (or the policy) selected nothing
  }
  e.below_tau_area = cascade.verification;
  e.ambiguous = cascade.ambiguous;
  e.consensus_measured = cascade.consensus_measured;
  e.consensus_support = cascade.consensus_support_chosen;
  e.placement = cascade.consensus_placement;
  return e;
}

namespace {

PairDecision No(PairStop stop) { return {false, stop}; }
constexpr PairDecision kYes{true, PairStop::kNone};

// An ambiguous cluster that the place consensus supports less than `min_support` (> 0, else never).
bool AmbiguousBelow(const PairEvidence& e, double min_support) {
  return e.ambiguous && e.consensus_measured && min_support > 0.0 && e.consensus_support < min_support;
}

}  // namespace

double PlacementLogOdds(const PairEvidence& evidence, const PairDecisionParams& params) {
  const PlacementAgreement& a = evidence.placement_agreement;
  if (!a.measured || a.ranked == 0) return 0.0;
  return AgreementLogOdds(a.ranked, a.agreeing, params.agree_chance, params.true_agree_fraction);
}

PairDecision DecideRequest(const PairEvidence& evidence, const PairDecisionParams& params) {
  if (evidence.cascade_stop != PairStop::kNone) return No(evidence.cascade_stop);
  // At a repeated place only other clusters that agree on the placement tell the true place from a look-alike;
  // registration's gates cannot (a corridor aligns well with another corridor).
  if (AmbiguousBelow(evidence, params.min_ambiguous_support)) return No(PairStop::kAmbiguousUnconfirmed);
  // The placement lays beta's other keyframes beside alpha's: at a true place their descriptors agree; a cluster
  // that matched strangers (a sensor that sees little of a place) leaves them as far as any two. Costs no bytes.
  if (params.disagree_odds > 0.0 && PlacementLogOdds(evidence, params) <= -std::log(params.disagree_odds)) {
    return No(PairStop::kPlacementDisagrees);
  }
  if (evidence.chains.refused()) return No(PairStop::kPlaceCheck);
  return kYes;
}

bool AmbiguousPlaceConfirmed(const PairEvidence& evidence, const PairDecisionParams& params) {
  return evidence.ambiguous && params.widen_ambiguous_support > 0.0 && evidence.consensus_measured &&
         evidence.consensus_support >= params.widen_ambiguous_support;
}

const char* WidenStopName(WidenStop stop) noexcept {
  switch (stop) {
    case WidenStop::kNone: return "widened";
    case WidenStop::kJoinedElsewhere: return "joined elsewhere";
    case WidenStop::kBelowTauArea: return "below tau_area";
    case WidenStop::kAmbiguousPlace: return "ambiguous place";
  }
  return "unknown";
}

WidenDecision DecideWiden(const PairEvidence& evidence, const PairDecisionParams& params) {
  // Widening connects robots; its scans cost bytes.
  if (evidence.joined_elsewhere) return {false, WidenStop::kJoinedElsewhere};
  // A cluster below tau_area or at an unconfirmed ambiguous place gets one registration: asking again until
  // something aligns is how a repeated structure gets merged.
  if (evidence.below_tau_area) return {false, WidenStop::kBelowTauArea};
  if (evidence.ambiguous && !AmbiguousPlaceConfirmed(evidence, params)) return {false, WidenStop::kAmbiguousPlace};
  return {true, WidenStop::kNone};
}

PairDecision DecideAccept(const PairEvidence& evidence, const PairDecisionParams& params,
                          const PlaceConsensusParams& placement_agreement) {
  if (!evidence.registered || evidence.verdict != RegistrationVerdict::kSuccess) return No(PairStop::kRegistration);
  if (evidence.gap_measured && AmbiguousPlaceConfirmed(evidence, params) && evidence.placement.valid &&
      !(evidence.gap.distance_m <= placement_agreement.agree_m && evidence.gap.yaw_deg <= placement_agreement.agree_deg)) {
    return No(PairStop::kOffConfirmedPlace);
  }
  if (evidence.colocation_measured && params.max_colocated_chance > 0.0 &&
      evidence.colocated_keyframes >= params.min_colocated_keyframes &&
      evidence.colocated_chance >= params.max_colocated_chance) {
    return No(PairStop::kDescriptorsDisagree);
  }
  return kYes;
}

}  // namespace commerge
