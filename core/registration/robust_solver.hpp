// SPDX-License-Identifier: BSD-3-Clause
// commerge: robust rigid fit on pruned correspondences (../shared/spec/REGISTRATION.md §1.2 "Pipeline", steps 11-12):
// rotation by graduated non-convexity with a truncated-least-squares cost (GNC-TLS) on translation-invariant chained
// measurements, then translation by per-axis adaptive voting (truncated least squares in 1-D).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct RobustSolverParams {
  /// epsilon_S [m]: measurement noise bound (spec 0.75 x voxel, <= 1 m). Translation TLS bound beta = this.
  double noise_bound_m = 0.75;
  /// GNC rotation bound c = rotation_bound_factor x noise_bound_m (spec 2: chained differences double it).
  double rotation_bound_factor = 2.0;
  /// mu grows by this factor per iteration (spec 1.4).
  double gnc_factor = 1.4;
  int max_iterations = 100;
  /// Stop when the TLS cost changes by less than this.
  double cost_tolerance = 1e-6;
  /// A measurement is a rotation inlier when its final weight is >= this.
  double inlier_weight = 0.5;
};

/// InvalidArgument naming the first field out of range.
Status ValidateRobustSolverParams(const RobustSolverParams& params);

struct RotationGncResult {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  int iterations = 0;
  std::size_t num_inliers = 0;  ///< measurements with weight >= inlier_weight
  bool valid = false;           ///< >= 2 inliers and a finite rotation
};

/// GNC-TLS rotation from measurement pairs y_k ~ R x_k (no translation): weighted Kabsch without centring
/// (SVD with the reflection fix), TLS weights with bound c = noise_bound_c_m, mu from 1 / (2 max r^2 / c^2 - 1)
/// growing by gnc_factor. `weights` (optional) receives the final weights. Sizes must match.
RotationGncResult EstimateRotationGncTls(Span<const Eigen::Vector3d> x, Span<const Eigen::Vector3d> y,
                                         double noise_bound_c_m, const RobustSolverParams& params,
                                         std::vector<double>* weights = nullptr);

/// 1-D truncated least squares by adaptive voting: among the consensus sets of the intervals
/// [v_k - bound, v_k + bound] the one minimising sum_in (v_k - mean)^2 + (#out) x bound wins (the reference
/// charges `bound`, not bound^2, per outlier; kept for parity). Returns its mean; *inlier[k] = 1 when
/// |v_k - mean| <= bound (optional). NaN for empty input. Ties: the smallest value wins (deterministic).
double EstimateScalarTls(Span<const double> values, double bound, std::vector<std::uint8_t>* inlier = nullptr);

struct RobustRegistrationResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  std::size_t num_rotation_inliers = 0;
  std::size_t num_final_inliers = 0;   ///< translation inliers on all three axes
  int gnc_iterations = 0;
  bool valid = false;                  ///< >= 2 rotation inliers and >= 1 final inlier
  std::vector<std::uint8_t> final_inlier;  ///< per correspondence
};

/// Robust fit of b_k ~ R a_k + t (spec steps 11-12): rotation from the cyclic chained differences
/// x_k = a_{k+1} - a_k, y_k = b_{k+1} - b_k (so the input order matters: spatially scattered orders give
/// long, well-conditioned baselines), translation per axis over all correspondences with t_k = b_k - R a_k.
/// Sizes must match; fewer than 3 correspondences give an invalid result.
RobustRegistrationResult SolveRobustRegistration(Span<const Eigen::Vector3d> a, Span<const Eigen::Vector3d> b,
                                                 const RobustSolverParams& params);

}  // namespace commerge
