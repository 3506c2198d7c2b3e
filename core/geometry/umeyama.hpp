// SPDX-License-Identifier: BSD-3-Clause
// commerge: closed-form alignment of corresponding point sets (Umeyama 1991 / Kabsch), rigid by default,
// optionally with a uniform scale.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct UmeyamaParams {
  /// Also estimate a uniform scale s (target ~= s R source + t). Off: rigid alignment (s = 1).
  bool estimate_scale = false;
  /// The sets are degenerate (rotation not unique: all points coincident or on one line) when the second
  /// singular value of the cross-covariance is below this fraction of the first.
  double degenerate_ratio = 1e-10;
};

struct UmeyamaResult {
  /// Rigid part: target_i ~= scale * (R * source_i) + t, stored as T_target_source = [R t; 0 1].
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  double scale = 1.0;  ///< 1 unless UmeyamaParams::estimate_scale
  double rmse_m = 0.0;  ///< sqrt(mean ||target_i - (scale R source_i + t)||^2) [m]
};

/// Least-squares alignment minimising sum_i ||target_i - (s R source_i + t)||^2 over R in SO(3), t (and s > 0
/// when requested), by SVD of the cross-covariance with the reflection fix. source[i] corresponds to
/// target[i]. Errors (invalid argument): sizes differ; fewer than 3 pairs; a non-finite coordinate;
/// degenerate sets (coincident or collinear points, see UmeyamaParams::degenerate_ratio).
Result<UmeyamaResult> Umeyama(Span<const Eigen::Vector3d> source, Span<const Eigen::Vector3d> target,
                              const UmeyamaParams& params = {});

/// Rigid alignment: T_target_source minimising sum_i ||target_i - T_target_source * source_i||^2.
/// Same errors as Umeyama().
Result<Eigen::Isometry3d> AlignRigid(Span<const Eigen::Vector3d> source, Span<const Eigen::Vector3d> target);

/// sqrt(mean_i ||target_i - T_target_source * source_i||^2) [m]; NaN when the sizes differ or are 0.
double AlignmentRmseM(Span<const Eigen::Vector3d> source, Span<const Eigen::Vector3d> target,
                      const Eigen::Isometry3d& T_target_source);

}  // namespace commerge
