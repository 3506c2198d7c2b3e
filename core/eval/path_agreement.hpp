// SPDX-License-Identifier: BSD-3-Clause
// commerge: how well placed robots agree along the whole path they share, not only where they were registered
// (issue 57's measure). Over every pair of keyframes (i of robot a, j of robot b, a < b, both placed) whose true
// positions are within radius_m of each other, the error of their relative position in the merge against the
// truth's:
//     e_ij = || translation(T_world_a_i^-1 T_world_b_j) - translation(T_gt_a_i^-1 T_gt_b_j) ||
// Both relative positions are read in keyframe a_i's own frame, so neither the world frame nor the truth's frame
// enters (a rotation of the whole merged map changes nothing); a robot whose map bends where the other's does not
// shows up wherever they are close.
#pragma once

#include <cstddef>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// One robot: its keyframes' poses in the merged world frame (empty: not placed, left out) and their true poses
/// (the same count, any common truth frame; empty: no truth, left out).
struct RobotPathTruth {
  Span<const Eigen::Isometry3d> T_world_keyframe;
  Span<const Eigen::Isometry3d> T_gt_keyframe;
};

struct PathAgreementParams {
  /// Keyframe pairs whose true positions are at most this far apart [m], > 0.
  double radius_m = 10.0;
  /// Every keyframe_stride-th keyframe of each robot is used (1: all), >= 1: a long mission's pairs stay countable.
  std::size_t keyframe_stride = 1;
};

struct PathAgreement {
  std::size_t pairs = 0;  ///< keyframe pairs measured (0: no two placed robots with truth came that close)
  double rms_m = 0.0;     ///< sqrt(mean e_ij^2) [m]
  double p95_m = 0.0;     ///< 95th percentile of e_ij (nearest rank) [m]
  double max_m = 0.0;
};

/// Errors (InvalidArgument, naming the robot or field): a robot whose placed poses and truth differ in count, a
/// non-finite pose, params out of range.
Result<PathAgreement> MeasurePathAgreement(Span<const RobotPathTruth> robots, const PathAgreementParams& params = {});

}  // namespace commerge
