// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/transform_agreement.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {
namespace {

Status CheckSet(const KeyframeSetView& set, std::size_t dim, const char* name) {
  if (set.descriptors.size() != dim * set.size() || set.T_map_sensor.size() != set.size()) {
    return InvalidArgument(std::string(name) + ": " + std::to_string(set.size()) + " keyframes with " +
                           std::to_string(set.descriptors.size()) + " descriptor values (dim " + std::to_string(dim) +
                           ") and " + std::to_string(set.T_map_sensor.size()) + " poses");
  }
  return Status::Ok();
}

// Unit-L2 distance of two unit vectors from their dot product, in float.
float UnitL2FromDot(float dot) { return std::sqrt(std::max(0.0f, 2.0f - 2.0f * dot)); }

// Unit-L2 distance of two unit vectors, in float (the metric's other kinds go through DescriptorDistance).
float UnitL2Distance(const float* a, const float* b, std::size_t dim) {
  float dot = 0.0f;
  for (std::size_t k = 0; k < dim; ++k) dot += a[k] * b[k];
  return UnitL2FromDot(dot);
}

// Alpha keyframes `ids` whose unit-L2 distance to `dj` is below `distance`: the same float sums, keyframe by
// keyframe, as UnitL2Distance, four keyframes at a time so that their sums overlap in the pipeline.
std::size_t CountNearerUnitL2(const float* alpha, const std::vector<std::uint32_t>& ids, const float* dj,
                              std::size_t dim, float distance) {
  std::size_t nearer = 0, k = 0;
  const auto below = [&](float dot) { return UnitL2FromDot(dot) < distance ? 1 : 0; };
  for (; k + 4 <= ids.size(); k += 4) {
    const float* a0 = alpha + std::size_t{ids[k]} * dim;
    const float* a1 = alpha + std::size_t{ids[k + 1]} * dim;
    const float* a2 = alpha + std::size_t{ids[k + 2]} * dim;
    const float* a3 = alpha + std::size_t{ids[k + 3]} * dim;
    float s0 = 0.0f, s1 = 0.0f, s2 = 0.0f, s3 = 0.0f;
    for (std::size_t d = 0; d < dim; ++d) {
      s0 += a0[d] * dj[d];
      s1 += a1[d] * dj[d];
      s2 += a2[d] * dj[d];
      s3 += a3[d] * dj[d];
    }
    nearer += below(s0) + below(s1) + below(s2) + below(s3);
  }
  for (; k < ids.size(); ++k) {
    nearer += UnitL2Distance(alpha + std::size_t{ids[k]} * dim, dj, dim) < distance ? 1 : 0;
  }
  return nearer;
}

double HeadingGapDeg(double yaw_a_rad, double yaw_b_rad) {
  double d = std::fmod(std::fabs(yaw_a_rad - yaw_b_rad), 2.0 * kPi);
  if (d > kPi) d = 2.0 * kPi - d;
  return d * 180.0 / kPi;
}

}  // namespace

Status ValidateTransformAgreementParams(const TransformAgreementParams& params) {
  if (!(params.near_m > 0.0) || !std::isfinite(params.near_m)) {
    return InvalidArgument("transform agreement near_m = " + std::to_string(params.near_m) + " must be > 0 and finite");
  }
  if (!(params.max_heading_deg > 0.0) || params.max_heading_deg > 180.0) {
    return InvalidArgument("transform agreement max_heading_deg = " + std::to_string(params.max_heading_deg) +
                           " must be in (0, 180]");
  }
  if (params.max_ranked == 0) return InvalidArgument("transform agreement max_ranked = 0 must be >= 1");
  return Status::Ok();
}

