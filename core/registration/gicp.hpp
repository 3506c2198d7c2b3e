// SPDX-License-Identifier: BSD-3-Clause
// commerge: fine registration by generalized ICP (../shared/spec/REGISTRATION.md §2 "GICP (fine), small_gicp style";
// Segal et al. 2009, small_gicp-style plane-regularised covariances), with point-to-plane ICP as an alternative factor
// on the same Levenberg-Marquardt optimiser.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/status.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/registration/submap_features.hpp"

namespace commerge {

enum class FineFactor {
  kGicp,          ///< r^T (C_t + R C_s R^T)^-1 r (spec §2.2)
  kPointToPlane,  ///< (n_t^T r)^2 with the target normal (paper table: "KISS-Matcher + Plane-ICP")
};

struct GicpParams {
  FineFactor factor = FineFactor::kGicp;
  /// Correspondences farther apart are dropped (spec §2.4: 5 x voxel size) [m].
  double max_correspondence_distance_m = 5.0;
  /// Outer iterations per phase; correspondences are searched again in each (spec 20).
  int max_iterations = 20;
  /// Levenberg-Marquardt trials per outer iteration (spec 10), initial damping and its factor.
  int max_inner_iterations = 10;
  double initial_lambda = 1e-3;
  double lambda_factor = 10.0;
  /// Converged when an accepted step rotates by <= rotation_eps_rad and moves by <= translation_eps_m.
  double rotation_eps_rad = 0.1 * kPi / 180.0;
  double translation_eps_m = 1e-3;
  /// Two phases (ours, not small_gicp's): first with max_correspondence_distance_m (wide basin; steps below 10x
  /// the thresholds count as converged), then with this tighter gate so that pairs without a true counterpart
  /// (parts seen by one submap only) stop pulling the result; `converged` is the second phase's [m]. 0 disables
  /// the second phase (core/agent/decisions/017-gicp-refinement-phase.md).
  double refine_correspondence_distance_m = 1.5;
  /// The wide-gate phase uses every coarse_phase_stride-th source point (1 = all): it only has to reach the
  /// basin; the refinement phase and the final evaluation use every point.
  int coarse_phase_stride = 2;
  /// A final correspondence is an inlier (overlap, fitness) when it is closer than inlier_distance_m [m] and,
  /// where the target point has a normal, its point-to-plane distance is <= inlier_plane_distance_m [m] and
  /// |cos| of the angle between the two normals is >= inlier_normal_cos.
  double inlier_distance_m = 1.0;
  double inlier_plane_distance_m = 0.3;
  double inlier_normal_cos = 0.7071;
};

/// InvalidArgument naming the first field out of range.
Status ValidateGicpParams(const GicpParams& params);

struct GicpResult {
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  bool converged = false;
  int iterations = 0;                 ///< outer iterations run
  std::size_t num_correspondences = 0;  ///< final pairs within the last phase's gate
  std::size_t num_inliers = 0;        ///< final pairs passing the inlier test (GicpParams::inlier_*)
  double inlier_rmse_m = 0.0;         ///< RMS distance of those inliers [m]
  double error = 0.0;                 ///< final 1/2 sum r^T M r over the correspondences
  /// Information (Gauss-Newton Hessian J^T M J) at the result, for the right perturbation T * ExpSE3(xi), rows
  /// and columns in core/geometry/se3's twist order xi = [translation v [m]; rotation omega [rad]] (at xi = 0 the
  /// same as the step T * [ExpSO3(omega), v] the optimiser applies).
  Matrix6d H = Matrix6d::Zero();
  /// Gradient J^T M r at the result (r = target point - transformed source point), same order [v; omega].
  Vector6d b = Vector6d::Zero();
  /// Share, per principal direction of the source normals, of the normal "mass" carried by the inliers;
  /// the minimum over the directions holding >= 2 % of the mass. Near 0: the inliers leave a direction that the
  /// source constrains unexplained (e.g. only the ground matches).
  double directional_overlap = 0.0;
};

/// Reusable GICP (keeps per-point scratch between calls). Not thread-safe.
class Gicp {
 public:
  /// Aligns `source` to `target` (both prepared with SubmapFeatures::ComputeGeometry) from
  /// `T_target_source_guess`. `params` must be valid; the guess must be finite.
  GicpResult Align(const SubmapFeatures& source, const SubmapFeatures& target,
                   const Eigen::Isometry3d& T_target_source_guess, const GicpParams& params);

  /// Bytes held by the per-correspondence scratch (capacity).
  std::size_t workspace_bytes() const noexcept { return factors_.capacity() * sizeof(Factor); }

 private:
  struct Factor {
    std::uint32_t source;
    std::uint32_t target;
    Eigen::Matrix3d M;
  };
  std::vector<Factor> factors_;
};

}  // namespace commerge
