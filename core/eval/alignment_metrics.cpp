// SPDX-License-Identifier: BSD-3-Clause
// Inter-robot alignment RMSE (paper eq. rmsemetric) and transform errors.
#include "core/eval/alignment_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include "core/common/number_text.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/geometry/umeyama.hpp"

namespace commerge {
namespace {

bool IsFiniteRigidPart(const Eigen::Isometry3d& T) { return T.matrix().topRows<3>().allFinite(); }

Status CheckPoses(Span<const Eigen::Isometry3d> poses, const char* name) {
  if (poses.size() < 3) {
    return InvalidArgument(std::string("inter-robot alignment: ") + name + " has " + std::to_string(poses.size()) +
                           " poses, at least 3 are needed");
  }
  for (std::size_t i = 0; i < poses.size(); ++i) {
    if (!IsFiniteRigidPart(poses[i])) {
      return InvalidArgument(std::string("inter-robot alignment: ") + name + " pose " + std::to_string(i) +
                             " has a non-finite entry");
    }
  }
  return Status::Ok();
}

Status CheckPair(Span<const Eigen::Isometry3d> estimated, Span<const Eigen::Isometry3d> ground_truth,
                 const char* estimated_name, const char* ground_truth_name) {
  if (estimated.size() != ground_truth.size()) {
    return InvalidArgument(std::string("inter-robot alignment: ") + estimated_name + " has " +
                           std::to_string(estimated.size()) + " poses but " + ground_truth_name + " has " +
                           std::to_string(ground_truth.size()) + " (they must correspond one to one)");
  }
  if (Status s = CheckPoses(estimated, estimated_name); !s.ok()) return s;
  return CheckPoses(ground_truth, ground_truth_name);
}

}  // namespace

std::vector<Eigen::Vector3d> AlignmentPoints(Span<const Eigen::Isometry3d> poses, bool with_axes, double offset_m) {
  std::vector<Eigen::Vector3d> points;
  points.reserve(poses.size() * (with_axes ? 3 : 1));
  for (const Eigen::Isometry3d& T : poses) {
    points.push_back(T.translation());
    if (with_axes) {
      points.push_back(T.translation() + offset_m * T.linear().col(0));
      points.push_back(T.translation() + offset_m * T.linear().col(1));
    }
  }
  return points;
}

TransformError ComputeTransformError(const Eigen::Isometry3d& T_estimate, const Eigen::Isometry3d& T_reference) {
  TransformError e;
  if (!IsFiniteRigidPart(T_estimate) || !IsFiniteRigidPart(T_reference)) {
    e.translation_m = std::numeric_limits<double>::quiet_NaN();
    e.rotation_deg = std::numeric_limits<double>::quiet_NaN();
    return e;
  }
  e.translation_m = (T_estimate.translation() - T_reference.translation()).norm();
  e.rotation_deg = RotationAngleRad(T_reference.linear().transpose() * T_estimate.linear()) * kRadToDeg;
  return e;
}

Status ValidateInterRobotAlignmentParams(const InterRobotAlignmentParams& params) {
  if (!(params.collinear_ratio >= 0.0 && params.collinear_ratio < 1.0)) {
    return InvalidArgument("inter-robot alignment: collinear_ratio must be in [0, 1), got " +
                           FormatNumber(params.collinear_ratio, 6));
  }
  if (!(params.axis_offset_m > 0.0 && std::isfinite(params.axis_offset_m))) {
    return InvalidArgument("inter-robot alignment: axis_offset_m must be finite and > 0, got " +
                           FormatNumber(params.axis_offset_m, 6));
  }
  return Status::Ok();
}

Result<InterRobotAlignment> InterRobotAlignmentRmse(Span<const Eigen::Isometry3d> alpha_estimated,
                                                    Span<const Eigen::Isometry3d> alpha_ground_truth,
                                                    Span<const Eigen::Isometry3d> beta_estimated,
                                                    Span<const Eigen::Isometry3d> beta_ground_truth,
                                                    const Eigen::Isometry3d& T_alpha_beta,
                                                    const InterRobotAlignmentParams& params) {
  if (Status s = ValidateInterRobotAlignmentParams(params); !s.ok()) return s;
  if (Status s = CheckPair(alpha_estimated, alpha_ground_truth, "alpha_estimated", "alpha_ground_truth"); !s.ok()) {
    return s;
  }
  if (Status s = CheckPair(beta_estimated, beta_ground_truth, "beta_estimated", "beta_ground_truth"); !s.ok()) {
    return s;
  }
  if (!IsFiniteRigidPart(T_alpha_beta)) {
    return InvalidArgument("inter-robot alignment: T_alpha_beta has a non-finite entry");
  }

  InterRobotAlignment out;
  UmeyamaParams umeyama;
  umeyama.degenerate_ratio = params.collinear_ratio;
  const std::vector<Eigen::Vector3d> alpha_est_positions = AlignmentPoints(alpha_estimated, false, 0.0);
  const std::vector<Eigen::Vector3d> alpha_gt_positions = AlignmentPoints(alpha_ground_truth, false, 0.0);
  Result<UmeyamaResult> fit = Umeyama(alpha_est_positions, alpha_gt_positions, umeyama);
  if (!fit.ok()) {
    // Every other failure was ruled out above: the positions are collinear (or coincident). The axis points
    // p + d R e_x, p + d R e_y are never collinear with p, so the orientations determine the rotation.
    out.used_orientations = true;
    const std::vector<Eigen::Vector3d> est = AlignmentPoints(alpha_estimated, true, params.axis_offset_m);
    const std::vector<Eigen::Vector3d> gt = AlignmentPoints(alpha_ground_truth, true, params.axis_offset_m);
    fit = Umeyama(est, gt, UmeyamaParams{});
    if (!fit.ok()) {
      return InvalidArgument("inter-robot alignment: alpha's trajectory is degenerate even with its orientations (" +
                             fit.status().message() + ")");
    }
  }
  out.T_gt_alpha = fit->T_target_source;
  out.alpha_rmse_m = AlignmentRmseM(alpha_est_positions, alpha_gt_positions, out.T_gt_alpha);

  const Eigen::Isometry3d T_gt_beta = out.T_gt_alpha * T_alpha_beta;
  double sum_sq = 0.0;
  double max_error = 0.0;
  for (std::size_t j = 0; j < beta_estimated.size(); ++j) {
    const double e = (T_gt_beta * beta_estimated[j].translation() - beta_ground_truth[j].translation()).norm();
    sum_sq += e * e;
    max_error = std::max(max_error, e);
  }
  out.count = beta_estimated.size();
  out.rmse_m = std::sqrt(sum_sq / static_cast<double>(out.count));
  out.max_error_m = max_error;
  return out;
}

}  // namespace commerge
