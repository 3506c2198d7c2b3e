// SPDX-License-Identifier: BSD-3-Clause
// commerge: point-to-point ICP, the geometric check of intra-robot loop candidates (paper, Eq. "icp" and
// "icp-accept"): nearest neighbours by k-d tree, inliers by a distance gate, closed-form (Kabsch) update.
#pragma once

#include <Eigen/Geometry>

#include <cstddef>
#include <vector>

#include "core/cloud/kd_tree.hpp"
#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct IcpParams {
  int max_iterations = 40;
  /// Correspondences farther apart than this are outliers [m] (1 m voxels: a few voxels).
  double max_correspondence_distance_m = 2.0;
  /// Stop when an iteration moves less than both of these.
  double convergence_translation_m = 1e-3;
  double convergence_rotation_rad = 1e-4;
  /// Fewer inliers than this: the alignment is not trusted.
  std::size_t min_inliers = 50;
};

struct IcpResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  int iterations = 0;
  bool converged = false;
  std::size_t num_inliers = 0;
  /// Mean squared inlier residual after the final update [m^2] (the paper's epsilon^ICP).
  double mean_squared_residual_m2 = 0.0;
  /// Inliers / source points.
  double inlier_ratio = 0.0;
  /// Gauss-Newton information of the estimate for a right perturbation T ExpSE3(delta), delta = [translation;
  /// rotation] (core/geometry/se3's twist order): sum over inliers of J^T J / sigma^2 with J = [I, -[p_source]x]
  /// and sigma^2 = the mean squared residual per coordinate. It treats the inliers as independent, so it is
  /// optimistic.
  Eigen::Matrix<double, 6, 6> hessian = Eigen::Matrix<double, 6, 6>::Zero();
};

/// Reusable ICP: keeps the target's k-d tree and scratch buffers between calls.
class PointToPointIcp {
 public:
  /// Indexes `target` (kept by reference until the next SetTarget).
  void SetTarget(Span<const PointXYZI> target);

  /// Aligns `source` to the target from `T_target_source_guess`. Errors: invalid parameters, empty clouds.
  /// A failed alignment (too few inliers) is a result with converged = false, not an error.
  Result<IcpResult> Align(Span<const PointXYZI> source, const Eigen::Isometry3d& T_target_source_guess,
                          const IcpParams& params);

  /// Bytes held: the target's k-d tree and the scratch buffers (their capacities).
  std::size_t workspace_bytes() const {
    return tree_.memory_bytes() + (src_scratch_.capacity() + dst_scratch_.capacity()) * sizeof(Eigen::Vector3d);
  }

 private:
  Span<const PointXYZI> target_;
  KdTree3 tree_;
  std::vector<Eigen::Vector3d> src_scratch_, dst_scratch_;
};

}  // namespace commerge
