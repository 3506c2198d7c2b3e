// SPDX-License-Identifier: BSD-3-Clause
#include "core/eval/shared_place.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/geometry/se3.hpp"

namespace commerge {

namespace {

constexpr double kRadToDeg = 57.29577951308232;

// Path [m] of `a` at places of `b`.
double PathAtPlacesOf(Span<const Eigen::Isometry3d> a, Span<const Eigen::Isometry3d> b, const SharedPlaceParams& p) {
  const double r2 = p.radius_m * p.radius_m;
  double path = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Eigen::Vector3d pa = a[i].translation();
    const double yaw_a = YawRad(a[i].linear());
    bool near = false;
    for (std::size_t j = 0; j < b.size() && !near; ++j) {
      if ((b[j].translation() - pa).squaredNorm() > r2) continue;
      double d = std::fabs(YawRad(b[j].linear()) - yaw_a) * kRadToDeg;
      if (d > 180.0) d = 360.0 - d;
      near = d <= p.max_heading_deg;
    }
    if (near && i > 0) path += (pa - a[i - 1].translation()).norm();
  }
  return path;
}

}  // namespace

Status ValidateSharedPlaceParams(const SharedPlaceParams& p) {
  if (!(p.radius_m > 0.0) || !std::isfinite(p.radius_m)) return InvalidArgument("shared place radius_m must be > 0");
  if (!(p.max_heading_deg > 0.0) || p.max_heading_deg > 180.0) {
    return InvalidArgument("shared place max_heading_deg must be in (0, 180]");
  }
  if (!(p.min_shared_path_m >= 0.0) || !std::isfinite(p.min_shared_path_m)) {
    return InvalidArgument("shared place min_shared_path_m must be >= 0");
  }
  return Status::Ok();
}

SharedPlace MeasureSharedPlace(Span<const Eigen::Isometry3d> alpha_gt, Span<const Eigen::Isometry3d> beta_gt,
                               const SharedPlaceParams& params) {
  SharedPlace s;
  s.alpha_path_m = PathAtPlacesOf(alpha_gt, beta_gt, params);
  s.beta_path_m = PathAtPlacesOf(beta_gt, alpha_gt, params);
  s.shared = std::min(s.alpha_path_m, s.beta_path_m) >= params.min_shared_path_m &&
             (s.alpha_path_m > 0.0 || params.min_shared_path_m == 0.0);
  return s;
}

std::vector<bool> ReachableFromRobot0(int robots, const std::vector<bool>& shared_pairs) {
  std::vector<bool> reachable(static_cast<std::size_t>(std::max(robots, 0)), false);
  if (robots <= 0) return reachable;
  reachable[0] = true;
  for (bool grew = true; grew;) {
    grew = false;
    std::size_t k = 0;
    for (int a = 0; a < robots; ++a) {
      for (int b = a + 1; b < robots; ++b, ++k) {
        if (k >= shared_pairs.size() || !shared_pairs[k]) continue;
        const std::size_t ia = static_cast<std::size_t>(a), ib = static_cast<std::size_t>(b);
        if (reachable[ia] != reachable[ib]) {
          reachable[ia] = reachable[ib] = true;
          grew = true;
        }
      }
    }
  }
  return reachable;
}

}  // namespace commerge
