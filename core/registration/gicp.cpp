// SPDX-License-Identifier: BSD-3-Clause
// GICP / point-to-plane ICP with Levenberg-Marquardt (../shared/spec/REGISTRATION.md §2.2 "Factor and optimiser"):
// correspondences and their information M are fixed during the inner LM trials and searched again at every outer
// iteration.
#include "core/registration/gicp.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

namespace commerge {
namespace {

inline Eigen::Vector3d PositionD(const PointXYZI& p) {
  return {static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z)};
}

// T * [ExpSO3(omega), v] with delta = [v; omega] (translation first, the order of core/geometry/se3's twists):
// the right perturbation the Jacobian below is written for.
Eigen::Isometry3d Perturb(const Eigen::Isometry3d& T, const Vector6d& delta) {
  Eigen::Isometry3d d = Eigen::Isometry3d::Identity();
  d.linear() = ExpSO3(delta.tail<3>());
  d.translation() = delta.head<3>();
  Eigen::Isometry3d out = T * d;
  // Keep the rotation orthonormal over many compositions.
  Eigen::Quaterniond q(out.linear());
  out.linear() = q.normalized().toRotationMatrix();
  return out;
}

// [v; omega] <-> [omega; v]: the Levenberg-Marquardt step is solved rotation first. LDLT pivots on the largest
// diagonal entry and its rounding depends on where rows and columns sit, so a fixed order keeps results
// reproducible; rotation first is the order the registration gates and tests were calibrated with.
Matrix6d RotationFirst(const Matrix6d& A) {
  Matrix6d out;
  out << A.bottomRightCorner<3, 3>(), A.bottomLeftCorner<3, 3>(), A.topRightCorner<3, 3>(), A.topLeftCorner<3, 3>();
  return out;
}
Vector6d SwapHalves(const Vector6d& v) {
  Vector6d out;
  out << v.tail<3>(), v.head<3>();
  return out;
}

}  // namespace

Status ValidateGicpParams(const GicpParams& p) {
  if (!(std::isfinite(p.max_correspondence_distance_m) && p.max_correspondence_distance_m > 0.0)) {
    return InvalidArgument("registration gicp: max_correspondence_distance_m must be finite and > 0");
  }
  if (p.max_iterations < 1 || p.max_iterations > 1000 || p.max_inner_iterations < 1 || p.max_inner_iterations > 100) {
    return InvalidArgument("registration gicp: max_iterations must be in [1, 1000], max_inner_iterations in [1, 100]");
  }
  if (!(p.initial_lambda > 0.0 && std::isfinite(p.initial_lambda)) || !(p.lambda_factor > 1.0 && std::isfinite(p.lambda_factor))) {
    return InvalidArgument("registration gicp: initial_lambda must be > 0 and lambda_factor > 1");
  }
  if (!(p.rotation_eps_rad > 0.0) || !(p.translation_eps_m > 0.0)) {
    return InvalidArgument("registration gicp: rotation_eps_rad and translation_eps_m must be > 0");
  }
  if (!(std::isfinite(p.inlier_distance_m) && p.inlier_distance_m > 0.0) ||
      !(std::isfinite(p.inlier_plane_distance_m) && p.inlier_plane_distance_m > 0.0)) {
    return InvalidArgument("registration gicp: inlier_distance_m and inlier_plane_distance_m must be finite and > 0");
  }
  if (!(p.inlier_normal_cos >= 0.0 && p.inlier_normal_cos <= 1.0)) {
    return InvalidArgument("registration gicp: inlier_normal_cos must be in [0, 1]");
  }
  if (!(std::isfinite(p.refine_correspondence_distance_m) && p.refine_correspondence_distance_m >= 0.0)) {
    return InvalidArgument("registration gicp: refine_correspondence_distance_m must be finite and >= 0");
  }
  if (p.coarse_phase_stride < 1 || p.coarse_phase_stride > 64) {
    return InvalidArgument("registration gicp: coarse_phase_stride must be in [1, 64]");
  }
  return Status::Ok();
}

