// SPDX-License-Identifier: BSD-3-Clause
// GNC-TLS rotation and per-axis adaptive-voting translation (../shared/spec/REGISTRATION.md §1.2 "Pipeline", steps
// 11-12; Yang et al., "Graduated Non-Convexity for Robust Spatial Perception", RA-L 2020).
#include "core/registration/robust_solver.hpp"

#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace commerge {
namespace {

// argmax_R sum_k w_k y_k^T R x_k over SO(3) (no centring): SVD of H = sum w x y^T = U S V^T,
// R = V diag(1, 1, det(V U^T)) U^T.
Eigen::Matrix3d WeightedKabsch(Span<const Eigen::Vector3d> x, Span<const Eigen::Vector3d> y,
                               const std::vector<double>& w) {
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < x.size(); ++k) h.noalias() += w[k] * x[k] * y[k].transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Matrix3d u = svd.matrixU();
  const Eigen::Matrix3d v = svd.matrixV();
  Eigen::Vector3d d(1.0, 1.0, (v * u.transpose()).determinant() < 0.0 ? -1.0 : 1.0);
  return v * d.asDiagonal() * u.transpose();
}

}  // namespace

Status ValidateRobustSolverParams(const RobustSolverParams& p) {
  if (!(std::isfinite(p.noise_bound_m) && p.noise_bound_m > 0.0)) {
    return InvalidArgument("registration solver: noise_bound_m must be finite and > 0");
  }
  if (!(std::isfinite(p.rotation_bound_factor) && p.rotation_bound_factor > 0.0)) {
    return InvalidArgument("registration solver: rotation_bound_factor must be finite and > 0");
  }
  if (!(p.gnc_factor > 1.0 && std::isfinite(p.gnc_factor))) {
    return InvalidArgument("registration solver: gnc_factor must be finite and > 1");
  }
  if (p.max_iterations < 1 || p.max_iterations > 10000) {
    return InvalidArgument("registration solver: max_iterations must be in [1, 10000]");
  }
  if (!(p.cost_tolerance >= 0.0) || !(p.inlier_weight > 0.0 && p.inlier_weight <= 1.0)) {
    return InvalidArgument("registration solver: cost_tolerance must be >= 0 and inlier_weight in (0, 1]");
  }
  return Status::Ok();
}

RotationGncResult EstimateRotationGncTls(Span<const Eigen::Vector3d> x, Span<const Eigen::Vector3d> y,
                                         double noise_bound_c_m, const RobustSolverParams& params,
                                         std::vector<double>* weights_out) {
  RotationGncResult r;
  const std::size_t n = x.size();
  if (n == 0 || y.size() != n) return r;
  std::vector<double> w(n, 1.0), r2(n, 0.0);
  const double c2 = noise_bound_c_m * noise_bound_c_m;
  double mu = 1.0;
  double prev_cost = std::numeric_limits<double>::infinity();
  for (int it = 0; it < params.max_iterations; ++it) {
    r.iterations = it + 1;
    r.R = WeightedKabsch(x, y, w);
    for (std::size_t k = 0; k < n; ++k) r2[k] = (y[k] - r.R * x[k]).squaredNorm();
    if (it == 0) {
      const double max_r2 = *std::max_element(r2.begin(), r2.end());
      mu = 1.0 / (2.0 * max_r2 / c2 - 1.0);
      if (!(mu > 0.0)) break;  // every residual is already small: all inliers, weights stay 1
    }
    // Closed-form TLS weights for the surrogate at mu (the cost uses the weights of the previous step).
    const double th_out = (mu + 1.0) / mu * c2;
    const double th_in = mu / (mu + 1.0) * c2;
    double cost = 0.0;
    for (std::size_t k = 0; k < n; ++k) {
      cost += w[k] * r2[k];
      if (r2[k] >= th_out) {
        w[k] = 0.0;
      } else if (r2[k] <= th_in) {
        w[k] = 1.0;
      } else {
        w[k] = std::sqrt(c2 * mu * (mu + 1.0) / r2[k]) - mu;
      }
    }
    if (std::fabs(cost - prev_cost) < params.cost_tolerance) break;
    prev_cost = cost;
    mu *= params.gnc_factor;
  }
  for (double wk : w) r.num_inliers += wk >= params.inlier_weight;
  r.valid = r.num_inliers >= 2 && r.R.allFinite();
  if (weights_out) *weights_out = std::move(w);
  return r;
}

