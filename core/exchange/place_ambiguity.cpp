// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/place_ambiguity.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>


namespace commerge {
namespace {

bool Valid(const DescriptorSetView& set, std::size_t k) { return set.valid.empty() || set.valid[k] != 0; }

Span<const float> Row(const DescriptorSetView& set, std::size_t k) { return set.values.subspan(k * set.dim, set.dim); }

// Counts the ambiguous keyframes of one side: `cross` holds (keyframe, its smallest distance to the other robot).
void CountSide(const DescriptorSetView& own, Span<const Eigen::Vector3d> positions_m,
               const std::vector<std::pair<std::size_t, double>>& cross, double far_m, const DescriptorMetric& metric,
               std::size_t* keyframes, std::size_t* ambiguous) {
  const double far2 = far_m * far_m;
  for (const auto& [k, cross_distance] : cross) {
    ++*keyframes;
    for (std::size_t other = 0; other < own.count(); ++other) {
      if (!Valid(own, other) || (positions_m[other] - positions_m[k]).squaredNorm() <= far2) continue;
      if (DescriptorDistance(metric, Row(own, k), Row(own, other)) <= cross_distance) {
        ++*ambiguous;
        break;
      }
    }
  }
}

// (keyframe, smallest distance over its l_seq partners) for the distinct valid keyframes of one side.
std::vector<std::pair<std::size_t, double>> CrossDistances(const DescriptorSetView& alpha,
                                                           const DescriptorSetView& beta,
                                                           Span<const SequentialLoopCell> l_seq, bool alpha_side,
                                                           const DescriptorMetric& metric) {
  std::vector<std::pair<std::size_t, double>> out;
  out.reserve(l_seq.size());
  for (const SequentialLoopCell& c : l_seq) {
    if (!Valid(alpha, c.alpha_index) || !Valid(beta, c.beta_index)) continue;
    const double d = DescriptorDistance(metric, Row(alpha, c.alpha_index), Row(beta, c.beta_index));
    out.emplace_back(alpha_side ? c.alpha_index : c.beta_index, d);
  }
  std::sort(out.begin(), out.end());  // by keyframe, then distance: the first of each keyframe is its smallest
  out.erase(std::unique(out.begin(), out.end(),
                        [](const auto& a, const auto& b) { return a.first == b.first; }),
            out.end());
  return out;
}

}  // namespace

Result<PlaceAmbiguity> MeasurePlaceAmbiguity(const DescriptorSetView& alpha, Span<const Eigen::Vector3d> alpha_positions_m,
                                             const DescriptorSetView& beta, Span<const Eigen::Vector3d> beta_positions_m,
                                             Span<const SequentialLoopCell> l_seq, double far_m,
                                             const DescriptorMetric& metric) {
  if (Status s = ValidateDescriptorSet(alpha, "place ambiguity alpha"); !s.ok()) return s;
  if (Status s = ValidateDescriptorSet(beta, "place ambiguity beta"); !s.ok()) return s;
  if (alpha.dim != beta.dim) return InvalidArgument("place ambiguity: descriptor dimensions differ");
  if (alpha_positions_m.size() != alpha.count() || beta_positions_m.size() != beta.count()) {
    return InvalidArgument("place ambiguity: positions per robot must match its descriptors (alpha " +
                           std::to_string(alpha_positions_m.size()) + " vs " + std::to_string(alpha.count()) +
                           ", beta " + std::to_string(beta_positions_m.size()) + " vs " +
                           std::to_string(beta.count()) + ")");
  }
  if (!(std::isfinite(far_m) && far_m >= 0.0)) {
    return InvalidArgument("place ambiguity: far_m must be finite and >= 0, got " + std::to_string(far_m));
  }
  for (const SequentialLoopCell& c : l_seq) {
    if (c.alpha_index >= alpha.count() || c.beta_index >= beta.count()) {
      return InvalidArgument("place ambiguity: loop (" + std::to_string(c.alpha_index) + ", " +
                             std::to_string(c.beta_index) + ") outside the descriptor sets (" +
                             std::to_string(alpha.count()) + " x " + std::to_string(beta.count()) + ")");
    }
  }
  PlaceAmbiguity out;
  CountSide(alpha, alpha_positions_m, CrossDistances(alpha, beta, l_seq, true, metric), far_m, metric,
            &out.alpha_keyframes, &out.alpha_ambiguous);
  CountSide(beta, beta_positions_m, CrossDistances(alpha, beta, l_seq, false, metric), far_m, metric,
            &out.beta_keyframes, &out.beta_ambiguous);
  return out;
}

}  // namespace commerge
