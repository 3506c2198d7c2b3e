// SPDX-License-Identifier: BSD-3-Clause
// Descriptor matching (../shared/spec/REGISTRATION.md §1.2 "Pipeline", step 8) by an exact brute-force pass over all
// descriptor pairs.
//
// Why brute force: a k-d tree in 33 dimensions visits most of its leaves anyway, and one pass over all pairs
// yields both the 2-NN of every query and the reverse 1-NN of every database row that the mutual check needs.
// The pass is a register-blocked kernel (4 queries x 8 database rows, 33 dimensions) written with the
// compiler's portable vector types; on x86-64 an AVX2 clone is chosen at load time (the arithmetic is the same
// sequence of IEEE multiplies and adds in every clone, so the results are identical).
//
// Cost control: in a submap voxelised at 1 m about half of the keypoints lie on open planes (road, facades)
// and carry the same "flat" descriptor (every pair feature in the middle bin). They form one dense cluster in
// descriptor space where almost every query fails the ratio test, so only keypoints whose descriptor differs
// from the flat one by >= min_saliency take part, at most max_match_keypoints per submap (the most salient;
// ties by index).
#include "core/registration/feature_matching.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#if defined(__x86_64__) && defined(__GNUC__)
#define CM_DESCRIPTOR_KERNEL_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define CM_DESCRIPTOR_KERNEL_CLONES
#endif
#if defined(__GNUC__)
// The vector helpers below are file-local and always inlined: no 32-byte vector crosses a call boundary, so
// the ABI note GCC gives for AVX-sized vectors without AVX does not apply.
#pragma GCC diagnostic ignored "-Wpsabi"
#define CM_ALWAYS_INLINE __attribute__((always_inline)) inline
#else
#define CM_ALWAYS_INLINE inline
#endif

