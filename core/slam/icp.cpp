// SPDX-License-Identifier: BSD-3-Clause
#include "core/slam/icp.hpp"

#include <cmath>
#include <string>

#include "core/geometry/se3.hpp"
#include "core/geometry/umeyama.hpp"

namespace commerge {


void PointToPointIcp::SetTarget(Span<const PointXYZI> target) {
  target_ = target;
  tree_.Build(target);
}

Result<IcpResult> PointToPointIcp::Align(Span<const PointXYZI> source, const Eigen::Isometry3d& guess,
                                         const IcpParams& params) {
  if (!(params.max_correspondence_distance_m > 0.0) || params.max_iterations < 1) {
    return InvalidArgument("icp: max_correspondence_distance_m must be > 0 and max_iterations >= 1, got " +
                           std::to_string(params.max_correspondence_distance_m) + " and " +
                           std::to_string(params.max_iterations));
  }
  if (source.empty() || target_.empty()) {
    return InvalidArgument("icp: empty cloud (source " + std::to_string(source.size()) + " points, target " +
                           std::to_string(target_.size()) + " points)");
  }
  if (!guess.matrix().allFinite()) return InvalidArgument("icp: the initial guess is not finite");

  const double gate_sq = params.max_correspondence_distance_m * params.max_correspondence_distance_m;
  IcpResult r;
  r.T_target_source = guess;
  src_scratch_.reserve(source.size());
  dst_scratch_.reserve(source.size());

  // Pairs the warped source with its nearest targets inside the gate; returns the mean squared residual.
  auto correspond = [&](const Eigen::Isometry3d& T) {
    src_scratch_.clear();
    dst_scratch_.clear();
    double sum_sq = 0.0;
    for (const PointXYZI& p : source) {
      const Eigen::Vector3d ps(static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z));
      const Eigen::Vector3d q = T * ps;
      std::uint32_t j = 0;
      float d2 = 0.0f;
      if (!tree_.Nearest(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), &j, &d2)) {
        continue;
      }
      const PointXYZI& t = target_[j];
      const Eigen::Vector3d pt(static_cast<double>(t.x), static_cast<double>(t.y), static_cast<double>(t.z));
      const double e2 = (q - pt).squaredNorm();
      if (!(e2 <= gate_sq)) continue;
      src_scratch_.push_back(ps);
      dst_scratch_.push_back(pt);
      sum_sq += e2;
    }
    return src_scratch_.empty() ? 0.0 : sum_sq / static_cast<double>(src_scratch_.size());
  };

  for (r.iterations = 1; r.iterations <= params.max_iterations; ++r.iterations) {
    correspond(r.T_target_source);
    if (src_scratch_.size() < std::max<std::size_t>(params.min_inliers, 3)) break;
    auto step = AlignRigid(Span<const Eigen::Vector3d>(src_scratch_), Span<const Eigen::Vector3d>(dst_scratch_));
    if (!step.ok()) break;  // degenerate correspondences (collinear): keep the last estimate
    const Eigen::Isometry3d T_new = *step;
    const Eigen::Isometry3d delta = r.T_target_source.inverse() * T_new;
    r.T_target_source = T_new;
    const double dt = delta.translation().norm();
    const double dr = Eigen::AngleAxisd(delta.linear()).angle();
    if (dt < params.convergence_translation_m && dr < params.convergence_rotation_rad) {
      r.converged = true;
      break;
    }
  }
  if (r.iterations > params.max_iterations) r.iterations = params.max_iterations;

  // Final correspondences at the returned transform: residual, inlier count and information.
  r.mean_squared_residual_m2 = correspond(r.T_target_source);
  r.num_inliers = src_scratch_.size();
  r.inlier_ratio = static_cast<double>(r.num_inliers) / static_cast<double>(source.size());
  if (r.num_inliers < params.min_inliers) r.converged = false;
  if (r.num_inliers > 0) {
    const double sigma2 = std::max(r.mean_squared_residual_m2 / 3.0, 1e-6);
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    for (const Eigen::Vector3d& ps : src_scratch_) {
      Eigen::Matrix<double, 3, 6> J;
      J.leftCols<3>().setIdentity();
      J.rightCols<3>() = -Skew(ps);  // d(T Exp(delta) p)/d(delta) = R [I, -[p]x]; R cancels in J^T J
      H += J.transpose() * J;
    }
    r.hessian = H / sigma2;
  }
  return r;
}

}  // namespace commerge
