// SPDX-License-Identifier: BSD-3-Clause
#include "core/slam/loop_detector.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {

Status ValidateLoopDetectorParams(const LoopDetectorParams& p) {
  if (!(p.max_descriptor_distance > 0.0)) {
    return InvalidArgument("loop detector: max_descriptor_distance must be > 0, got " +
                           std::to_string(p.max_descriptor_distance));
  }
  if (!(p.max_icp_mean_squared_residual_m2 > 0.0)) {
    return InvalidArgument("loop detector: max_icp_mean_squared_residual_m2 must be > 0, got " +
                           std::to_string(p.max_icp_mean_squared_residual_m2));
  }
  if (p.yaw_hypotheses < 1 || p.yaw_hypotheses > 360) {
    return InvalidArgument("loop detector: yaw_hypotheses must be in [1, 360], got " + std::to_string(p.yaw_hypotheses));
  }
  if (!(p.effective_correspondences > 0.0) || !(p.min_inlier_ratio >= 0.0 && p.min_inlier_ratio <= 1.0)) {
    return InvalidArgument("loop detector: effective_correspondences must be > 0 and min_inlier_ratio in [0, 1]");
  }
  if (p.yaw_screening_iterations < 0 || p.yaw_refinements < 1 || p.yaw_refinements > p.yaw_hypotheses) {
    return InvalidArgument("loop detector: yaw_screening_iterations must be >= 0 and yaw_refinements in [1, "
                           "yaw_hypotheses], got " + std::to_string(p.yaw_screening_iterations) + " and " +
                           std::to_string(p.yaw_refinements));
  }
  if (!(p.max_correction_m >= 0.0) || !(p.max_correction_per_travelled >= 0.0)) {
    return InvalidArgument("loop detector: max_correction_m and max_correction_per_travelled must be >= 0, got " +
                           std::to_string(p.max_correction_m) + " and " + std::to_string(p.max_correction_per_travelled));
  }
  if (!(p.max_correction_deg >= 0.0) || !(p.max_correction_deg_per_travelled_m >= 0.0)) {
    return InvalidArgument(
        "loop detector: max_correction_deg and max_correction_deg_per_travelled_m must be >= 0, got " +
        std::to_string(p.max_correction_deg) + " and " + std::to_string(p.max_correction_deg_per_travelled_m));
  }
  if (!(p.prediction_accept_inlier_ratio > 0.0)) {
    return InvalidArgument("loop detector: prediction_accept_inlier_ratio must be > 0 (> 1 disables it), got " +
                           std::to_string(p.prediction_accept_inlier_ratio));
  }
  if (!(p.max_refinement_m >= 0.0) || !(p.max_refinement_deg >= 0.0)) {
    return InvalidArgument("loop detector: max_refinement_m and max_refinement_deg must be >= 0, got " +
                           std::to_string(p.max_refinement_m) + " and " + std::to_string(p.max_refinement_deg));
  }
  if (p.refine_with_gicp) {
    if (Status s = ValidateSubmapFeatureParams(p.refine_features); !s.ok()) {
      return InvalidArgument("loop detector: refine_features: " + s.message());
    }
    if (Status s = ValidateGicpParams(p.refine_gicp); !s.ok()) {
      return InvalidArgument("loop detector: refine_gicp: " + s.message());
    }
  }
  return Status::Ok();
}

const char* LoopVerdictName(LoopVerdict v) {
  switch (v) {
    case LoopVerdict::kAccepted: return "accepted";
    case LoopVerdict::kNoCandidate: return "no candidate";
    case LoopVerdict::kDescriptorTooFar: return "descriptor distance above tau_intra";
    case LoopVerdict::kIcpFailed: return "ICP did not converge";
    case LoopVerdict::kIcpResidualTooLarge: return "ICP residual above tau_ICP";
    case LoopVerdict::kTooFewInliers: return "too few ICP inliers";
    case LoopVerdict::kCorrectionTooLarge: return "correction larger than odometry drift allows";
  }
  return "?";
}

DescriptorDatabase::DescriptorDatabase(const PlaceDescriptor& descriptor, std::size_t max_keyframes)
    : descriptor_(descriptor), dimension_(descriptor.dimension()), values_(max_keyframes * descriptor.dimension()),
      valid_(max_keyframes) {}

Status DescriptorDatabase::Add(Span<const float> values, bool valid) {
  if (values.size() != dimension_) {
    return InvalidArgument("descriptor database: descriptor has " + std::to_string(values.size()) +
                           " values, expected " + std::to_string(dimension_));
  }
  if (valid_.full()) {
    return ResourceExhausted("descriptor database: full at " + std::to_string(valid_.capacity()) +
                             " keyframes (raise --max-keyframes)");
  }
  for (float v : values) values_.push_back(v);
  valid_.push_back(static_cast<std::uint8_t>(valid ? 1 : 0));
  return Status::Ok();
}

Span<const float> DescriptorDatabase::Get(std::size_t keyframe) const {
  return Span<const float>(values_.data() + keyframe * dimension_, dimension_);
}

DescriptorDatabase::Match DescriptorDatabase::NearestBefore(Span<const float> query, std::size_t end) const {
  Match best;
  end = std::min(end, size());
  for (std::size_t k = 0; k < end; ++k) {
    if (!valid_[k]) continue;
    const double d = descriptor_.Distance(query, Get(k));
    if (!best.found || d < best.distance) {
      best.found = true;
      best.keyframe = static_cast<std::uint32_t>(k);
      best.distance = d;
    }
  }
  return best;
}

