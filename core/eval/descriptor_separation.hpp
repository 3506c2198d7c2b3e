// SPDX-License-Identifier: BSD-3-Clause
// commerge: how well a place descriptor separates the same place from different places, for two robots with
// ground truth: the descriptor distances of keyframe pairs that are truly at one place (and, for a forward-looking
// sensor, seen from headings within its field of view) against those of pairs truly far apart, as quantiles.
#pragma once

#include <cstddef>

#include <Eigen/Geometry>

#include "core/common/span.hpp"
#include "core/exchange/affinity.hpp"

namespace commerge {

struct DescriptorSeparationParams {
  double true_pair_max_m = 3.0;    ///< a true pair: ground-truth positions at most this far apart [m]
  double false_pair_min_m = 20.0;  ///< a false pair: at least this far apart [m]; pairs in between are skipped
  /// A true pair also needs yaws within this of each other [deg] (SharedPlaceParams::max_heading_deg: 180 for a
  /// spinning sensor, the horizontal field of view of a forward-looking one).
  double max_heading_deg = 180.0;
  /// With a metric other than unit L2 (the Scan Context distance costs ~1000x a dot product) only false pairs
  /// (i, j) with (i + j) % stride == 0 are measured; every true pair is. 0 or 1 = every false pair.
  std::size_t costly_metric_false_pair_stride = 31;
};

/// Quantiles of the two sets of distances; -1 for a quantile of an empty set.
struct DistanceQuantiles {
  std::size_t true_pairs = 0, false_pairs = 0;
  double true_p05 = 0, true_p50 = 0, true_p95 = 0;     ///< of the true pairs
  double false_p01 = 0, false_p05 = 0, false_p50 = 0;  ///< of the false pairs
};

/// The q-quantile of `values` (q in [0, 1]): the element of rank min(n - 1, floor(q n)) in ascending order;
/// -1 when empty. Reorders `values` (std::nth_element).
double QuantileInPlace(Span<float> values, double q);

/// Descriptor distances (DescriptorDistance under `metric`) of every pair of valid keyframes i of alpha and j of
/// beta that have ground truth (i < alpha_gt.size(), j < beta_gt.size(); keyframe k's ground truth is
/// *_gt[k]), sorted into true and false pairs by params, and their quantiles (true: 5, 50, 95 %; false: 1, 5,
/// 50 %). Both descriptor sets must have the same dim.
DistanceQuantiles DescriptorSeparation(const DescriptorSetView& alpha, Span<const Eigen::Isometry3d> alpha_gt,
                                       const DescriptorSetView& beta, Span<const Eigen::Isometry3d> beta_gt,
                                       const DescriptorMetric& metric, const DescriptorSeparationParams& params = {});

}  // namespace commerge