GicpResult Gicp::Align(const SubmapFeatures& source, const SubmapFeatures& target,
                       const Eigen::Isometry3d& guess, const GicpParams& params) {
  GicpResult res;
  res.T_target_source = guess;
  const Span<const PointXYZI> src = source.points();
  const Span<const PointXYZI> tgt = target.points();
  if (src.empty() || tgt.empty() || !guess.matrix().allFinite()) return res;
  double max_d2 = params.max_correspondence_distance_m * params.max_correspondence_distance_m;
  const bool plane = params.factor == FineFactor::kPointToPlane;
  const auto& cov_s = source.covariances();
  const auto& cov_t = target.covariances();
  const auto& normal_t = target.normals();
  const auto& normal_t_valid = target.normal_valid();
  factors_.reserve(src.size());

  std::size_t stride = 1;
  // Correspondences at T: factors_, H, b and the error 1/2 sum r^T M r.
  auto linearize = [&](const Eigen::Isometry3d& T, Matrix6d* H, Vector6d* b) {
    factors_.clear();
    H->setZero();
    b->setZero();
    double e = 0.0;
    const Eigen::Matrix3d R = T.linear();
    for (std::size_t i = 0; i < src.size(); i += stride) {
      const Eigen::Vector3d p = PositionD(src[i]);
      const Eigen::Vector3d q = T * p;
      std::uint32_t j = 0;
      float d2 = 0.0f;
      if (!target.tree().Nearest(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), &j,
                                 &d2)) {
        continue;
      }
      if (!(static_cast<double>(d2) <= max_d2)) continue;
      Eigen::Matrix3d M;
      if (plane) {
        if (!normal_t_valid[j]) continue;
        const Eigen::Vector3d n = normal_t[j].cast<double>();
        M = n * n.transpose();
      } else {
        M = (cov_t[j] + R * cov_s[i] * R.transpose()).inverse();
      }
      const Eigen::Vector3d r = PositionD(tgt[j]) - q;
      Eigen::Matrix<double, 3, 6> J;  // d(T [ExpSO3(omega), v] p)/d[v; omega] = [R, -R [p]x], negated for r
      J.leftCols<3>() = -R;
      J.rightCols<3>() = R * Skew(p);
      const Eigen::Matrix<double, 6, 3> JtM = J.transpose() * M;
      H->noalias() += JtM * J;
      b->noalias() += JtM * r;
      e += 0.5 * r.dot(M * r);
      factors_.push_back(Factor{static_cast<std::uint32_t>(i), j, M});
    }
    return e;
  };
  auto evaluate = [&](const Eigen::Isometry3d& T) {
    double e = 0.0;
    for (const Factor& f : factors_) {
      const Eigen::Vector3d r = PositionD(tgt[f.target]) - T * PositionD(src[f.source]);
      e += 0.5 * r.dot(f.M * r);
    }
    return e;
  };

  Eigen::Isometry3d T = guess;
  Matrix6d H;
  Vector6d b;
  // One Levenberg-Marquardt run with the current gate; returns whether it converged (steps below eps_scale x
  // the convergence thresholds).
  auto optimise = [&](int* iterations, double eps_scale) {
    double lambda = params.initial_lambda;
    bool converged = false;
    for (int it = 0; it < params.max_iterations && !converged; ++it) {
      ++*iterations;
      const double e = linearize(T, &H, &b);
      if (factors_.size() < 6) break;  // nothing to optimise: not converged
      const Matrix6d H_rot_first = RotationFirst(H);
      const Vector6d b_rot_first = SwapHalves(b);
      bool accepted = false;
      for (int inner = 0; inner < params.max_inner_iterations; ++inner) {
        const Vector6d delta =
            SwapHalves((H_rot_first + lambda * Matrix6d::Identity()).ldlt().solve(-b_rot_first));  // [v; omega]
        if (!delta.allFinite()) {
          lambda *= params.lambda_factor;
          continue;
        }
        const Eigen::Isometry3d T_new = Perturb(T, delta);
        if (evaluate(T_new) <= e) {
          T = T_new;
          lambda /= params.lambda_factor;
          accepted = true;
          converged = delta.tail<3>().norm() <= eps_scale * params.rotation_eps_rad &&
                      delta.head<3>().norm() <= eps_scale * params.translation_eps_m;
          break;
        }
        lambda *= params.lambda_factor;
      }
      if (!accepted) break;  // LM could not decrease the error: stop, not converged
    }
    return converged;
  };
  const bool refine = params.refine_correspondence_distance_m > 0.0 &&
                      params.refine_correspondence_distance_m < params.max_correspondence_distance_m;
  if (refine) {
    // Wide gate on a subsample, only to reach the basin: 10x looser steps count as converged, and the tight
    // phase runs even when this one stops at its iteration limit (correspondences switching at the 5 m gate
    // can keep the steps above 1 mm); convergence is judged by the tight phase alone.
    stride = static_cast<std::size_t>(params.coarse_phase_stride);
    optimise(&res.iterations, 10.0);
    max_d2 = params.refine_correspondence_distance_m * params.refine_correspondence_distance_m;
    stride = 1;
    res.converged = T.matrix().allFinite() && optimise(&res.iterations, 1.0);
  } else {
    res.converged = optimise(&res.iterations, 1.0);
  }
  res.T_target_source = T;

  // Final correspondences: information, overlap and fitness at the result.
  res.error = linearize(T, &res.H, &res.b);
  res.num_correspondences = factors_.size();
  const double in_d2 = params.inlier_distance_m * params.inlier_distance_m;
  double sum_sq = 0.0;
  Eigen::Matrix3d normals_all = Eigen::Matrix3d::Zero(), normals_in = Eigen::Matrix3d::Zero();
  const auto& normal_s = source.normals();
  const auto& normal_s_valid = source.normal_valid();
  for (std::size_t i = 0; i < src.size(); ++i) {
    if (normal_s_valid[i]) {
      const Eigen::Vector3d n = normal_s[i].cast<double>();
      normals_all.noalias() += n * n.transpose();
    }
  }
  const double plane_d = params.inlier_plane_distance_m;
  const Eigen::Matrix3d R = T.linear();
  for (const Factor& f : factors_) {
    const Eigen::Vector3d r = PositionD(tgt[f.target]) - T * PositionD(src[f.source]);
    const double d2 = r.squaredNorm();
    bool inlier = d2 <= in_d2;
    if (inlier && normal_t_valid[f.target]) {
      const Eigen::Vector3d nt = normal_t[f.target].cast<double>();
      inlier = std::fabs(nt.dot(r)) <= plane_d;
      if (inlier && normal_s_valid[f.source]) {
        inlier = std::fabs(nt.dot(R * normal_s[f.source].cast<double>())) >= params.inlier_normal_cos;
      }
    }
    if (inlier) {
      ++res.num_inliers;
      sum_sq += d2;
      if (normal_s_valid[f.source]) {
        const Eigen::Vector3d n = normal_s[f.source].cast<double>();
        normals_in.noalias() += n * n.transpose();
      }
    }
  }
  res.inlier_rmse_m = res.num_inliers ? std::sqrt(sum_sq / static_cast<double>(res.num_inliers)) : 0.0;
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(normals_all);
  const double total = normals_all.trace();
  double directional = total > 0.0 ? 1.0 : 0.0;
  for (int d = 0; d < 3 && total > 0.0; ++d) {
    const double all = eig.eigenvalues()(d);
    if (!(all >= 0.02 * total)) continue;
    const Eigen::Vector3d e = eig.eigenvectors().col(d);
    directional = std::min(directional, e.dot(normals_in * e) / all);
  }
  res.directional_overlap = directional;
  return res;
}

}  // namespace commerge
