// SPDX-License-Identifier: BSD-3-Clause
// commerge: which robots truly share a place, from ground truth: the denominator of merge recall. Two robots
// share a place when enough of one's path lies near the other's (positions within radius_m of a keyframe of the
// other, headings within max_heading_deg: a forward-looking sensor sees nothing of the same place from the
// opposite direction). A robot can be merged when a chain of such pairs joins it to robot 0.
// Also the truth a merge is judged by where the robots met: a drifting robot's map cannot be placed by one rigid
// transform both at its start and at the shared place, and a registration can only be right at the place it saw.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/eval/alignment_metrics.hpp"

namespace commerge {

struct SharedPlaceParams {
  double radius_m = 5.0;             ///< keyframes of two robots this close are at the same place [m], > 0
  double max_heading_deg = 180.0;    ///< and their yaw differs by at most this [deg] (180: any), in (0, 180]
  double min_shared_path_m = 20.0;   ///< path of one robot at the other's places for the pair to count [m], >= 0
  /// Or this fraction of the shorter robot's whole path, when that is less (a small scene: two halves of a
  /// 60 m walk in a 14 x 16 m courtyard share their place without 20 m of common path), in [0, 1]; 0 = the
  /// absolute min_shared_path_m alone.
  double min_shared_path_fraction = 0.25;
};

Status ValidateSharedPlaceParams(const SharedPlaceParams& params);

/// The default SharedPlaceParams for the robots' LiDAR named `lidar` (names as LidarSensorFor): a sensor narrower
/// than 360 deg (ScanTraits: Livox Avia 70.4 deg, Aeva 120 deg) does not see a place again from a heading more
/// than its horizontal field of view away, so max_heading_deg becomes that field of view; a spinning sensor or
/// an unknown name keeps 180 (any heading).
SharedPlaceParams SharedPlaceParamsForSensor(const std::string& lidar);

struct SharedPlace {
  /// Path length [m] of alpha's trajectory whose keyframes have a beta keyframe at the same place (each keyframe
  /// counts the distance to its predecessor), and the same for beta: the smaller of the two decides.
  double alpha_path_m = 0.0, beta_path_m = 0.0;
  double alpha_total_m = 0.0, beta_total_m = 0.0;  ///< whole path length of each robot [m]
  /// min(alpha_path_m, beta_path_m) >= min(min_shared_path_m, min_shared_path_fraction x the shorter total)
  /// (min_shared_path_m alone when the fraction is 0)
  bool shared = false;
};

/// Two robots' ground-truth keyframe poses (one frame for both). Brute force over the pairs of keyframes.
SharedPlace MeasureSharedPlace(Span<const Eigen::Isometry3d> alpha_gt, Span<const Eigen::Isometry3d> beta_gt,
                               const SharedPlaceParams& params);

/// Robots joined to robot 0 by a chain of shared pairs (reachable[0] = true). `shared(a, b)` for a < b is
/// shared_pairs[index of (a, b) in the order (0,1), (0,2), .., (1,2), ..].
std::vector<bool> ReachableFromRobot0(int robots, const std::vector<bool>& shared_pairs);

/// The transform a perfect registration at the places two robots share would give, and where it applies.
struct SharedPlaceTruth {
  /// Maps robot `other`'s estimated map frame into robot `ref`'s, so that other's keyframes at the shared places
  /// land where ref's estimated map has those places.
  Eigen::Isometry3d T_ref_other = Eigen::Isometry3d::Identity();
  /// Centroid of other's keyframes at the shared places, in other's map frame [m]: where a merge is judged.
  Eigen::Vector3d p_other_place = Eigen::Vector3d::Zero();
  std::size_t keyframe_pairs = 0;  ///< other's keyframes with a ref keyframe at the same place
};

/// Each keyframe i of `other` with a keyframe of `ref` at the same place (ground truth within params.radius_m,
/// headings within params.max_heading_deg; the nearest such j) says where its estimated pose belongs in ref's map:
///   T^ref_i = ref_est[j] * ref_gt[j]^-1 * other_gt[i].
/// T_ref_other is the rigid least-squares fit of other_est[i] onto T^ref_i over those keyframes (positions and
/// the points 1 m along each pose's x and y axes, so a straight stretch fixes the rotation too). Without drift
/// it equals the transform between the two robots' true start poses. Errors (InvalidArgument naming the
/// input): estimated and ground-truth sizes differ; a non-finite pose; invalid params; NotFound when fewer than
/// min_keyframe_pairs keyframes of other are at a place of ref.
/// `other_keyframes` (optional) restricts the fit to those keyframes of other, for example the scans a merge
/// registered: odometry drifts, so no one rigid transform fits every shared place, and a merge is judged at the
/// place it was made. An index outside other's poses is InvalidArgument.
Result<SharedPlaceTruth> TruthAtSharedPlace(Span<const Eigen::Isometry3d> ref_est, Span<const Eigen::Isometry3d> ref_gt,
                                            Span<const Eigen::Isometry3d> other_est,
                                            Span<const Eigen::Isometry3d> other_gt, const SharedPlaceParams& params,
                                            std::size_t min_keyframe_pairs = 3,
                                            Span<const std::uint32_t> other_keyframes = {});

/// Error of `T_ref_other` (an estimate of truth.T_ref_other) at the shared place: translation_m is the distance
/// between where the two transforms put truth.p_other_place, rotation_deg the angle between their rotations.
TransformError ErrorAtSharedPlace(const Eigen::Isometry3d& T_ref_other, const SharedPlaceTruth& truth);

}  // namespace commerge
