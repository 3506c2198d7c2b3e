// SPDX-License-Identifier: BSD-3-Clause
// commerge: the merge server's decisions about one robot pair, in one place. Every safeguard between stage A and
// an accepted merge tests one hypothesis, "robot beta's map lies in robot alpha's at placement P", with a few kinds
// of evidence (PairEvidence: what stage A, the place consensus, the ambiguity check, the chains through third
// robots, registration and the descriptor check found). There are three decisions: spend bytes on the pair
// (DecideRequest), spend more after a refusal (DecideWiden), accept a registered transform (DecideAccept). Each is
// a pure function of the evidence and PairDecisionParams and names the stop (PairStop) when it says no. Why each
// threshold has its value: core/agent/decisions/.
#pragma once

#include <cstddef>
#include <cstdint>
#include "core/common/status.hpp"
#include "core/exchange/exchange_cascade.hpp"
#include "core/exchange/place_consensus.hpp"
#include "core/exchange/transform_agreement.hpp"
#include "core/registration/submap_registration.hpp"

namespace commerge {

/// Where a pair stopped on its way to a merge (kNone: it merged). The same names in the run report, the recall
/// benchmark and the server's status.
enum class PairStop : std::uint8_t {
  kNone = 0,              ///< merged
  kIncomparable,          ///< the robots' descriptor parameter ids differ
  kStageA,                ///< stage A found no cluster
  kAmbiguousUnconfirmed,  ///< stage A's cluster is at an ambiguous place that the place consensus does not confirm
  kPlacementDisagrees,    ///< at stage A's placement the robots' descriptors look like strangers' (before any scan)
  kStageB,                ///< stage B found no cover (a limit before any, or infeasible shares)
  kStageC,                ///< stage C or the policy selected nothing
  kPlaceCheck,            ///< the chains through third robots disagree with the pair's placement
  kNothingSelected,       ///< the exchange mode selected no scan of a robot
  kNotThisRound,          ///< the round rule (pair_exchange.hpp) did not register the pair this round
  kScansMissing,          ///< no selected scan of a robot was received
  kRegistration,          ///< registration's gates refused (PairMergeResult::registration.verdict says which)
  kOffConfirmedPlace,     ///< registered away from where the place consensus confirms the ambiguous place
  kDescriptorsDisagree,   ///< where the transform joins the robots, their descriptors are no nearer than chance
  kInconsistent,          ///< the frame solver rejected the transform (inconsistent with the other pairs)
};
inline constexpr int kNumPairStops = 15;

/// "merged", "descriptor ids differ", "stage A", ... (stable, for logs, tables and messages).
const char* PairStopName(PairStop stop) noexcept;

/// The thresholds of the three decisions (ours, not the paper's; 0 switches each off).
struct PairDecisionParams {
  /// [keyframes] An ambiguous cluster whose place consensus support is below this is not requested
  /// (decisions/005-ambiguous-places-without-consensus.md).
  double min_ambiguous_support = 40.0;
  /// [keyframes] An ambiguous cluster of at least this support may be widened, and is accepted only at its
  /// consensus placement (within cascade consensus agree_m / agree_deg; decisions/008 and 009).
  double widen_ambiguous_support = 100.0;
  /// [keyframes] A pair below this support is checked against the chains through third robots whose pairs with
  /// both reach it (the measurement: ExchangePlanner's place check); refused when chains exist and none agrees
  /// (decisions/006-place-check-across-pairs.md).
  double chain_check_support = 40.0;
  /// A transform that co-locates at least min_colocated_keyframes beta keyframes outside stage A's cluster with
  /// alpha's, at a median chance of max_colocated_chance or more, is refused. [0, 1]
  /// (decisions/010-descriptor-agreement.md).
  double max_colocated_chance = 0.2;
  std::size_t min_colocated_keyframes = 20;
  /// A keyframe co-located by a cluster's placement agrees when its chance (transform_agreement.hpp) is at most
  /// this: among strangers that happens with this probability. (0, 1)
  double agree_chance = 0.05;
  /// At a true shared place at least this fraction of the co-located keyframes agrees, in the world where the
  /// descriptor separates worst (decisions/025-descriptor-odds-at-the-placement.md). (agree_chance, 1)
  double true_agree_fraction = 0.25;
  /// [odds] The pair is not requested when the keyframes that stage A's placement co-locates (outside its cluster)
  /// agree as strangers' do at least this many times likelier than as at a true place (AgreementLogOdds <=
  /// -ln(disagree_odds)); 0 = off (the paper). 0 or >= 1.
  double disagree_odds = 100.0;
};

/// InvalidArgument naming the field when a threshold is negative, not finite, or a chance outside [0, 1];
/// agree_chance outside (0, 1), true_agree_fraction not in (agree_chance, 1), disagree_odds neither 0 nor >= 1.
Status ValidatePairDecisionParams(const PairDecisionParams& params);

/// What has been measured about one pair so far; each part is filled where it is measured and says whether it was.
struct PairEvidence {
  /// The cascade (stage A to the policy): its stop when it passed nothing on (kStageA, kStageB, kStageC), else kNone.
  PairStop cascade_stop = PairStop::kNone;
  /// Stage A's cluster is below tau_area (passed on for verification).
  bool below_tau_area = false;
  /// Stage A's cluster is at an ambiguous place (place_ambiguity.hpp).
  bool ambiguous = false;
  /// The place consensus ran: the support of the cluster passed on and its placement.
  bool consensus_measured = false;
  double consensus_support = 0.0;
  ClusterPlacement placement;
  /// Descriptor agreement at the placement of the cluster stage A passed on (measured after stage A when the
  /// cascade passed a cluster on and the decision uses it; measured = false otherwise).
  PlacementAgreement placement_agreement;
  /// The chains through third robots (measured after every pair's cascade of the round).
  PlaceCheckVerdict chains;
  /// Registration ran: its geometry verdict; the gap to the consensus placement (when measured) and the descriptor
  /// agreement (colocation_measured; chance -1 when it could not be measured).
  bool registered = false;
  RegistrationVerdict verdict = RegistrationVerdict::kTooFewPoints;
  bool gap_measured = false;
  PlacementGap gap;
  bool colocation_measured = false;
  std::size_t colocated_keyframes = 0;
  double colocated_chance = -1.0;
  /// For widening: the pair's robots are joined already through other pairs merged this round.
  bool joined_elsewhere = false;
};

/// The cascade's part of the evidence: cascade_stop from its stages' results (stage A found no cluster, stage B had
/// no cover, stage C selected nothing), tau_area, ambiguity, consensus.
PairEvidence CascadeEvidence(const ExchangeCascadeResult& cascade);

struct PairDecision {
  bool yes = false;
  PairStop stop = PairStop::kNone;  ///< why not (kNone when yes)
};

/// Spend bytes on the pair: the cascade passed a selection on, its cluster is not an unconfirmed ambiguous place
/// (support < min_ambiguous_support), the descriptors at its placement do not look like strangers' (refused when
/// PlacementLogOdds <= -ln(disagree_odds)), and no chain of third robots contradicts it. With what is measured so
/// far (chains are known only after the round's cascades).
PairDecision DecideRequest(const PairEvidence& evidence, const PairDecisionParams& params);
/// AgreementLogOdds of the evidence's placement agreement (0 when it was not measured or ranked nothing).
double PlacementLogOdds(const PairEvidence& evidence, const PairDecisionParams& params);
/// The cluster is ambiguous and the place consensus confirms it (support >= widen_ambiguous_support > 0): it may be
/// widened, and its transform must lie at its placement (DecideAccept).
bool AmbiguousPlaceConfirmed(const PairEvidence& evidence, const PairDecisionParams& params);
/// Why a refused pair is not widened.
enum class WidenStop : std::uint8_t {
  kNone = 0,          ///< widened
  kJoinedElsewhere,   ///< its robots are joined already through other pairs merged this round
  kBelowTauArea,      ///< its cluster is below tau_area: its one registration decides
  kAmbiguousPlace,    ///< its cluster is at an ambiguous place not confirmed for widening
};
/// "widened", "joined elsewhere", "below tau_area", "ambiguous place".
const char* WidenStopName(WidenStop stop) noexcept;
struct WidenDecision {
  bool yes = false;
  WidenStop stop = WidenStop::kNone;
};
/// Spend more after a refused registration: its robots not joined through other merged pairs, not below tau_area,
/// not an ambiguous place unless AmbiguousPlaceConfirmed.
WidenDecision DecideWiden(const PairEvidence& evidence, const PairDecisionParams& params);
/// Accept a registered transform: the gates passed, it lies at the confirmed placement (when AmbiguousPlaceConfirmed
/// and the gap is measured: within `placement_agreement`'s agree_m and agree_deg, the tolerances by which two
/// clusters agree) and the descriptors agree where it joins the robots (when measured).
PairDecision DecideAccept(const PairEvidence& evidence, const PairDecisionParams& params,
                          const PlaceConsensusParams& placement_agreement);

}  // namespace commerge