double EstimateScalarTls(Span<const double> values, double bound, std::vector<std::uint8_t>* inlier) {
  const std::size_t n = values.size();
  if (inlier) inlier->assign(n, 0);
  if (n == 0) return std::numeric_limits<double>::quiet_NaN();
  // Interval ends: (value, +1) opens, (value, -1) closes; at equal values openings come first (closed intervals).
  std::vector<std::pair<double, int>> ends;
  ends.reserve(2 * n);
  for (std::size_t k = 0; k < n; ++k) {
    ends.emplace_back(values[k] - bound, static_cast<int>(k) + 1);
    ends.emplace_back(values[k] + bound, -(static_cast<int>(k) + 1));
  }
  std::sort(ends.begin(), ends.end(), [](const std::pair<double, int>& a, const std::pair<double, int>& b) {
    if (a.first != b.first) return a.first < b.first;
    if ((a.second > 0) != (b.second > 0)) return a.second > 0;
    return a.second < b.second;
  });
  double sum = 0.0, sum_sq = 0.0;
  std::size_t count = 0;
  double best_cost = std::numeric_limits<double>::infinity();
  double best_mean = values[0];
  for (const auto& e : ends) {
    const double v = values[static_cast<std::size_t>(std::abs(e.second) - 1)];
    if (e.second > 0) {
      sum += v, sum_sq += v * v, ++count;
      const double mean = sum / static_cast<double>(count);
      const double cost = std::max(0.0, sum_sq - sum * mean) + static_cast<double>(n - count) * bound;
      if (cost < best_cost) best_cost = cost, best_mean = mean;
    } else {
      sum -= v, sum_sq -= v * v, --count;
    }
  }
  if (inlier) {
    for (std::size_t k = 0; k < n; ++k) (*inlier)[k] = std::fabs(values[k] - best_mean) <= bound;
  }
  return best_mean;
}

RobustRegistrationResult SolveRobustRegistration(Span<const Eigen::Vector3d> a, Span<const Eigen::Vector3d> b,
                                                 const RobustSolverParams& params) {
  RobustRegistrationResult out;
  const std::size_t n = a.size();
  out.final_inlier.assign(n, 0);
  if (n < 3 || b.size() != n) return out;
  std::vector<Eigen::Vector3d> x(n), y(n);
  for (std::size_t k = 0; k < n; ++k) {
    const std::size_t next = (k + 1) % n;
    x[k] = a[next] - a[k];
    y[k] = b[next] - b[k];
  }
  const RotationGncResult rot =
      EstimateRotationGncTls(x, y, params.rotation_bound_factor * params.noise_bound_m, params);
  out.num_rotation_inliers = rot.num_inliers;
  out.gnc_iterations = rot.iterations;
  if (!rot.valid) return out;

  std::vector<double> t[3];
  for (auto& axis : t) axis.resize(n);
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d tk = b[k] - rot.R * a[k];
    t[0][k] = tk.x(), t[1][k] = tk.y(), t[2][k] = tk.z();
  }
  Eigen::Vector3d translation;
  std::vector<std::uint8_t> axis_inlier;
  for (int axis = 0; axis < 3; ++axis) {
    translation(axis) = EstimateScalarTls(t[axis], params.noise_bound_m, &axis_inlier);
    for (std::size_t k = 0; k < n; ++k) out.final_inlier[k] = (axis == 0 ? 1 : out.final_inlier[k]) & axis_inlier[k];
  }
  for (std::uint8_t f : out.final_inlier) out.num_final_inliers += f;
  out.T_target_source.setIdentity();
  out.T_target_source.linear() = rot.R;
  out.T_target_source.translation() = translation;
  out.valid = rot.valid && out.num_final_inliers >= 1 && translation.allFinite();
  return out;
}

}  // namespace commerge
