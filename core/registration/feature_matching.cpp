// SPDX-License-Identifier: BSD-3-Clause
// Descriptor matching (REGISTRATION.md §1.2 step 8) with exact 33-D k-d trees (nanoflann).
//
// Cost control: in a submap voxelised at 1 m about half of the keypoints lie on open planes (road, facades)
// and carry the same "flat" descriptor (every pair feature in the middle bin). They form one dense cluster in
// descriptor space where every search is expensive and almost every query fails the ratio test, so only
// keypoints whose descriptor differs from the flat one by >= min_saliency take part, at most
// max_match_keypoints per submap (the most salient; ties by index).
#include "core/registration/feature_matching.hpp"

#include <nanoflann.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace commerge {

struct FeatureMatcher::Index {
  struct Adaptor {
    const float* data = nullptr;
    std::size_t count = 0;
    std::size_t kdtree_get_point_count() const { return count; }
    float kdtree_get_pt(std::size_t i, std::size_t dim) const { return data[i * kFpfhDims + dim]; }
    template <class BBox>
    bool kdtree_get_bbox(BBox&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Adaptor<float, Adaptor>, Adaptor, kFpfhDims,
                                                   std::uint32_t>;
  Adaptor adaptor;
  std::unique_ptr<Tree> tree;
  std::vector<float> descriptors;    // selected descriptors, row-major
  std::vector<std::uint32_t> point;  // point index of each selected descriptor
  std::vector<std::pair<float, std::uint32_t>> ranking;

  // Selects the salient keypoints of `f` and indexes their descriptors.
  void Build(const SubmapFeatures& f, const FeatureMatchingParams& params, std::size_t* num_dropped) {
    const std::vector<float>& all = f.descriptors();
    const std::size_t n = f.keypoints().size();
    ranking.clear();
    const auto min_s2 = static_cast<float>(params.min_saliency * params.min_saliency);
    for (std::size_t k = 0; k < n; ++k) {
      const float s2 = FlatDescriptorDistanceSq(all.data() + k * kFpfhDims);
      if (s2 >= min_s2) ranking.emplace_back(-s2, static_cast<std::uint32_t>(k));
    }
    if (ranking.size() > params.max_match_keypoints) {
      std::nth_element(ranking.begin(), ranking.begin() + static_cast<std::ptrdiff_t>(params.max_match_keypoints),
                       ranking.end());
      ranking.resize(params.max_match_keypoints);
    }
    // Back to keypoint order so that the query order (and the tie-breaks) do not depend on the ranking.
    std::sort(ranking.begin(), ranking.end(),
              [](const std::pair<float, std::uint32_t>& a, const std::pair<float, std::uint32_t>& b) {
                return a.second < b.second;
              });
    *num_dropped = n - ranking.size();
    descriptors.resize(ranking.size() * kFpfhDims);
    point.resize(ranking.size());
    for (std::size_t m = 0; m < ranking.size(); ++m) {
      const std::uint32_t k = ranking[m].second;
      std::copy_n(all.data() + static_cast<std::size_t>(k) * kFpfhDims, kFpfhDims, descriptors.data() + m * kFpfhDims);
      point[m] = f.keypoints()[k];
    }
    adaptor.data = descriptors.data();
    adaptor.count = ranking.size();
    if (adaptor.count == 0) return;
    if (!tree) {
      tree = std::make_unique<Tree>(kFpfhDims, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    } else {
      tree->buildIndex();
    }
  }
  std::size_t size() const { return adaptor.count; }
  const float* row(std::size_t i) const { return descriptors.data() + i * kFpfhDims; }
  std::size_t Knn(const float* query, std::size_t k, std::uint32_t* idx, float* d2) const {
    if (adaptor.count == 0) return 0;
    nanoflann::KNNResultSet<float, std::uint32_t> rs(static_cast<std::uint32_t>(k));
    rs.init(idx, d2);
    tree->findNeighbors(rs, query, nanoflann::SearchParams());
    return rs.size();
  }
};

float FlatDescriptorDistanceSq(const float* descriptor) {
  float s = 0.0f;
  for (int b = 0; b < kFpfhDims; ++b) {
    const float e = descriptor[b] - (b % kFpfhBins == kFpfhBins / 2 ? 100.0f : 0.0f);
    s += e * e;
  }
  return s;
}

Status ValidateFeatureMatchingParams(const FeatureMatchingParams& p) {
  if (!(p.ratio_sq > 0.0 && p.ratio_sq <= 1.0)) {
    return InvalidArgument("registration matching: ratio_sq must be in (0, 1]");
  }
  if (!(std::isfinite(p.max_descriptor_distance) && p.max_descriptor_distance > 0.0)) {
    return InvalidArgument("registration matching: max_descriptor_distance must be finite and > 0");
  }
  if (p.max_correspondences == 0 || p.max_correspondences > 16384) {
    return InvalidArgument("registration matching: max_correspondences must be in [1, 16384], got " +
                           std::to_string(p.max_correspondences));
  }
  if (!(p.min_saliency >= 0.0 && p.min_saliency < 250.0)) {
    return InvalidArgument("registration matching: min_saliency must be in [0, 250)");
  }
  if (p.max_match_keypoints < 2) return InvalidArgument("registration matching: max_match_keypoints must be >= 2");
  return Status::Ok();
}

FeatureMatcher::FeatureMatcher() : source_index_(std::make_unique<Index>()), target_index_(std::make_unique<Index>()) {}
FeatureMatcher::~FeatureMatcher() = default;

FeatureMatchingStats FeatureMatcher::Match(const SubmapFeatures& source, const SubmapFeatures& target,
                                           const FeatureMatchingParams& params, std::vector<Correspondence>* out) {
  out->clear();
  FeatureMatchingStats stats;
  source_index_->Build(source, params, &stats.num_source_not_salient);
  target_index_->Build(target, params, &stats.num_target_not_salient);
  // Queries come from the side with fewer descriptors (j), searched in the larger side (i).
  const bool source_is_query = source_index_->size() <= target_index_->size();
  const Index& big = source_is_query ? *target_index_ : *source_index_;
  const Index& small = source_is_query ? *source_index_ : *target_index_;
  if (big.size() == 0 || small.size() == 0) return stats;

  const auto gate_sq = static_cast<float>(params.max_descriptor_distance * params.max_descriptor_distance);
  const auto ratio_sq = static_cast<float>(params.ratio_sq);
  stats.num_queries = small.size();
  for (std::size_t q = 0; q < small.size(); ++q) {
    std::uint32_t idx[2] = {0, 0};
    float d2[2] = {0.0f, std::numeric_limits<float>::infinity()};
    const std::size_t found = big.Knn(small.row(q), 2, idx, d2);
    if (found == 0) continue;
    if (found < 2) d2[1] = std::numeric_limits<float>::infinity();
    if (!(d2[0] <= gate_sq)) {
      ++stats.num_failed_gate;
      continue;
    }
    if (!(d2[0] <= ratio_sq * d2[1])) {
      ++stats.num_failed_ratio;
      continue;
    }
    if (params.mutual) {
      std::uint32_t back = 0;
      float back_d2 = 0.0f;
      if (small.Knn(big.row(idx[0]), 1, &back, &back_d2) != 1 || back != q) {
        ++stats.num_failed_mutual;
        continue;
      }
    }
    Correspondence c;
    c.source_index = source_is_query ? small.point[q] : big.point[idx[0]];
    c.target_index = source_is_query ? big.point[idx[0]] : small.point[q];
    c.descriptor_distance_sq = d2[0];
    c.ratio_sq = std::isfinite(d2[1]) && d2[1] > 0.0f ? d2[0] / d2[1] : 0.0f;
    out->push_back(c);
  }
  // Most distinctive first; stable keeps the query order among equal ratios (deterministic).
  std::stable_sort(out->begin(), out->end(),
                   [](const Correspondence& a, const Correspondence& b) { return a.ratio_sq < b.ratio_sq; });
  if (out->size() > params.max_correspondences) {
    stats.num_capped = out->size() - params.max_correspondences;
    out->resize(params.max_correspondences);
  }
  return stats;
}

}  // namespace commerge