namespace commerge {
namespace {

constexpr int kLanes = 8;      // database rows per block
constexpr int kQueryRows = 4;  // query rows per register block
constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
// Padding rows of the database sit this far from everything: their squared distances (~3e31) never win.
constexpr float kFarAway = 1e15f;
using Vec8f = float __attribute__((vector_size(32)));
using Vec8i = std::int32_t __attribute__((vector_size(32)));

// Vectors go in and out of the helpers by pointer or reference, never by value: clang (14) refuses a 32-byte
// vector passed or returned by value when the caller lacks AVX (the default clone), even always inlined.
template <class V, class T>
CM_ALWAYS_INLINE void LoadVec(const T* p, V* v) {
  std::memcpy(v, p, sizeof(*v));
}
template <class V, class T>
CM_ALWAYS_INLINE void StoreVec(T* p, const V& v) {
  std::memcpy(p, &v, sizeof(v));
}
CM_ALWAYS_INLINE void Select(const Vec8i& mask, const Vec8f& a, const Vec8f& b, Vec8f* out) {  // mask ? a : b
  Vec8i ia, ib;
  LoadVec(&a, &ia);
  LoadVec(&b, &ib);
  const Vec8i r = (ia & mask) | (ib & ~mask);
  LoadVec(&r, out);
}

// All pairs of `queries` (num_queries rows, padded with readable rows to a multiple of kQueryRows) and the
// database `blocks` (num_blocks x kFpfhDims x kLanes: rows transposed per block, padding rows kFarAway).
// Per query (ascending database order, strict "<", so the lowest index wins ties): row_d1/row_i1 nearest,
// row_d2 second. Per database row: col_d/col_i nearest query (strict "<" over ascending queries).
CM_DESCRIPTOR_KERNEL_CLONES
void ScanAllPairs(const float* queries, std::size_t num_queries, const float* blocks, std::size_t num_blocks,
                  std::size_t num_database, float* row_d1, float* row_d2, std::uint32_t* row_i1, float* col_d,
                  std::int32_t* col_i) {
  for (std::size_t q0 = 0; q0 < num_queries; q0 += kQueryRows) {
    const float* q = queries + q0 * kFpfhDims;
    const std::size_t rows = std::min<std::size_t>(kQueryRows, num_queries - q0);
    for (std::size_t b = 0; b < num_blocks; ++b) {
      const float* blk = blocks + b * kFpfhDims * kLanes;
      // Four named accumulators (not an array) so that they live in registers.
      Vec8f a0 = {}, a1 = {}, a2 = {}, a3 = {};
      for (int d = 0; d < kFpfhDims; ++d) {
        Vec8f v;
        LoadVec(blk + d * kLanes, &v);
        const Vec8f e0 = q[d] - v;
        const Vec8f e1 = q[kFpfhDims + d] - v;
        const Vec8f e2 = q[2 * kFpfhDims + d] - v;
        const Vec8f e3 = q[3 * kFpfhDims + d] - v;
        a0 += e0 * e0;
        a1 += e1 * e1;
        a2 += e2 * e2;
        a3 += e3 * e3;
      }
      const Vec8f acc[kQueryRows] = {a0, a1, a2, a3};
      Vec8f cd;
      Vec8i ci;
      LoadVec(col_d + b * kLanes, &cd);
      LoadVec(col_i + b * kLanes, &ci);
      for (std::size_t r = 0; r < rows; ++r) {
        const Vec8i closer = acc[r] < cd;
        Select(closer, acc[r], cd, &cd);
        ci = (closer & static_cast<std::int32_t>(q0 + r)) | (ci & ~closer);
        float& d1 = row_d1[q0 + r];
        float& d2 = row_d2[q0 + r];
        // Most blocks hold nothing closer than the query's current second nearest: one vector compare skips
        // them (the lane loop below re-checks every lane, so the outcome is the same).
        const Vec8i below = acc[r] < d2;
        std::uint64_t any[4];
        StoreVec(any, below);
        if ((any[0] | any[1] | any[2] | any[3]) == 0) continue;
        float lane_d[kLanes];
        StoreVec(lane_d, acc[r]);
        for (int l = 0; l < kLanes; ++l) {
          const float dist = lane_d[l];
          if (!(dist < d2)) continue;
          const std::size_t j = b * kLanes + static_cast<std::size_t>(l);
          if (j >= num_database) break;
          if (dist < d1) {
            d2 = d1;
            d1 = dist;
            row_i1[q0 + r] = static_cast<std::uint32_t>(j);
          } else {
            d2 = dist;
          }
        }
      }
      StoreVec(col_d + b * kLanes, cd);
      StoreVec(col_i + b * kLanes, ci);
    }
  }
}

// Fills `out` with the salient keypoints of `f` (see the file comment).
void SelectSalient(const SubmapFeatures& f, const FeatureMatchingParams& params,
                   std::vector<std::pair<float, std::uint32_t>>* ranking, FeatureMatcher::Selection* out,
                   std::size_t* num_dropped) {
  const std::vector<float>& all = f.descriptors();
  const std::size_t n = f.keypoints().size();
  ranking->clear();
  const auto min_s2 = static_cast<float>(params.min_saliency * params.min_saliency);
  for (std::size_t k = 0; k < n; ++k) {
    const float s2 = FlatDescriptorDistanceSq(all.data() + k * kFpfhDims);
    if (s2 >= min_s2) ranking->emplace_back(-s2, static_cast<std::uint32_t>(k));
  }
  if (ranking->size() > params.max_match_keypoints) {
    std::nth_element(ranking->begin(), ranking->begin() + static_cast<std::ptrdiff_t>(params.max_match_keypoints),
                     ranking->end());
    ranking->resize(params.max_match_keypoints);
  }
  // Back to keypoint order so that the query order (and the tie-breaks) do not depend on the ranking.
  std::sort(ranking->begin(), ranking->end(),
            [](const std::pair<float, std::uint32_t>& a, const std::pair<float, std::uint32_t>& b) {
              return a.second < b.second;
            });
  *num_dropped = n - ranking->size();
  out->descriptors.resize(ranking->size() * kFpfhDims);
  out->point.resize(ranking->size());
  for (std::size_t m = 0; m < ranking->size(); ++m) {
    const std::uint32_t k = (*ranking)[m].second;
    std::copy_n(all.data() + static_cast<std::size_t>(k) * kFpfhDims, kFpfhDims, out->descriptors.data() + m * kFpfhDims);
    out->point[m] = f.keypoints()[k];
  }
}

}  // namespace

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
  if (p.max_match_keypoints < 2 || p.max_match_keypoints > 100000) {
    return InvalidArgument("registration matching: max_match_keypoints must be in [2, 100000]");
  }
  return Status::Ok();
}

