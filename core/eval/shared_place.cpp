// SPDX-License-Identifier: BSD-3-Clause
#include "core/eval/shared_place.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/descriptor/sensor_presets.hpp"
#include "core/geometry/se3.hpp"
#include "core/geometry/umeyama.hpp"

namespace commerge {

namespace {

// Its own name: a unity batch may also see core/geometry/angles.hpp's kRadToDeg.
constexpr double kSharedPlaceRadToDeg = 57.29577951308232;

// Heading difference [deg] in [0, 180].
double HeadingDifferenceDeg(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
  double d = std::fabs(YawRad(a.linear()) - YawRad(b.linear())) * kSharedPlaceRadToDeg;
  d = std::fmod(d, 360.0);
  return d > 180.0 ? 360.0 - d : d;
}

double PathLength(Span<const Eigen::Isometry3d> poses) {
  double length = 0.0;
  for (std::size_t i = 1; i < poses.size(); ++i) length += (poses[i].translation() - poses[i - 1].translation()).norm();
  return length;
}

// Path [m] of `a` at places of `b`.
double PathAtPlacesOf(Span<const Eigen::Isometry3d> a, Span<const Eigen::Isometry3d> b, const SharedPlaceParams& p) {
  const double r2 = p.radius_m * p.radius_m;
  double path = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Eigen::Vector3d pa = a[i].translation();
    bool near = false;
    for (std::size_t j = 0; j < b.size() && !near; ++j) {
      if ((b[j].translation() - pa).squaredNorm() > r2) continue;
      near = HeadingDifferenceDeg(a[i], b[j]) <= p.max_heading_deg;
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
  if (!(p.min_shared_path_fraction >= 0.0 && p.min_shared_path_fraction <= 1.0)) {
    return InvalidArgument("shared place min_shared_path_fraction must be in [0, 1]");
  }
  return Status::Ok();
}

SharedPlaceParams SharedPlaceParamsForSensor(const std::string& lidar) {
  SharedPlaceParams p;
  Result<LidarSensor> sensor = LidarSensorFor(lidar);
  if (sensor.ok() && ScanTraits(*sensor).horizontal_fov_deg < 360.0) {
    p.max_heading_deg = ScanTraits(*sensor).horizontal_fov_deg;
  }
  return p;
}

SharedPlace MeasureSharedPlace(Span<const Eigen::Isometry3d> alpha_gt, Span<const Eigen::Isometry3d> beta_gt,
                               const SharedPlaceParams& params) {
  SharedPlace s;
  s.alpha_path_m = PathAtPlacesOf(alpha_gt, beta_gt, params);
  s.beta_path_m = PathAtPlacesOf(beta_gt, alpha_gt, params);
  s.alpha_total_m = PathLength(alpha_gt);
  s.beta_total_m = PathLength(beta_gt);
  const double needed_m =
      params.min_shared_path_fraction > 0.0
          ? std::min(params.min_shared_path_m,
                     params.min_shared_path_fraction * std::min(s.alpha_total_m, s.beta_total_m))
          : params.min_shared_path_m;
  s.shared = std::min(s.alpha_path_m, s.beta_path_m) >= needed_m && (s.alpha_path_m > 0.0 || needed_m == 0.0);
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

Result<SharedPlaceTruth> TruthAtSharedPlace(Span<const Eigen::Isometry3d> ref_est, Span<const Eigen::Isometry3d> ref_gt,
                                            Span<const Eigen::Isometry3d> other_est,
                                            Span<const Eigen::Isometry3d> other_gt, const SharedPlaceParams& params,
                                            std::size_t min_keyframe_pairs, Span<const std::uint32_t> other_keyframes) {
  if (Status s = ValidateSharedPlaceParams(params); !s.ok()) return s;
  if (ref_est.size() != ref_gt.size()) return InvalidArgument("ref_est and ref_gt differ in size");
  if (other_est.size() != other_gt.size()) return InvalidArgument("other_est and other_gt differ in size");
  for (Span<const Eigen::Isometry3d> poses : {ref_est, ref_gt, other_est, other_gt}) {
    for (const Eigen::Isometry3d& T : poses) {
      if (!T.matrix().allFinite()) return InvalidArgument("TruthAtSharedPlace: a pose has a non-finite entry");
    }
  }
  std::vector<bool> judged(other_gt.size(), other_keyframes.empty());
  for (std::uint32_t k : other_keyframes) {
    if (k >= other_gt.size()) {
      return InvalidArgument("TruthAtSharedPlace: keyframe " + std::to_string(k) + " of the other robot is outside its " +
                             std::to_string(other_gt.size()) + " poses");
    }
    judged[k] = true;
  }
  const double r2 = params.radius_m * params.radius_m;
  std::vector<Eigen::Isometry3d> source, target;  // other's estimated poses, and where they belong in ref's map
  SharedPlaceTruth truth;
  for (std::size_t i = 0; i < other_gt.size(); ++i) {
    if (!judged[i]) continue;
    std::size_t best = ref_gt.size();
    double best_d2 = r2;
    for (std::size_t j = 0; j < ref_gt.size(); ++j) {
      const double d2 = (ref_gt[j].translation() - other_gt[i].translation()).squaredNorm();
      if (d2 <= best_d2 && HeadingDifferenceDeg(ref_gt[j], other_gt[i]) <= params.max_heading_deg) {
        best = j;
        best_d2 = d2;
      }
    }
    if (best == ref_gt.size()) continue;
    source.push_back(other_est[i]);
    target.push_back(ref_est[best] * ref_gt[best].inverse() * other_gt[i]);
    truth.p_other_place += other_est[i].translation();
    ++truth.keyframe_pairs;
  }
  if (truth.keyframe_pairs < std::max<std::size_t>(min_keyframe_pairs, 1)) {
    return NotFound("TruthAtSharedPlace: " + std::to_string(truth.keyframe_pairs) +
                    " keyframes of the other robot at a place of the reference robot");
  }
  truth.p_other_place /= static_cast<double>(truth.keyframe_pairs);
  constexpr double kAxisOffsetM = 1.0;
  const std::vector<Eigen::Vector3d> source_points =
      AlignmentPoints(Span<const Eigen::Isometry3d>(source), true, kAxisOffsetM);
  const std::vector<Eigen::Vector3d> target_points =
      AlignmentPoints(Span<const Eigen::Isometry3d>(target), true, kAxisOffsetM);
  Result<Eigen::Isometry3d> T =
      AlignRigid(Span<const Eigen::Vector3d>(source_points), Span<const Eigen::Vector3d>(target_points));
  if (!T.ok()) return T.status();
  truth.T_ref_other = *T;
  return truth;
}

TransformError ErrorAtSharedPlace(const Eigen::Isometry3d& T_ref_other, const SharedPlaceTruth& truth) {
  TransformError e = ComputeTransformError(T_ref_other, truth.T_ref_other);
  e.translation_m = (T_ref_other * truth.p_other_place - truth.T_ref_other * truth.p_other_place).norm();
  return e;
}

}  // namespace commerge
