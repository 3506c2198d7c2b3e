// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/place_ambiguity.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/descriptor/solid.hpp"


namespace commerge {
namespace {

bool Valid(const DescriptorSetView& set, std::size_t k) { return set.valid.empty() || set.valid[k] != 0; }

Span<const float> Row(const DescriptorSetView& set, std::size_t k) { return set.values.subspan(k * set.dim, set.dim); }

// SolidDistance(Row(set, a), Row(set, b)) (core/descriptor/solid.cpp: Cosine, then Distance) with the squared
// norms aa, bb taken from `norms2` instead of recomputed: the same double operations in the same order, so the
// same value bit for bit, with one accumulation per pair instead of three.
double UnitL2Distance(const DescriptorSetView& set, std::size_t a, std::size_t b, const std::vector<double>& norms2) {
  const float* x = set.values.data() + a * set.dim;
  const float* y = set.values.data() + b * set.dim;
  double ab = 0.0;
  for (std::size_t i = 0; i < set.dim; ++i) ab += static_cast<double>(x[i]) * static_cast<double>(y[i]);
  const double aa = norms2[a], bb = norms2[b];
  if (!(aa > 0.0 && bb > 0.0)) return kSolidMaxDistance;
  const double c = ab / (std::sqrt(aa) * std::sqrt(bb));
  if (!std::isfinite(c)) return kSolidMaxDistance;
  return std::sqrt(std::max(0.0, 2.0 - 2.0 * c));
}

// UnitL2Distance(set, a, b[t], norms2) for t < count (count <= 4), the four sums interleaved.
void UnitL2Distances(const DescriptorSetView& set, std::size_t a, const std::size_t* b, std::size_t count,
                     const std::vector<double>& norms2, double* out) {
  if (count < 4) {
    for (std::size_t t = 0; t < count; ++t) out[t] = UnitL2Distance(set, a, b[t], norms2);
    return;
  }
  const float* x = set.values.data() + a * set.dim;
  const float* y0 = set.values.data() + b[0] * set.dim;
  const float* y1 = set.values.data() + b[1] * set.dim;
  const float* y2 = set.values.data() + b[2] * set.dim;
  const float* y3 = set.values.data() + b[3] * set.dim;
  double ab0 = 0.0, ab1 = 0.0, ab2 = 0.0, ab3 = 0.0;
  for (std::size_t i = 0; i < set.dim; ++i) {
    const double xi = static_cast<double>(x[i]);
    ab0 += xi * static_cast<double>(y0[i]);
    ab1 += xi * static_cast<double>(y1[i]);
    ab2 += xi * static_cast<double>(y2[i]);
    ab3 += xi * static_cast<double>(y3[i]);
  }
  const double ab[4] = {ab0, ab1, ab2, ab3};
  const double aa = norms2[a];
  for (std::size_t t = 0; t < 4; ++t) {
    const double bb = norms2[b[t]];
    double d = kSolidMaxDistance;
    if (aa > 0.0 && bb > 0.0) {
      const double c = ab[t] / (std::sqrt(aa) * std::sqrt(bb));
      if (std::isfinite(c)) d = std::sqrt(std::max(0.0, 2.0 - 2.0 * c));
    }
    out[t] = d;
  }
}

// Counts the ambiguous keyframes of one side: `cross` holds (keyframe, its smallest distance to the other robot).
void CountSide(const DescriptorSetView& own, Span<const Eigen::Vector3d> positions_m,
               const std::vector<std::pair<std::size_t, double>>& cross, double far_m, const DescriptorMetric& metric,
               std::size_t* keyframes, std::size_t* ambiguous) {
  const double far2 = far_m * far_m;
  const bool unit_l2 = metric.kind == DescriptorMetric::Kind::kUnitL2;
  std::vector<double> norms2;  // unit L2: every keyframe's squared norm, summed as Cosine sums it
  if (unit_l2 && !cross.empty()) {
    norms2.resize(own.count());
    for (std::size_t k = 0; k < own.count(); ++k) {
      const float* x = own.values.data() + k * own.dim;
      double aa = 0.0;
      for (std::size_t i = 0; i < own.dim; ++i) aa += static_cast<double>(x[i]) * static_cast<double>(x[i]);
      norms2[k] = aa;
    }
  }
  std::vector<std::size_t> others;  // unit L2: the far valid keyframes, taken 4 at a time
  for (const auto& [k, cross_distance] : cross) {
    ++*keyframes;
    if (!unit_l2) {
      for (std::size_t other = 0; other < own.count(); ++other) {
        if (!Valid(own, other) || (positions_m[other] - positions_m[k]).squaredNorm() <= far2) continue;
        if (DescriptorDistance(metric, Row(own, k), Row(own, other)) <= cross_distance) {
          ++*ambiguous;
          break;
        }
      }
      continue;
    }
    others.clear();
    for (std::size_t other = 0; other < own.count(); ++other) {
      if (Valid(own, other) && (positions_m[other] - positions_m[k]).squaredNorm() > far2) others.push_back(other);
    }
    // Four independent distances at a time (each summed in its own order, so each is UnitL2Distance's value);
    // the first one at or below cross_distance decides, as in the loop above.
    bool found = false;
    for (std::size_t q = 0; q < others.size() && !found; q += 4) {
      double d[4];
      const std::size_t count = std::min<std::size_t>(4, others.size() - q);
      UnitL2Distances(own, k, others.data() + q, count, norms2, d);
      for (std::size_t t = 0; t < count && !found; ++t) found = d[t] <= cross_distance;
    }
    if (found) ++*ambiguous;
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