void FindDescriptorNeighbors(const float* queries, std::size_t num_queries, const float* database,
                             std::size_t num_database, std::vector<float>* scratch, DescriptorNeighbors* out) {
  out->nearest.assign(num_queries, kNone);
  out->d1_sq.assign(num_queries, std::numeric_limits<float>::infinity());
  out->d2_sq.assign(num_queries, std::numeric_limits<float>::infinity());
  out->reverse_nearest.assign(num_database, kNone);
  if (num_queries == 0 || num_database == 0) return;
  const std::size_t num_blocks = (num_database + kLanes - 1) / kLanes;
  const std::size_t padded_queries = (num_queries + kQueryRows - 1) / kQueryRows * kQueryRows;
  // scratch: [transposed database blocks | padded queries | column distances | column indices (as int32)]
  const std::size_t block_floats = num_blocks * kFpfhDims * kLanes;
  const std::size_t query_floats = padded_queries * kFpfhDims;
  const std::size_t column_floats = num_blocks * kLanes;
  scratch->resize(block_floats + query_floats + 2 * column_floats);
  float* blocks = scratch->data();
  float* padded = blocks + block_floats;
  float* col_d = padded + query_floats;
  auto* col_i = reinterpret_cast<std::int32_t*>(col_d + column_floats);
  static_assert(sizeof(float) == sizeof(std::int32_t), "column indices share the float scratch");
  for (std::size_t j = 0; j < num_blocks * kLanes; ++j) {
    float* dst = blocks + (j / kLanes) * kFpfhDims * kLanes + j % kLanes;
    for (int d = 0; d < kFpfhDims; ++d) dst[d * kLanes] = j < num_database ? database[j * kFpfhDims + d] : kFarAway;
  }
  std::copy_n(queries, num_queries * kFpfhDims, padded);
  std::fill(padded + num_queries * kFpfhDims, padded + query_floats, 0.0f);
  std::fill(col_d, col_d + column_floats, std::numeric_limits<float>::infinity());
  std::fill(col_i, col_i + column_floats, -1);
  ScanAllPairs(padded, num_queries, blocks, num_blocks, num_database, out->d1_sq.data(), out->d2_sq.data(),
               out->nearest.data(), col_d, col_i);
  for (std::size_t j = 0; j < num_database; ++j) out->reverse_nearest[j] = static_cast<std::uint32_t>(col_i[j]);
}

FeatureMatchingStats FeatureMatcher::Match(const SubmapFeatures& source, const SubmapFeatures& target,
                                           const FeatureMatchingParams& params, std::vector<Correspondence>* out) {
  out->clear();
  FeatureMatchingStats stats;
  SelectSalient(source, params, &ranking_, &source_, &stats.num_source_not_salient);
  SelectSalient(target, params, &ranking_, &target_, &stats.num_target_not_salient);
  // Queries come from the side with fewer descriptors, searched in the larger side.
  const bool source_is_query = source_.size() <= target_.size();
  const Selection& big = source_is_query ? target_ : source_;
  const Selection& small = source_is_query ? source_ : target_;
  if (big.size() == 0 || small.size() == 0) return stats;
  FindDescriptorNeighbors(small.descriptors.data(), small.size(), big.descriptors.data(), big.size(), &scratch_,
                          &neighbors_);

  const auto gate_sq = static_cast<float>(params.max_descriptor_distance * params.max_descriptor_distance);
  const auto ratio_sq = static_cast<float>(params.ratio_sq);
  stats.num_queries = small.size();
  for (std::size_t q = 0; q < small.size(); ++q) {
    const std::uint32_t i = neighbors_.nearest[q];
    const float d1 = neighbors_.d1_sq[q];
    const float d2 = neighbors_.d2_sq[q];
    if (!(d1 <= gate_sq)) {
      ++stats.num_failed_gate;
      continue;
    }
    if (!(d1 <= ratio_sq * d2)) {
      ++stats.num_failed_ratio;
      continue;
    }
    if (params.mutual && neighbors_.reverse_nearest[i] != q) {
      ++stats.num_failed_mutual;
      continue;
    }
    Correspondence c;
    c.source_index = source_is_query ? small.point[q] : big.point[i];
    c.target_index = source_is_query ? big.point[i] : small.point[q];
    c.descriptor_distance_sq = d1;
    c.ratio_sq = std::isfinite(d2) && d2 > 0.0f ? d1 / d2 : 0.0f;
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

std::size_t FeatureMatcher::workspace_bytes() const noexcept {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return held(source_.descriptors) + held(source_.point) + held(target_.descriptors) + held(target_.point) +
         held(ranking_) + held(scratch_) + held(neighbors_.nearest) + held(neighbors_.d1_sq) + held(neighbors_.d2_sq) +
         held(neighbors_.reverse_nearest);
}

}  // namespace commerge
