// SPDX-License-Identifier: BSD-3-Clause
// Umeyama, "Least-squares estimation of transformation parameters between two point patterns", PAMI 1991:
// centre both sets, SVD of the cross-covariance Sigma = U D V^T, R = U S V^T with S = diag(1, 1, +-1) chosen
// so that det R = +1, s = tr(D S) / var(source), t = mu_target - s R mu_source.
#include "core/geometry/umeyama.hpp"

#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>

#include "core/common/number_text.hpp"

namespace commerge {
namespace {

}  // namespace

Result<UmeyamaResult> Umeyama(Span<const Eigen::Vector3d> source, Span<const Eigen::Vector3d> target,
                              const UmeyamaParams& params) {
  if (source.size() != target.size()) {
    return InvalidArgument("umeyama: " + std::to_string(source.size()) + " source points but " +
                           std::to_string(target.size()) + " target points (they must correspond one to one)");
  }
  const std::size_t n = source.size();
  if (n < 3) return InvalidArgument("umeyama: " + std::to_string(n) + " point pairs, at least 3 are needed");
  if (!(params.degenerate_ratio >= 0.0 && params.degenerate_ratio < 1.0)) {
    return InvalidArgument("umeyama: degenerate_ratio must be in [0, 1), got " +
                           FormatNumber(params.degenerate_ratio, 6));
  }
  Eigen::Vector3d mu_source = Eigen::Vector3d::Zero();
  Eigen::Vector3d mu_target = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    if (!source[i].allFinite() || !target[i].allFinite()) {
      return InvalidArgument("umeyama: point pair " + std::to_string(i) + " has a non-finite coordinate");
    }
    mu_source += source[i];
    mu_target += target[i];
  }
  const double inv_n = 1.0 / static_cast<double>(n);
  mu_source *= inv_n;
  mu_target *= inv_n;

  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();  // cross-covariance, target x source
  double var_source = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d s = source[i] - mu_source;
    sigma.noalias() += (target[i] - mu_target) * s.transpose();
    var_source += s.squaredNorm();
  }
  sigma *= inv_n;
  var_source *= inv_n;

  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  const Eigen::Vector3d d = svd.singularValues();
  if (!(d(0) > 0.0) || d(1) <= params.degenerate_ratio * d(0)) {
    return InvalidArgument("umeyama: degenerate point sets (all points coincident or on one line: singular values " +
                           FormatNumber(d(0), 6) + ", " + FormatNumber(d(1), 6) + ", " + FormatNumber(d(2), 6) +
                           "), the rotation is not unique");
  }
  Eigen::Vector3d s_diag(1.0, 1.0, 1.0);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) s_diag(2) = -1.0;  // no reflection

  UmeyamaResult result;
  const Eigen::Matrix3d R = svd.matrixU() * s_diag.asDiagonal() * svd.matrixV().transpose();
  result.scale = params.estimate_scale ? d.dot(s_diag) / var_source : 1.0;
  result.T_target_source.linear() = R;
  result.T_target_source.translation() = mu_target - result.scale * (R * mu_source);

  double sum_sq = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    sum_sq += (target[i] - (result.scale * (R * source[i]) + result.T_target_source.translation())).squaredNorm();
  }
  result.rmse_m = std::sqrt(sum_sq * inv_n);
  return result;
}

Result<Eigen::Isometry3d> AlignRigid(Span<const Eigen::Vector3d> source, Span<const Eigen::Vector3d> target) {
  Result<UmeyamaResult> r = Umeyama(source, target, UmeyamaParams{});
  if (!r.ok()) return r.status();
  return r->T_target_source;
}

double AlignmentRmseM(Span<const Eigen::Vector3d> source, Span<const Eigen::Vector3d> target,
                      const Eigen::Isometry3d& T_target_source) {
  if (source.size() != target.size() || source.empty()) return std::numeric_limits<double>::quiet_NaN();
  double sum_sq = 0.0;
  for (std::size_t i = 0; i < source.size(); ++i) sum_sq += (target[i] - T_target_source * source[i]).squaredNorm();
  return std::sqrt(sum_sq / static_cast<double>(source.size()));
}

}  // namespace commerge
