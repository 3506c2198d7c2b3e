// SPDX-License-Identifier: BSD-3-Clause
// commerge: a robot's intra-robot loops against its ground truth: the error of each accepted loop transform,
// which loops are false, and the median and largest translation error (what `commerge run` prints per robot).
#pragma once

#include <Eigen/Geometry>

#include "core/common/span.hpp"

namespace commerge {

/// When a loop is false: its error (LoopErrorTransform) translates by more than max_translation_m or rotates by
/// more than max_rotation_deg.
struct FalseLoopCriterion {
  double max_translation_m = 2.0;  ///< [m]
  double max_rotation_deg = 10.0;  ///< [deg]
};

/// The loops of one robot against its ground truth. checked = -1 without ground truth (the other fields 0).
struct LoopErrors {
  long long checked = -1;  ///< loops judged
  long long wrong = 0;     ///< of those, false by the FalseLoopCriterion
  double median_m = 0.0;   ///< median translation error (the upper one of an even count) [m]; 0 without loops
  double max_m = 0.0;      ///< largest translation error [m]; 0 without loops
};

/// The error of a loop measurement against the truth, in the query keyframe's frame:
///   E = (T_gt_match^-1 T_gt_query)^-1 T_match_query.
/// T_gt_match, T_gt_query: the two keyframes' ground-truth poses (one frame for both). Identity when exact.
Eigen::Isometry3d LoopErrorTransform(const Eigen::Isometry3d& T_match_query, const Eigen::Isometry3d& T_gt_match,
                                     const Eigen::Isometry3d& T_gt_query);

/// Rotation angle of T's rotation [deg], in [0, 180].
double RotationAngleDeg(const Eigen::Isometry3d& T);

/// True when `error` (a LoopErrorTransform) translates by more than criterion.max_translation_m or rotates by
/// more than criterion.max_rotation_deg (a loop exactly at a limit is not false).
bool IsFalseLoop(const Eigen::Isometry3d& error, const FalseLoopCriterion& criterion = {});

/// The loop errors of one robot that has ground truth: checked = errors.size(), wrong = the false ones,
/// median_m the element at index n / 2 of the sorted translation errors, max_m the largest.
LoopErrors SummarizeLoopErrors(Span<const Eigen::Isometry3d> errors, const FalseLoopCriterion& criterion = {});

}  // namespace commerge