Result<std::vector<ColocatedKeyframe>> ColocatedKeyframes(const KeyframeSetView& alpha, const KeyframeSetView& beta,
                                                          std::size_t descriptor_dim,
                                                          const Eigen::Isometry3d& T_alpha_beta,
                                                          const TransformAgreementParams& params,
                                                          std::uint32_t exclude_beta_min, std::uint32_t exclude_beta_max,
                                                          std::size_t* colocated, const DescriptorMetric& metric) {
  if (Status s = ValidateTransformAgreementParams(params); !s.ok()) return s;
  const auto Distance = [&](const float* a, const float* b) {
    if (metric.kind == DescriptorMetric::Kind::kUnitL2) return UnitL2Distance(a, b, descriptor_dim);
    return static_cast<float>(
        DescriptorDistance(metric, Span<const float>(a, descriptor_dim), Span<const float>(b, descriptor_dim)));
  };
  if (descriptor_dim == 0) return InvalidArgument("transform agreement: descriptor dimension 0");
  if (Status s = CheckSet(alpha, descriptor_dim, "alpha"); !s.ok()) return s;
  if (Status s = CheckSet(beta, descriptor_dim, "beta"); !s.ok()) return s;
  if (!T_alpha_beta.matrix().allFinite()) return InvalidArgument("transform agreement: non-finite T_alpha_beta");

  // Alpha's valid keyframes sorted by x: each beta keyframe looks only at the slab x +- near_m.
  struct AlphaKey {
    double x;
    std::uint32_t index;
  };
  std::vector<AlphaKey> by_x;
  std::vector<std::uint32_t> alpha_valid;
  for (std::size_t i = 0; i < alpha.size(); ++i) {
    if (!alpha.valid[i] || !alpha.T_map_sensor[i].matrix().allFinite()) continue;
    by_x.push_back({alpha.T_map_sensor[i].translation().x(), static_cast<std::uint32_t>(i)});
    alpha_valid.push_back(static_cast<std::uint32_t>(i));
  }
  std::sort(by_x.begin(), by_x.end(), [](const AlphaKey& a, const AlphaKey& b) { return a.x < b.x; });
  const bool any_heading = params.max_heading_deg >= 180.0;
  const double near2 = params.near_m * params.near_m;

  // First every co-located keyframe with its nearest co-located descriptor (a slab search), then the ranks of
  // at most max_ranked of them (a distance to every alpha keyframe each).
  std::vector<ColocatedKeyframe> out;
  for (std::size_t j = 0; j < beta.size(); ++j) {
    if (!beta.valid[j] || !beta.T_map_sensor[j].matrix().allFinite()) continue;
    if (exclude_beta_min <= exclude_beta_max && j >= exclude_beta_min && j <= exclude_beta_max) continue;
    const Eigen::Isometry3d T_alpha_j = T_alpha_beta * beta.T_map_sensor[j];
    const Eigen::Vector3d p = T_alpha_j.translation();
    const double yaw_j = any_heading ? 0.0 : YawRad(T_alpha_j.linear());
    const float* dj = beta.descriptors.data() + j * descriptor_dim;
    auto it = std::lower_bound(by_x.begin(), by_x.end(), p.x() - params.near_m,
                               [](const AlphaKey& a, double x) { return a.x < x; });
    float best = std::numeric_limits<float>::infinity();
    std::uint32_t best_i = 0, candidates = 0;
    for (; it != by_x.end() && it->x <= p.x() + params.near_m; ++it) {
      const Eigen::Isometry3d& Ti = alpha.T_map_sensor[it->index];
      if ((Ti.translation() - p).squaredNorm() > near2) continue;
      if (!any_heading && HeadingGapDeg(YawRad(Ti.linear()), yaw_j) > params.max_heading_deg) continue;
      const float d = Distance(alpha.descriptors.data() + std::size_t{it->index} * descriptor_dim, dj);
      ++candidates;
      if (d < best) {
        best = d;
        best_i = it->index;
      }
    }
    if (!std::isfinite(best)) continue;
    ColocatedKeyframe c;
    c.beta = static_cast<std::uint32_t>(j);
    c.alpha = best_i;
    c.distance = best;
    c.candidates = candidates;
    out.push_back(c);
  }
  if (colocated) *colocated = out.size();
  if (out.size() > params.max_ranked) {
    std::vector<ColocatedKeyframe> chosen;
    for (std::size_t k = 0; k < params.max_ranked; ++k) chosen.push_back(out[k * out.size() / params.max_ranked]);
    out.swap(chosen);
  }
  for (ColocatedKeyframe& c : out) {
    const float* dj = beta.descriptors.data() + std::size_t{c.beta} * descriptor_dim;
    std::size_t nearer = 0;
    if (metric.kind == DescriptorMetric::Kind::kUnitL2) {
      nearer = CountNearerUnitL2(alpha.descriptors.data(), alpha_valid, dj, descriptor_dim, c.distance);
    } else {
      for (std::uint32_t i : alpha_valid) {
        nearer += Distance(alpha.descriptors.data() + std::size_t{i} * descriptor_dim, dj) < c.distance ? 1 : 0;
      }
    }
    const double r = static_cast<double>(nearer) / static_cast<double>(alpha_valid.size());
    c.rank_fraction = static_cast<float>(r);
    c.chance = static_cast<float>(1.0 - std::pow(1.0 - r, static_cast<double>(c.candidates)));
  }
  return out;
}

