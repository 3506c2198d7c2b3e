// SPDX-License-Identifier: BSD-3-Clause
// commerge: what a merge round asks of each robot pair once earlier rounds have answered it (ours; the paper's
// rounds re-run the whole exchange). The cascade runs every round, but a pair's scans are bought only when they can
// change the answer:
//   * a robot of the pair is not placed in the world frame (robot_not_placed): full priority, the pair's plan is
//     requested and registered every round, as before any rule;
//   * the pair has a registration verified for the robots' current sessions:
//       - its robots' poses in the verified overlap moved beyond a bound (a loop closure, poses_moved): the
//         overlap is registered again, from the scans the server holds at the poses it has now (scans it lacks are
//         requested); a refusal at the moved poses keeps the earlier result;
//       - the frame solver could check it with nothing (a bridge, the last round's verdict "unverified") and the
//         cascade now selects a place far from every overlap the pair was registered at (new_overlap): the
//         selection's keyframes away from those overlaps are registered as the pair's second region, and the
//         frame solver gets both (unless another pair's registration this round may close a cycle over it:
//         HoldSecondRegions);
//       - otherwise (unchanged) it keeps its result and costs no scans;
//   * otherwise (never verified, refused, or its verified registration rejected by the frame solver) with both
//     robots placed through other pairs: the pair's plan is registered the first time (first_attempt), after a
//     rejection or refusal only where the cascade's selection is a place far from every one tried
//     (verification_failed, new_overlap), at most max_tried_regions places; otherwise nothing_new;
//   * a robot restarted (a new session, a new map frame): what the pair had is void (robot_restarted).
// Pure functions and plain data: MergeRound (merge_round.hpp) keeps the histories and applies the decisions.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/merge_server.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/merge/frame_solver.hpp"

