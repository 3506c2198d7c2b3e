// SPDX-License-Identifier: BSD-3-Clause
// commerge: descriptor correspondences between two submaps (../shared/spec/REGISTRATION.md §1.2 "Pipeline", step 8):
// 2-NN in 33-D descriptor space with a descriptor gate and a ratio test on squared distances, a mutual (reverse 1-NN)
// check, and a cap that keeps the most distinctive pairs (smallest d1^2 / d2^2).
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
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
  /// At most this many keypoints per submap take part, the most salient first: bounds the 33-D search without
  /// losing real pairs (core/agent/decisions/016-registration-neighbour-and-keypoint-caps.md).
  std::size_t max_match_keypoints = 3000;
};

/// Squared distance of a kFpfhDims descriptor to the flat-plane descriptor (the saliency used above).
float FlatDescriptorDistanceSq(const float* descriptor);

/// InvalidArgument when ratio_sq is not in (0, 1], the gate is not finite and > 0, the cap is 0 or > 16384,
/// min_saliency is not in [0, 250) or max_match_keypoints is not in [2, 100000].
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

/// Result of a brute-force nearest-neighbour pass between query and database descriptors (kFpfhDims each).
struct DescriptorNeighbors {
  /// Per query: its nearest database row (UINT32_MAX when the database is empty), d1^2 and the second
  /// smallest d2^2 (infinity when there is none). Ties: the lowest database index is the nearest.
  std::vector<std::uint32_t> nearest;
  std::vector<float> d1_sq;
  std::vector<float> d2_sq;
  /// Per database row: its nearest query row (UINT32_MAX when there are no queries); ties: lowest index.
  std::vector<std::uint32_t> reverse_nearest;
};

/// Exact 2-NN of every query row in the database and 1-NN of every database row in the queries, in one pass
/// over all pairs (no N x M matrix: blocks of 4 queries x 8 database rows stay in registers). Row-major
/// inputs; `scratch` keeps its capacity between calls. Every value must be finite.
void FindDescriptorNeighbors(const float* queries, std::size_t num_queries, const float* database,
                             std::size_t num_database, std::vector<float>* scratch, DescriptorNeighbors* out);

/// Reusable matcher (keeps the selected descriptors and scratch between calls). Not thread-safe.
class FeatureMatcher {
 public:
  FeatureMatcher() = default;

  /// Fills *out (cleared first) with correspondences ordered by ascending d1^2 / d2^2 (ties: by query index),
  /// a spatially scattered order that the chained rotation measurements of the robust solver rely on.
  /// Deterministic. `params` must be valid.
  FeatureMatchingStats Match(const SubmapFeatures& source, const SubmapFeatures& target,
                             const FeatureMatchingParams& params, std::vector<Correspondence>* out);

  /// Salient keypoints of one submap (see FeatureMatchingParams::min_saliency and max_match_keypoints).
  struct Selection {
    std::vector<float> descriptors;    // row-major
    std::vector<std::uint32_t> point;  // point index of each selected descriptor
    std::size_t size() const noexcept { return point.size(); }
  };

  /// Bytes held: the selected descriptors, ranking, scratch and neighbour lists (capacities).
  std::size_t workspace_bytes() const noexcept;

 private:
  Selection source_;
  Selection target_;
  std::vector<std::pair<float, std::uint32_t>> ranking_;
  std::vector<float> scratch_;
  DescriptorNeighbors neighbors_;
};

}  // namespace commerge
