// SPDX-License-Identifier: BSD-3-Clause
#include "core/eval/descriptor_separation.hpp"

#include <algorithm>
#include <vector>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {

namespace {

bool SeparationKeyframeValid(const DescriptorSetView& set, std::size_t k) {
  return set.valid.empty() || set.valid[k] != 0;
}

}  // namespace

double QuantileInPlace(Span<float> values, double q) {
  if (values.empty()) return -1.0;
  const std::size_t k =
      std::min(values.size() - 1, static_cast<std::size_t>(q * static_cast<double>(values.size())));
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(k), values.end());
  return static_cast<double>(values[k]);
}

DistanceQuantiles DescriptorSeparation(const DescriptorSetView& alpha, Span<const Eigen::Isometry3d> alpha_gt,
                                       const DescriptorSetView& beta, Span<const Eigen::Isometry3d> beta_gt,
                                       const DescriptorMetric& metric, const DescriptorSeparationParams& params) {
  const double max_heading_rad = params.max_heading_deg * kDegToRad;
  const bool costly = metric.kind != DescriptorMetric::Kind::kUnitL2;
  const std::size_t stride = params.costly_metric_false_pair_stride;
  const std::size_t na = std::min(alpha.count(), alpha_gt.size());
  const std::size_t nb = std::min(beta.count(), beta_gt.size());
  std::vector<float> same, different;
  for (std::size_t i = 0; i < na; ++i) {
    if (!SeparationKeyframeValid(alpha, i)) continue;
    for (std::size_t j = 0; j < nb; ++j) {
      if (!SeparationKeyframeValid(beta, j)) continue;
      const double d = (alpha_gt[i].translation() - beta_gt[j].translation()).norm();
      if (d > params.true_pair_max_m && d < params.false_pair_min_m) continue;
      const double heading_rad =
          RotationAngleRad(Eigen::AngleAxisd(YawRad(alpha_gt[i].linear()) - YawRad(beta_gt[j].linear()),
                                             Eigen::Vector3d::UnitZ()).toRotationMatrix());
      if (d <= params.true_pair_max_m && heading_rad > max_heading_rad) continue;
      if (d > params.true_pair_max_m && costly && stride > 1 && (i + j) % stride != 0) continue;
      const double distance = DescriptorDistance(metric, alpha.values.subspan(i * alpha.dim, alpha.dim),
                                                 beta.values.subspan(j * beta.dim, beta.dim));
      (d <= params.true_pair_max_m ? same : different).push_back(static_cast<float>(distance));
    }
  }
  DistanceQuantiles out;
  out.true_pairs = same.size();
  out.false_pairs = different.size();
  out.true_p05 = QuantileInPlace(Span<float>(same), 0.05);
  out.true_p50 = QuantileInPlace(Span<float>(same), 0.5);
  out.true_p95 = QuantileInPlace(Span<float>(same), 0.95);
  out.false_p01 = QuantileInPlace(Span<float>(different), 0.01);
  out.false_p05 = QuantileInPlace(Span<float>(different), 0.05);
  out.false_p50 = QuantileInPlace(Span<float>(different), 0.5);
  return out;
}

}  // namespace commerge
