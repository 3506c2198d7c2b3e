// SPDX-License-Identifier: BSD-3-Clause
// commerge: which robots truly share a place, from ground truth: the denominator of merge recall. Two robots
// share a place when enough of one's path lies near the other's (positions within radius_m of a keyframe of the
// other, headings within max_heading_deg: a forward-looking sensor sees nothing of the same place from the
// opposite direction). A robot can be merged when a chain of such pairs joins it to robot 0.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct SharedPlaceParams {
  double radius_m = 5.0;             ///< keyframes of two robots this close are at the same place [m], > 0
  double max_heading_deg = 180.0;    ///< and their yaw differs by at most this [deg] (180: any), in (0, 180]
  double min_shared_path_m = 20.0;   ///< path of one robot at the other's places for the pair to count [m], >= 0
};

Status ValidateSharedPlaceParams(const SharedPlaceParams& params);

struct SharedPlace {
  /// Path length [m] of alpha's trajectory whose keyframes have a beta keyframe at the same place (each keyframe
  /// counts the distance to its predecessor), and the same for beta: the smaller of the two decides.
  double alpha_path_m = 0.0, beta_path_m = 0.0;
  bool shared = false;  ///< min(alpha_path_m, beta_path_m) >= min_shared_path_m
};

/// Two robots' ground-truth keyframe poses (one frame for both). Brute force over the pairs of keyframes.
SharedPlace MeasureSharedPlace(Span<const Eigen::Isometry3d> alpha_gt, Span<const Eigen::Isometry3d> beta_gt,
                               const SharedPlaceParams& params);

/// Robots joined to robot 0 by a chain of shared pairs (reachable[0] = true). `shared(a, b)` for a < b is
/// shared_pairs[index of (a, b) in the order (0,1), (0,2), .., (1,2), ..].
std::vector<bool> ReachableFromRobot0(int robots, const std::vector<bool>& shared_pairs);

}  // namespace commerge