Result<LoopCheck> LoopVerifier::Verify(std::uint32_t query, std::uint32_t match, double descriptor_distance,
                                       Span<const PointXYZI> query_scan, Span<const PointXYZI> match_scan,
                                       const Eigen::Isometry3d& T_match_query_odom, const LoopDetectorParams& p) {
  LoopCheck check;
  check.loop.query = query;
  check.loop.match = match;
  check.loop.descriptor_distance = descriptor_distance;
  if (descriptor_distance > p.max_descriptor_distance) {
    check.verdict = LoopVerdict::kDescriptorTooFar;
    return check;
  }
  if (query_scan.empty() || match_scan.empty()) {
    check.verdict = LoopVerdict::kIcpFailed;
    return check;
  }
  icp_.SetTarget(match_scan);
  // Initial guesses: the trajectory's prediction, then yaw-only rotations (revisits in the opposite
  // direction, or after drift, are far from the prediction).
  bool have_best = false;
  IcpResult best;
  // Prefer more overlap first (a tiny residual on a sliver is not a loop), then the lower residual.
  auto better_than = [](const IcpResult& a, const IcpResult& b) {
    return a.inlier_ratio > b.inlier_ratio + 0.05 ||
           (a.inlier_ratio >= b.inlier_ratio - 0.05 && a.mean_squared_residual_m2 < b.mean_squared_residual_m2);
  };
  auto consider = [&](const IcpResult& r) {
    if (r.num_inliers == 0) return;
    if (!have_best || better_than(r, best)) {
      best = r;
      have_best = true;
    }
  };
  if (T_match_query_odom.matrix().allFinite()) {
    auto r = icp_.Align(query_scan, T_match_query_odom, p.icp);
    if (!r.ok()) return r.status();
    consider(*r);
  }
  const bool prediction_verified = have_best && best.converged &&
                                   best.inlier_ratio >= p.prediction_accept_inlier_ratio &&
                                   best.mean_squared_residual_m2 <= p.max_icp_mean_squared_residual_m2;
  if (!prediction_verified) {
    // Yaw-only restarts (revisits in the opposite direction, or after drift, are far from the prediction):
    // screened with a few iterations each, the most promising refined in full.
    const bool screen = p.yaw_screening_iterations > 0 && p.yaw_screening_iterations < p.icp.max_iterations;
    IcpParams screening = p.icp;
    if (screen) screening.max_iterations = p.yaw_screening_iterations;
    screened_.clear();
    for (int h = 0; h < p.yaw_hypotheses; ++h) {
      Eigen::Isometry3d guess = Eigen::Isometry3d::Identity();
      guess.linear() = Eigen::AngleAxisd(2.0 * kPi * h / p.yaw_hypotheses, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      auto r = icp_.Align(query_scan, guess, screening);
      if (!r.ok()) return r.status();
      if (!screen) {
        consider(*r);
      } else if (r->num_inliers > 0) {
        screened_.push_back(*r);
      }
    }
    if (screen) {
      std::stable_sort(screened_.begin(), screened_.end(),
                       [&](const IcpResult& a, const IcpResult& b) { return better_than(a, b); });
      const std::size_t refine = std::min<std::size_t>(screened_.size(), static_cast<std::size_t>(std::max(p.yaw_refinements, 1)));
      for (std::size_t i = 0; i < refine; ++i) {
        auto r = icp_.Align(query_scan, screened_[i].T_target_source, p.icp);
        if (!r.ok()) return r.status();
        consider(*r);
      }
    }
  }
  if (!have_best || !best.converged) {
    check.verdict = LoopVerdict::kIcpFailed;
    if (have_best) check.loop.icp = best;
    return check;
  }
  check.loop.icp = best;
  check.loop.T_match_query = best.T_target_source;
  if (best.inlier_ratio < p.min_inlier_ratio) {
    check.verdict = LoopVerdict::kTooFewInliers;
    return check;
  }
  if (best.mean_squared_residual_m2 > p.max_icp_mean_squared_residual_m2) {
    check.verdict = LoopVerdict::kIcpResidualTooLarge;
    return check;
  }
  // Information from the residuals (paper: "based on the point-wise residuals"), scaled to an effective
  // number of independent correspondences.
  check.loop.information =
      best.hessian * (p.effective_correspondences / static_cast<double>(std::max<std::size_t>(best.num_inliers, 1)));
  check.verdict = LoopVerdict::kAccepted;
  if (p.refine_with_gicp) Refine(query_scan, match_scan, p, &check.loop);
  return check;
}

void LoopVerifier::Refine(Span<const PointXYZI> query_scan, Span<const PointXYZI> match_scan,
                          const LoopDetectorParams& p, LoopClosure* loop) {
  // Both scans are in their own sensor frames: normals face the frame origin.
  query_features_.ComputeGeometry(query_scan, Span<const Eigen::Vector3d>(), p.refine_features);
  match_features_.ComputeGeometry(match_scan, Span<const Eigen::Vector3d>(), p.refine_features);
  const GicpResult g = gicp_.Align(query_features_, match_features_, loop->T_match_query, p.refine_gicp);
  if (!g.converged || !IsValidRigidTransform(g.T_target_source)) return;
  const Eigen::Isometry3d change = loop->T_match_query.inverse() * g.T_target_source;
  const double change_deg = RotationAngleRad(change.linear()) * 180.0 / kPi;
  if (change.translation().norm() > p.max_refinement_m || change_deg > p.max_refinement_deg) return;
  loop->T_match_query = g.T_target_source;
  loop->refined = true;
}

}  // namespace commerge
