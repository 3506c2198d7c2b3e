// SPDX-License-Identifier: BSD-3-Clause
#include "core/slam/ground_up.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include <Eigen/Eigenvalues>

#include "core/geometry/angles.hpp"

namespace commerge {

Status ValidateGroundUpParams(const GroundUpParams& p) {
  auto bad = [](const char* field, double value, const char* range) {
    return InvalidArgument(std::string("ground up: ") + field + " = " + std::to_string(value) + " is outside " + range);
  };
  if (!(p.min_frame_tilt_deg >= 0.0 && p.min_frame_tilt_deg <= 45.0)) return bad("min_frame_tilt_deg", p.min_frame_tilt_deg, "[0, 45]");
  if (!(p.min_range_m >= 0.0 && p.max_range_m > p.min_range_m && std::isfinite(p.max_range_m))) {
    return bad("max_range_m", p.max_range_m, "(min_range_m, inf)");
  }
  if (!(p.percentile >= 0.0 && p.percentile <= 100.0)) return bad("percentile", p.percentile, "[0, 100]");
  if (!(p.band_m > 0.0 && std::isfinite(p.band_m))) return bad("band_m", p.band_m, "(0, inf)");
  if (p.iterations < 1 || p.iterations > 20) return bad("iterations", p.iterations, "[1, 20]");
  if (p.min_points < 3) return bad("min_points", static_cast<double>(p.min_points), "[3, inf)");
  if (!(p.max_lean_deg > 0.0 && p.max_lean_deg < 90.0)) return bad("max_lean_deg", p.max_lean_deg, "(0, 90)");
  if (!(p.max_flatness > 0.0 && p.max_flatness <= 1.0)) return bad("max_flatness", p.max_flatness, "(0, 1]");
  return Status::Ok();
}

bool FitGroundNormal(Span<const PointXYZI> levelled, const GroundUpParams& params, std::vector<float>* z_scratch,
                     Eigen::Vector3d* normal) {
  const double r0 = params.min_range_m * params.min_range_m, r1 = params.max_range_m * params.max_range_m;
  auto in_ring = [&](const PointXYZI& p) {
    const double x = static_cast<double>(p.x), y = static_cast<double>(p.y);
    const double r2 = x * x + y * y;
    return r2 >= r0 && r2 < r1 && std::isfinite(p.z);
  };
  z_scratch->clear();
  for (const PointXYZI& p : levelled) {
    if (in_ring(p)) z_scratch->push_back(p.z);
  }
  if (z_scratch->size() < params.min_points) return false;
  const std::size_t k = std::min(z_scratch->size() - 1,
                                 static_cast<std::size_t>(params.percentile / 100.0 * static_cast<double>(z_scratch->size())));
  std::nth_element(z_scratch->begin(), z_scratch->begin() + static_cast<std::ptrdiff_t>(k), z_scratch->end());
  // The plane n . p = d, first horizontal through the percentile.
  Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  double d = static_cast<double>((*z_scratch)[k]);
  double flatness = 1.0;
  std::size_t used = 0;
  for (int it = 0; it < params.iterations; ++it) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
    used = 0;
    for (const PointXYZI& p : levelled) {
      if (!in_ring(p)) continue;
      const Eigen::Vector3d q(static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z));
      if (std::abs(n.dot(q) - d) > params.band_m) continue;
      sum += q;
      outer += q * q.transpose();
      ++used;
    }
    if (used < params.min_points) return false;
    const Eigen::Vector3d mean = sum / static_cast<double>(used);
    const Eigen::Matrix3d cov = outer / static_cast<double>(used) - mean * mean.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    n = eig.eigenvectors().col(0);
    if (n.z() < 0.0) n = -n;
    d = n.dot(mean);
    const double middle = eig.eigenvalues()(1);
    flatness = middle > 0.0 ? eig.eigenvalues()(0) / middle : 1.0;
  }
  if (flatness > params.max_flatness) return false;
  if (std::acos(std::clamp(n.z(), -1.0, 1.0)) > params.max_lean_deg * kDegToRad) return false;
  *normal = n;
  return true;
}

Eigen::Vector3d GroundUpEstimate::up() const {
  const double norm = sum_.norm();
  return count_ == 0 || !(norm > 0.0) ? Eigen::Vector3d::UnitZ() : Eigen::Vector3d(sum_ / norm);
}

double GroundUpEstimate::tilt_deg() const {
  return std::acos(std::clamp(up().z(), -1.0, 1.0)) / kDegToRad;
}

}  // namespace commerge
