// SPDX-License-Identifier: BSD-3-Clause
// commerge: evaluation metrics for map merging: the paper's inter-robot alignment RMSE e_rmse (section
// "Evaluation Metrics", eq. rmsemetric) and the error between an estimated and a reference rigid transform.
#pragma once

#include <cstddef>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// Difference between an estimated and a reference rigid transform.
struct TransformError {
  double translation_m = 0.0;  ///< ||t_estimate - t_reference|| [m] (= translation norm of T_reference^-1 T_estimate)
  double rotation_deg = 0.0;   ///< rotation angle of R_reference^T R_estimate, in [0, 180] [deg]
};

/// Error of `T_estimate` against `T_reference` (both mapping the same source frame into the same target frame).
/// A non-finite argument gives NaN fields.
TransformError ComputeTransformError(const Eigen::Isometry3d& T_estimate, const Eigen::Isometry3d& T_reference);

struct InterRobotAlignmentParams {
  /// Robot alpha's estimated positions are treated as collinear (rotation about the line not observable from
  /// positions alone) when the second singular value of their cross-covariance with the ground truth is below
  /// this fraction of the first (UmeyamaParams::degenerate_ratio). Must be in [0, 1).
  double collinear_ratio = 1e-6;
  /// Collinear fallback: besides each position p, the points p + axis_offset_m * R e_x and
  /// p + axis_offset_m * R e_y of each pose (R its rotation) are aligned, which fixes the rotation [m]. > 0.
  double axis_offset_m = 1.0;
};

/// e_rmse and the quantities around it.
struct InterRobotAlignment {
  /// sqrt(mean_j e_j^2) with e_j = ||translation(T_gt_alpha * T_alpha_beta * T^beta_j) - translation(T^{beta,GT}_j)||
  /// [m]: the paper's e_rmse.
  double rmse_m = 0.0;
  double max_error_m = 0.0;  ///< max_j e_j [m]
  /// sqrt(mean_i ||p^{alpha,GT}_i - T_gt_alpha p^alpha_i||^2) over robot alpha's positions [m]: how well alpha's
  /// own trajectory fits its ground truth (a large value means e_rmse also measures alpha's drift).
  double alpha_rmse_m = 0.0;
  std::size_t count = 0;  ///< number of beta poses j in the RMSE
  /// The Umeyama alignment of alpha's map frame to the ground-truth frame gt (rigid, no scale).
  Eigen::Isometry3d T_gt_alpha = Eigen::Isometry3d::Identity();
  /// True when alpha's positions were collinear and T_gt_alpha was fitted on the pose axes as well.
  bool used_orientations = false;
};

/// Points for a rigid fit of poses: each position, and with_axes also p + offset_m R e_x and p + offset_m R e_y
/// (never collinear with p, so the poses' orientations fix the rotation even on a straight stretch).
std::vector<Eigen::Vector3d> AlignmentPoints(Span<const Eigen::Isometry3d> poses, bool with_axes, double offset_m);

/// Checks InterRobotAlignmentParams; InvalidArgument naming the field otherwise.
Status ValidateInterRobotAlignmentParams(const InterRobotAlignmentParams& params);

/// The paper's inter-robot alignment RMSE:
///   e_rmse = RMSE_j || translation(T_gt_alpha * T_alpha_beta * T^beta_j) - translation(T^{beta,GT}_j) ||
/// * alpha_estimated[i]: robot alpha's estimated poses in alpha's own map frame; alpha_ground_truth[i] the
///   ground-truth pose at the same instant, in the common ground-truth frame gt.
/// * beta_estimated[j], beta_ground_truth[j]: the same for robot beta (same gt frame as alpha's ground truth).
/// * T_alpha_beta: the estimated transform from beta's map frame into alpha's (p_alpha = T_alpha_beta p_beta).
/// T_gt_alpha is the rigid Umeyama alignment (no scale) of alpha's estimated positions onto its ground-truth
/// positions. When those positions are collinear (a straight drive; see collinear_ratio) the rotation about
/// the line is unobservable from positions, so the alignment also uses the points p + d R e_x and p + d R e_y
/// of every pose (d = axis_offset_m): the orientations then fix the rotation, and used_orientations is set.
/// Errors (InvalidArgument, naming the input): alpha_estimated / alpha_ground_truth or beta_estimated /
/// beta_ground_truth differ in size; any of the four has fewer than 3 poses; a pose or T_alpha_beta has a
/// non-finite entry; alpha's poses remain degenerate even with the orientations; invalid params.
Result<InterRobotAlignment> InterRobotAlignmentRmse(Span<const Eigen::Isometry3d> alpha_estimated,
                                                    Span<const Eigen::Isometry3d> alpha_ground_truth,
                                                    Span<const Eigen::Isometry3d> beta_estimated,
                                                    Span<const Eigen::Isometry3d> beta_ground_truth,
                                                    const Eigen::Isometry3d& T_alpha_beta,
                                                    const InterRobotAlignmentParams& params = {});

}  // namespace commerge
