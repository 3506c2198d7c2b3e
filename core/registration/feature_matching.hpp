// SPDX-License-Identifier: BSD-3-Clause
// commerge: descriptor correspondences between two submaps (REGISTRATION.md §1.2 step 8): 2-NN in 33-D
// descriptor space with a descriptor gate and a ratio test on squared distances, a mutual (reverse 1-NN)
// check, and a cap that keeps the most distinctive pairs (smallest d1^2 / d2^2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "core/common/status.hpp"
#include "core/registration/submap_features.hpp"

namespace commerge {

struct FeatureMatchingParams {
  /// Ratio test d1^2 <= ratio_sq * d2^2 (spec 0.9, i.e. d1 / d2 <= 0.949); 1 disables it.
  double ratio_sq = 0.9;
  /// Descriptor gate d1 <= this (descriptors are three blocks summing to 100 each).
  double max_descriptor_distance = 30.0;
  /// Keep at most this many correspondences, the smallest d1^2 / d2^2 first (bounds the pruning graph).
  std::size_t max_correspondences = 5000;
  /// Keep a pair only when the reverse nearest neighbour points back.
  bool mutual = true;
  /// Keypoints whose descriptor lies closer than this to the flat-plane descriptor (100 in the middle bin of
  /// each block) do not take part: open road and facade interiors all look alike (see feature_matching.cpp).
  /// 0 keeps every keypoint (the reference behaviour; this filter and the cap below are ours).
  double min_saliency = 10.0;
  /// At most this many keypoints per submap take part, the most salient first (bounds the 33-D search; 2000
  /// or 2500 lost real pairs on bench_registration).
  std::size_t max_match_keypoints = 3000;
};

/// Squared distance of a kFpfhDims descriptor to the flat-plane descriptor (the saliency used above).
float FlatDescriptorDistanceSq(const float* descriptor);

/// InvalidArgument when ratio_sq is not in (0, 1], the gate is not finite and > 0, the cap is 0 or > 16384,
/// min_saliency is not in [0, 250) or max_match_keypoints < 2.
Status ValidateFeatureMatchingParams(const FeatureMatchingParams& params);

/// A putative point correspondence: source point index, target point index (into the submaps' points).
struct Correspondence {
  std::uint32_t source_index = 0;
  std::uint32_t target_index = 0;
  float descriptor_distance_sq = 0.0f;  ///< d1^2
  float ratio_sq = 0.0f;                ///< d1^2 / d2^2 (0 when there is no second neighbour)
};

struct FeatureMatchingStats {
  std::size_t num_queries = 0;         ///< descriptors of the smaller side
  std::size_t num_failed_gate = 0;     ///< d1 above max_descriptor_distance
  std::size_t num_failed_ratio = 0;
  std::size_t num_failed_mutual = 0;
  std::size_t num_capped = 0;          ///< dropped by max_correspondences
  std::size_t num_source_not_salient = 0;  ///< source keypoints left out (min_saliency, max_match_keypoints)
  std::size_t num_target_not_salient = 0;
};

/// Reusable matcher (keeps its 33-D k-d trees and scratch between calls). Not thread-safe.
class FeatureMatcher {
 public:
  FeatureMatcher();
  ~FeatureMatcher();
  FeatureMatcher(const FeatureMatcher&) = delete;
  FeatureMatcher& operator=(const FeatureMatcher&) = delete;

  /// Fills *out (cleared first) with correspondences ordered by ascending d1^2 / d2^2 (ties: by query index),
  /// a spatially scattered order that the chained rotation measurements of the robust solver rely on.
  /// Deterministic. `params` must be valid.
  FeatureMatchingStats Match(const SubmapFeatures& source, const SubmapFeatures& target,
                             const FeatureMatchingParams& params, std::vector<Correspondence>* out);

 private:
  struct Index;
  std::unique_ptr<Index> source_index_;
  std::unique_ptr<Index> target_index_;
};

}  // namespace commerge
