// SPDX-License-Identifier: BSD-3-Clause
// commerge: a finished merge against ground truth, robot by robot: whether a chain of robot pairs that share a
// place (shared_place.hpp) joins the robot to robot 0, whether the merge placed it, and whether the placement is
// wrong. Odometry drifts, so no rigid transform fits every shared place: a placed robot is judged where it met
// another placed robot (TruthAtSharedPlace, at the keyframes their registration used when those lie at a shared
// place), and at its start pose only when it shares no place with a placed robot.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/eval/alignment_metrics.hpp"
#include "core/eval/shared_place.hpp"

namespace commerge {

/// A placement is wrong when it is off the truth by more than either limit.
struct WrongMergeCriterion {
  double max_translation_m = 1.0;  ///< [m], > 0
  double max_rotation_deg = 3.0;   ///< [deg], > 0
};

/// True when e.translation_m > max_translation_m or e.rotation_deg > max_rotation_deg (exactly at a limit is
/// right).
bool IsWrongMerge(const TransformError& e, const WrongMergeCriterion& criterion = {});

/// How far off `e` is in units of the criterion: max(translation_m / max_translation_m, rotation_deg /
/// max_rotation_deg): above 1 means off by more than a limit (up to the rounding of the division); the lower, the
/// better the placement agrees.
double WrongMergeScore(const TransformError& e, const WrongMergeCriterion& criterion = {});

/// One robot's keyframe trajectories (borrowed): estimated, in the robot's map frame, and ground truth, in the
/// frame common to every robot, keyframe by keyframe.
struct RobotTrajectoryTruth {
  Span<const Eigen::Isometry3d> estimated;
  Span<const Eigen::Isometry3d> ground_truth;  ///< empty: no ground truth; else as many as `estimated`
  Eigen::Isometry3d T_gt_map = Eigen::Isometry3d::Identity();  ///< the robot's map frame in the ground truth
};

/// Where the merge put one robot.
struct RobotPlacement {
  bool placed = false;  ///< in the world frame (robot 0's map frame)
  Eigen::Isometry3d T_world_map = Eigen::Isometry3d::Identity();  ///< when placed
};

/// One robot pair of the merge, in the merge's order of pairs.
struct JudgedPair {
  int alpha = 0, beta = 0;
  bool registered = false;  ///< a registration was attempted and succeeded
  /// Keyframes of alpha and of beta whose scans the registration used (borrowed; empty when unknown).
  Span<const std::uint32_t> alpha_keyframes, beta_keyframes;
};

struct MergeJudgementParams {
  WrongMergeCriterion wrong;
  SharedPlaceParams shared_place;  ///< which keyframes of two robots are at the same place
  /// A registration's own keyframes decide the truth at their place when at least this many of them lie at a
  /// place of the partner (TruthAtSharedPlace's min_keyframe_pairs); else every shared place does.
  std::size_t min_registered_keyframes = 3;
};

/// Per pair: whether the two robots share a place by ground truth (MeasureSharedPlace of their ground truth).
/// Empty when a robot of any pair has no ground truth. A pair's alpha and beta must index `robots`.
std::vector<SharedPlace> MeasurePairSharedPlaces(Span<const RobotTrajectoryTruth> robots, Span<const JudgedPair> pairs,
                                                 const SharedPlaceParams& params);

/// The keyframes of `robot` whose scans the registration of the pair {robot, partner} used: of the first pair of
/// those two robots (in either order) in `pairs`; empty when there is none or it is not registered.
Span<const std::uint32_t> RegisteredKeyframes(Span<const JudgedPair> pairs, int robot, int partner);

/// The placement of one robot against the truth where it met another placed robot.
struct PlaceJudgement {
  bool judged = false;  ///< false when the robot shares no place with a placed robot
  TransformError error;  ///< ErrorAtSharedPlace of the reported T_partner_robot (judged)
  int partner = -1;     ///< the placed robot of `error` (judged)
};

/// Placed `robot` against every other placed robot q: the reported T_q_robot = T_world_q^-1 T_world_robot against
/// TruthAtSharedPlace(ref q, other robot), fitted at the keyframes their registration used (RegisteredKeyframes)
/// when at least params.min_registered_keyframes of those lie at a shared place, else over every place they share
/// (a merge at a look-alike place stays far from the truth at any of the robot's keyframes). The partner with the
/// lowest WrongMergeScore decides (the first one on a tie). `robots` and `placements` are indexed by robot.
PlaceJudgement JudgeAtSharedPlace(Span<const RobotTrajectoryTruth> robots, Span<const RobotPlacement> placements,
                                  Span<const JudgedPair> pairs, int robot, const MergeJudgementParams& params);

/// How robot r of a merge compares with the truth.
struct RobotVerdict {
  bool has_gt = false;     ///< MeasurePairSharedPlaces gave an answer (every robot of a pair has ground truth)
  bool reachable = false;  ///< a chain of pairs that share a place joins it to robot 0 (has_gt)
  bool merged = false;     ///< placed
  TransformError error;    ///< of T_world_map against T_gt_map(0)^-1 T_gt_map(r), the true start poses (merged, has_gt)
  TransformError error_at_place;  ///< JudgeAtSharedPlace's error (judged_at_place)
  bool judged_at_place = false;   ///< robot r > 0 shares a place with a placed robot
  int place_partner = -1;         ///< the robot of error_at_place
  /// r > 0, merged, has_gt and IsWrongMerge: of error_at_place when judged there, else of error.
  bool wrong = false;
};

/// The verdict of every robot (robots.size() of them; placements the same size). Robot 0 is the world frame:
/// it is never judged at a place nor wrong.
std::vector<RobotVerdict> JudgeRobots(Span<const RobotTrajectoryTruth> robots, Span<const RobotPlacement> placements,
                                      Span<const JudgedPair> pairs, const MergeJudgementParams& params = {});

}  // namespace commerge