namespace commerge {

struct PairExchangeParams {
  /// false: every pair is requested and registered every round (rounds that know nothing of earlier ones).
  bool enabled = true;
  /// A verified overlap is registered again when a keyframe of it moved more than this since it was registered
  /// [m], [deg]. The robots stream a moved pose when it is 0.5 m / 1 deg from the server's
  /// (RobotAgentParams::pose_update_min_...): the smallest move the server sees with default robots.
  double moved_m = 0.5;
  double moved_deg = 1.0;
  /// A selection is a new overlap when the median distance of its keyframes to the nearest keyframe of every
  /// region registered (or tried) for the pair is above this on both robots' sides [m]: a place whose scans see
  /// other structure (a street block of the simulator's towns is 80 m).
  double new_overlap_m = 50.0;
  /// Places a pair between placed robots is tried at (first attempt and new overlaps, each registration once);
  /// then it asks for nothing more until a robot is unplaced or restarts.
  std::size_t max_tried_regions = 4;
};

Status ValidatePairExchangeParams(const PairExchangeParams& params);

enum class PairExchangeReason : std::uint8_t {
  // The pair is registered this round (its scans not held are requested):
  kEveryRound,  ///< the rule is off (PairExchangeParams::enabled false)
  kRobotNotPlaced,
  kRobotRestarted,
  kFirstAttempt,
  kPosesMoved,
  kNewOverlap,
  kVerificationFailed,
  // It is not (no scans):
  kUnchanged,
  kNothingNew,
};
/// "every_round", "robot_not_placed", "robot_restarted", "first_attempt", "poses_moved", "new_overlap", "verification_failed",
/// "unchanged", "nothing_new".
const char* PairExchangeReasonName(PairExchangeReason reason) noexcept;
/// True for the reasons that register the pair (every_round .. verification_failed).
bool RegistersPair(PairExchangeReason reason) noexcept;

/// The keyframes one registration of a pair used and the server's poses of them then (T_map_sensor in each
/// robot's map frame; `*_known` 0 where the pose was not known, then not compared).
struct PairRegion {
  std::vector<std::uint32_t> alpha_keyframes, beta_keyframes;
  std::vector<Eigen::Isometry3d> alpha_poses, beta_poses;
  std::vector<std::uint8_t> alpha_known, beta_known;
  int round = 0;
};

/// One verified registration of a pair.
struct VerifiedRegion {
  PairMergeResult result;
  PairRegion region;
  /// The last round's frame solver verdict of its measurement (kAccepted before any).
  MeasurementVerdict verdict = MeasurementVerdict::kAccepted;
};

/// What the rounds know of one robot pair for the robots' sessions.
struct PairHistory {
  int alpha = 0, beta = 0;
  std::int64_t alpha_session = 0, beta_session = 0;
  /// At most kMaxVerifiedRegions; [0] the primary, [1] a second region (new_overlap of a bridge).
  std::vector<VerifiedRegion> verified;
  /// Every place registered for the pair (verified or not), at most PairExchangeParams::max_tried_regions.
  std::vector<PairRegion> tried;
  /// The round whose frame solver rejected a verified registration of the pair (0: none), and the last refusal.
  int rejected_round = 0;
  int refused_round = 0;
  std::string refused_reason;
  /// Set when a round found the robots' sessions changed and voided the rest (until the pair is registered).
  bool restarted = false;
};
inline constexpr std::size_t kMaxVerifiedRegions = 2;

/// One robot's keyframe poses as the server holds them (RobotKeyframeDb::T_map_sensor and pose_known).
struct RobotPoses {
  Span<const Eigen::Isometry3d> T_map_sensor;
  Span<const std::uint8_t> pose_known;
};

/// How far the region's keyframes moved since it was registered: the largest translation [m] and rotation [deg]
/// over both robots' keyframes whose pose is known then and now.
struct RegionMotion {
  double max_translation_m = 0.0;
  double max_rotation_deg = 0.0;
  std::size_t keyframes = 0;  ///< compared
};
RegionMotion MeasureRegionMotion(const PairRegion& region, const RobotPoses& alpha, const RobotPoses& beta);

/// Distance of a selection from the regions registered before: per robot side, the median over the selection's
/// keyframes of the distance to the nearest keyframe of any region (current poses); the smaller side. +infinity
/// when there are no regions or no positions to compare.
double OverlapDistanceM(const PairSelection& selection, Span<const PairRegion> regions, const RobotPoses& alpha,
                        const RobotPoses& beta);

/// The region of a selection with the current poses.
PairRegion MakePairRegion(const PairSelection& selection, const RobotPoses& alpha, const RobotPoses& beta, int round);

struct PairExchangeInput {
  const PairSelection* plan = nullptr;  ///< this round's plan of the pair (the cascade's selection)
  const PairHistory* history = nullptr;  ///< nullptr: nothing known (or for other sessions: see restarted)
  bool restarted = false;                ///< the history held data for older sessions of a robot
  bool alpha_placed = false, beta_placed = false;  ///< in the world frame after the last round
  RobotPoses alpha, beta;
};

struct PairExchangeDecision {
  int alpha = 0, beta = 0;
  PairExchangeReason reason = PairExchangeReason::kRobotNotPlaced;
  std::string why;  ///< one line for a person (reports, the round's TSV)
  /// What to register when RegistersPair(reason): the plan's selection, (poses_moved) the verified region's
  /// keyframes, or (new_overlap of a verified pair) the plan's keyframes farther than new_overlap_m from every
  /// region tried. region: the verified region re-registered (poses_moved), the next free slot (new_overlap of a
  /// verified pair), else 0.
  PairSelection selection;
  std::size_t region = 0;
  RegionMotion motion;                  ///< of the verified region (when there is one)
  double overlap_distance_m = 0.0;      ///< of the plan's selection from the regions (when measured)
  /// Filled by MergeRound: scans requested for this pair's registration (a scan two pairs share counts for the
  /// first), and those its widening asked for.
  std::size_t scans_requested = 0;
  std::size_t scans_widened = 0;
};

/// The rule of the header comment for one pair.
PairExchangeDecision DecidePairExchange(const PairExchangeInput& input, const PairExchangeParams& params);

/// A round's decisions together: while a pair between placed robots that no verified registration joins is
/// registered (first_attempt, verification_failed, new_overlap of region 0), it may close a cycle that checks
/// every bridge at once; the bridges' second regions (new_overlap of region 1) wait for its verdict (unchanged).
void HoldSecondRegions(std::vector<PairExchangeDecision>* decisions);

/// One line per round for reports: "alpha-beta reason scans_requested[+scans_widened]" per decision, joined by
/// "; " (e.g. "0-1 unchanged 0; 0-2 robot_not_placed 12+6").
std::string ExchangeDecisionsText(Span<const PairExchangeDecision> decisions);

}  // namespace commerge