double MedianChance(Span<const ColocatedKeyframe> colocated, std::uint32_t exclude_beta_min,
                    std::uint32_t exclude_beta_max, std::size_t* count) {
  std::vector<float> chances;
  for (const ColocatedKeyframe& c : colocated) {
    if (exclude_beta_min <= exclude_beta_max && c.beta >= exclude_beta_min && c.beta <= exclude_beta_max) continue;
    chances.push_back(c.chance);
  }
  if (count) *count = chances.size();
  if (chances.empty()) return -1.0;
  const std::size_t mid = chances.size() / 2;
  std::nth_element(chances.begin(), chances.begin() + static_cast<std::ptrdiff_t>(mid), chances.end());
  return static_cast<double>(chances[mid]);
}

double AgreementLogOdds(std::size_t ranked, std::size_t agreeing, double agree_chance, double true_fraction) {
  if (!(agree_chance > 0.0 && agree_chance < true_fraction && true_fraction < 1.0) || agreeing > ranked) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const double k = static_cast<double>(agreeing);
  const double rest = static_cast<double>(ranked - agreeing);
  return k * std::log(true_fraction / agree_chance) + rest * std::log((1.0 - true_fraction) / (1.0 - agree_chance));
}

Eigen::Isometry3d PlacementTransform(const ClusterPlacement& placement) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(placement.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = placement.t_alpha_beta_m;
  return T;
}

Result<PlacementAgreement> MeasurePlacementAgreement(const KeyframeSetView& alpha, const KeyframeSetView& beta,
                                                     std::size_t descriptor_dim, const ClusterPlacement& placement,
                                                     const SequentialCluster& cluster,
                                                     const TransformAgreementParams& params, double agree_chance,
                                                     const DescriptorMetric& metric) {
  if (!(agree_chance >= 0.0 && agree_chance <= 1.0)) {
    return InvalidArgument("placement agreement: agree_chance must be in [0, 1], got " + std::to_string(agree_chance));
  }
  PlacementAgreement out;
  if (!placement.valid) return out;
  std::size_t colocated = 0;
  auto ranked = ColocatedKeyframes(alpha, beta, descriptor_dim, PlacementTransform(placement), params,
                                   static_cast<std::uint32_t>(cluster.col_min),
                                   static_cast<std::uint32_t>(cluster.col_max), &colocated, metric);
  if (!ranked.ok()) return ranked.status();
  out.measured = true;
  out.colocated = colocated;
  out.ranked = ranked->size();
  for (const ColocatedKeyframe& c : *ranked) out.agreeing += static_cast<double>(c.chance) <= agree_chance ? 1 : 0;
  out.median_chance = MedianChance(Span<const ColocatedKeyframe>(*ranked), 1, 0, nullptr);
  return out;
}

}  // namespace commerge
