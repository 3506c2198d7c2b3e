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

/// How much the evidence says that beta's map lies in alpha's at the placement P of stage A's cluster: kNone (not
/// worth a byte), kWeak (worth one request, checked against the chains through third robots), kStrong (worth
/// widening after a refusal; a link of those chains). EvidenceLevel says how it is read from the evidence.
enum class EvidenceLevel : std::uint8_t { kNone = 0, kWeak, kStrong };
/// "none", "weak", "strong".
const char* EvidenceLevelName(EvidenceLevel level) noexcept;

/// The evidence ladder's steps and the descriptor checks (ours, not the paper's; decisions/026-evidence-ladder.md).
struct PairDecisionParams {
  /// [keyframes] Place consensus support at which the evidence rises from weak to strong: at or above it a pair
  /// may be widened and links the chains through third robots; below it, it is checked against them. An
  /// ambiguous cluster (repeated structure) is one level lower: below this it is not worth a request. 0 = every
  /// plain pair strong, every ambiguous one at least weak (the paper).
  double weak_support_kf = 40.0;
  /// [keyframes] Support at which an ambiguous cluster is strong again; it is then accepted only at its placement
  /// (within the cascade consensus's agree_m / agree_deg). 0 = off: an ambiguous cluster is never strong.
  double strong_support_kf = 100.0;
  /// [odds] The descriptors veto stage A's placement before any request: the keyframes it lays side by side
  /// outside its cluster agree as strangers' do at least this many times likelier than as at a true place
  /// (PlacementLogOdds <= -ln(disagree_odds)). 0 = off (the paper), else >= 1.
  double disagree_odds = 100.0;
  /// The descriptor model the veto reads: a co-located keyframe agrees when its chance (transform_agreement.hpp)
  /// is at most agree_chance, which among strangers happens with that probability; at a true shared place at
  /// least true_agree_fraction of them agree, in the world where the descriptor separates worst
  /// (decisions/025-descriptor-odds-at-the-placement.md). 0 < agree_chance < true_agree_fraction < 1.
  double agree_chance = 0.05;
  double true_agree_fraction = 0.25;
  /// After registration: a transform that co-locates at least min_colocated_keyframes beta keyframes outside stage
  /// A's cluster with alpha's, at a median chance of max_colocated_chance or more, is refused. [0, 1], 0 = off
  /// (decisions/010-descriptor-agreement.md; why these are not the veto's odds: decisions/026-evidence-ladder.md).
  double max_colocated_chance = 0.2;
  std::size_t min_colocated_keyframes = 20;
};

/// InvalidArgument naming the field when a support is negative or not finite, strong_support_kf (when on) below
/// weak_support_kf, agree_chance outside (0, 1), true_agree_fraction not in (agree_chance, 1), disagree_odds neither
/// 0 nor >= 1, max_colocated_chance outside [0, 1].
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
  /// agreement at the registered transform (measured = false when it was not measured).
  bool registered = false;
  RegistrationVerdict verdict = RegistrationVerdict::kTooFewPoints;
  bool gap_measured = false;
  PlacementGap gap;
  PlacementAgreement transform_agreement;
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

/// The ladder: none when the cascade passed nothing on, when the descriptors at stage A's placement veto it
/// (PlacementLogOdds <= -ln(disagree_odds)) or when an ambiguous cluster's support is below weak_support_kf; else
/// strong when the support reaches weak_support_kf (strong_support_kf for an ambiguous cluster), else weak. A
/// support that was not measured (no place consensus, or its memory cap) counts as 0: it lowers the evidence,
/// and the pair's reason says why.
EvidenceLevel PlaceEvidence(const PairEvidence& evidence, const PairDecisionParams& params);
/// AgreementLogOdds of a measured agreement (0 when it was not measured or ranked nothing).
double LogOddsOf(const PlacementAgreement& agreement, const PairDecisionParams& params);
/// AgreementLogOdds of the evidence's placement agreement.
double PlacementLogOdds(const PairEvidence& evidence, const PairDecisionParams& params);
/// Spend bytes on the pair: the evidence is at least weak and, when it is only weak, no chain of third robots
/// contradicts it (chains are known only after the round's cascades). The stop names the first reason: the
/// cascade's, kPlacementDisagrees (the descriptor veto), kAmbiguousUnconfirmed (an ambiguous place below
/// weak_support_kf), kPlaceCheck.
PairDecision DecideRequest(const PairEvidence& evidence, const PairDecisionParams& params);
/// The cluster is ambiguous and its evidence strong: it may be widened, and its transform must lie at its
/// placement (DecideAccept).
bool AmbiguousPlaceConfirmed(const PairEvidence& evidence, const PairDecisionParams& params);
/// Why a refused pair is not widened.
enum class WidenStop : std::uint8_t {
  kNone = 0,          ///< widened
  kJoinedElsewhere,   ///< its robots are joined already through other pairs merged this round
  kBelowTauArea,      ///< its cluster is below tau_area: its one registration decides
  kWeakEvidence,      ///< the evidence for its placement is not strong
};
/// "widened", "joined elsewhere", "below tau_area", "weak evidence".
const char* WidenStopName(WidenStop stop) noexcept;
struct WidenDecision {
  bool yes = false;
  WidenStop stop = WidenStop::kNone;
};
/// Spend more after a refused registration: its robots not joined through other merged pairs, not below tau_area,
/// and the evidence strong.
WidenDecision DecideWiden(const PairEvidence& evidence, const PairDecisionParams& params);
/// Accept a registered transform: the gates passed, it lies at the confirmed placement (when AmbiguousPlaceConfirmed
/// and the gap is measured: within `placement_agreement`'s agree_m and agree_deg, the tolerances by which two
/// clusters agree) and the descriptors agree where it joins the robots (transform_agreement, when measured:
/// refused at a median chance of max_colocated_chance or more over min_colocated_keyframes or more).
PairDecision DecideAccept(const PairEvidence& evidence, const PairDecisionParams& params,
                          const PlaceConsensusParams& placement_agreement);

}  // namespace commerge
