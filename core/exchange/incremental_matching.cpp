// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/incremental_matching.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

namespace commerge {
namespace {

bool RowMajorLess(const CompactHit& a, const CompactHit& b) {
  return a.alpha_index != b.alpha_index ? a.alpha_index < b.alpha_index : a.beta_index < b.beta_index;
}

}  // namespace

Result<IncrementalSequentialMatcher> IncrementalSequentialMatcher::Create(const IncrementalMatchParams& params) {
  Status s = ValidateSequentialMatchParams(params.stage_a);
  if (!s.ok()) return s;
  if (params.dim == 0) return InvalidArgument("incremental matching: descriptor dimension must be >= 1");
  if (params.stage_a.sequence_half_window != 0) {
    return InvalidArgument("incremental matching: sequence smoothing (sequence_half_window " +
                           std::to_string(params.stage_a.sequence_half_window) +
                           ") changes cells near the old borders when keyframes arrive; use the full "
                           "RunSequentialMatching for it");
  }
  if (params.stage_a.neighbour_rank != 0) {
    return InvalidArgument("incremental matching: neighbour_rank " + std::to_string(params.stage_a.neighbour_rank) +
                           " ranks each row and column over the whole matrix, which changes as keyframes arrive; "
                           "use the full RunSequentialMatching for it");
  }
  constexpr std::size_t kMaxIndex = std::numeric_limits<std::uint32_t>::max();
  for (const std::size_t capacity : {params.alpha_capacity, params.beta_capacity}) {
    if (capacity > kMaxIndex || capacity > std::numeric_limits<std::size_t>::max() / sizeof(float) / params.dim) {
      return InvalidArgument("incremental matching: capacity " + std::to_string(capacity) + " x dim " +
                             std::to_string(params.dim) + " is out of range (at most 2^32 - 1 keyframes)");
    }
  }
  if (params.max_hits > static_cast<std::size_t>(std::numeric_limits<std::int32_t>::max())) {
    return InvalidArgument("incremental matching: max_hits " + std::to_string(params.max_hits) +
                           " is above 2^31 - 1");
  }
  IncrementalSequentialMatcher m;
  m.params_ = params;
  m.alpha_values_.reserve(params.alpha_capacity * params.dim);
  m.beta_values_.reserve(params.beta_capacity * params.dim);
  m.alpha_flags_.reserve(params.alpha_capacity);
  m.beta_flags_.reserve(params.beta_capacity);
  Result<AffinityTileKernel> kernel =
      AffinityTileKernel::Create(m.alpha(), m.beta(), params.stage_a.tile_rows, params.stage_a.tile_cols);
  if (!kernel.ok()) return kernel.status();
  m.kernel_ = std::move(kernel.value());
  m.kernel_.Reserve(params.alpha_capacity, params.beta_capacity);
  m.min_distance_ = std::numeric_limits<double>::infinity();
  return m;
}

DescriptorSetView IncrementalSequentialMatcher::alpha() const noexcept {
  return DescriptorSetView{Span<const float>(alpha_values_), params_.dim, Span<const std::uint8_t>(alpha_flags_)};
}

DescriptorSetView IncrementalSequentialMatcher::beta() const noexcept {
  return DescriptorSetView{Span<const float>(beta_values_), params_.dim, Span<const std::uint8_t>(beta_flags_)};
}

Status IncrementalSequentialMatcher::AppendAlpha(const DescriptorSetView& batch) {
  return Append(batch, params_.alpha_capacity, "alpha", &alpha_values_, &alpha_flags_);
}

Status IncrementalSequentialMatcher::AppendBeta(const DescriptorSetView& batch) {
  return Append(batch, params_.beta_capacity, "beta", &beta_values_, &beta_flags_);
}

Status IncrementalSequentialMatcher::Append(const DescriptorSetView& batch, std::size_t capacity, const char* name,
                                            std::vector<float>* values, std::vector<std::uint8_t>* flags) {
  const std::string what = std::string("incremental matching: ") + name + " batch";
  Status s = ValidateDescriptorSet(batch, what.c_str());
  if (!s.ok()) return s;
  if (batch.dim != params_.dim) {
    return InvalidArgument(what + " has dimension " + std::to_string(batch.dim) + ", the matcher " +
                           std::to_string(params_.dim));
  }
  const std::size_t have = flags->size(), add = batch.count();
  if (add > capacity - have) {
    return ResourceExhausted(what + " of " + std::to_string(add) + " keyframes exceeds the capacity: " +
                             std::to_string(have) + " of " + std::to_string(capacity) + " used");
  }
  values->insert(values->end(), batch.values.begin(), batch.values.end());  // within the reserved capacity
  if (batch.valid.empty()) {
    flags->insert(flags->end(), add, std::uint8_t{1});
  } else {
    flags->insert(flags->end(), batch.valid.begin(), batch.valid.end());
  }
  return Status::Ok();
}

Result<bool> IncrementalSequentialMatcher::ComputeRegion(std::size_t r0, std::size_t r1, std::size_t c0,
                                                         std::size_t c1) {
  const std::size_t tr = params_.stage_a.tile_rows, tc = params_.stage_a.tile_cols;
  const auto tau = static_cast<float>(params_.stage_a.tau_inter);
  AffinityTile t;
  for (std::size_t r = r0; r < r1; r += std::min(tr, r1 - r)) {
    for (std::size_t c = c0; c < c1; c += std::min(tc, c1 - c)) {
      Status s = kernel_.ComputeTile(r, c, std::min(tr, r1 - r), std::min(tc, c1 - c), &t);
      if (!s.ok()) return s;
      if (std::isfinite(t.min_distance) && static_cast<double>(t.min_distance) < min_distance_) {
        min_distance_ = static_cast<double>(t.min_distance);
      }
      if (!(t.min_distance <= tau)) continue;  // no hit in this tile
      for (std::size_t i = 0; i < t.rows; ++i) {
        const float* row = t.distances + i * t.stride;
        for (std::size_t j = 0; j < t.cols; ++j) {
          if (!(row[j] <= tau)) continue;
          if (hits_.size() + new_hits_.size() >= params_.max_hits) return false;
          new_hits_.push_back({static_cast<std::uint32_t>(t.row_begin + i), static_cast<std::uint32_t>(t.col_begin + j),
                               row[j]});
        }
      }
    }
  }
  return true;
}

Result<SequentialMatchResult> IncrementalSequentialMatcher::Update() {
  const std::size_t n0 = stats_.num_alpha, m0 = stats_.num_beta;
  const std::size_t n1 = alpha_flags_.size(), m1 = beta_flags_.size();
  const std::uint64_t cells_before = kernel_.cells_computed();
  Status s = kernel_.Extend(alpha(), beta());  // norms and packs of the new keyframes only
  if (!s.ok()) return s;

  bool full_pass = stats_.overflowed;
  if (!full_pass) {
    new_hits_.clear();
    Result<bool> fits = ComputeRegion(n0, n1, 0, m1);  // new rows x all columns
    if (fits.ok() && *fits) fits = ComputeRegion(0, n0, m0, m1);  // old rows x new columns
    if (!fits.ok()) return fits.status();
    if (!*fits) {  // too many hits for the store: release it, exact full pass from now on
      stats_.overflowed = true;
      full_pass = true;
      std::vector<CompactHit>().swap(hits_);
      std::vector<CompactHit>().swap(new_hits_);
    }
  }

  Result<SequentialMatchResult> result = Status(StatusCode::kInternal, "incremental matching: no result");
  if (full_pass) {
    result = RunSequentialMatching(kernel_, params_.stage_a);
  } else {
    std::sort(new_hits_.begin(), new_hits_.end(), RowMajorLess);
    const auto old_size = static_cast<std::ptrdiff_t>(hits_.size());
    hits_.insert(hits_.end(), new_hits_.begin(), new_hits_.end());
    std::inplace_merge(hits_.begin(), hits_.begin() + old_size, hits_.end(), RowMajorLess);
    new_hits_.clear();
    result = RunSequentialMatchingOnHits(hits_, n1, m1, min_distance_, params_.stage_a);
  }
  if (!result.ok()) return result.status();

  stats_.num_alpha = n1;
  stats_.num_beta = m1;
  ++stats_.updates;
  stats_.last_update_cells = kernel_.cells_computed() - cells_before;
  stats_.total_cells += stats_.last_update_cells;
  stats_.num_hits = hits_.size();
  stats_.last_update_full_pass = full_pass;
  if (full_pass) ++stats_.full_pass_fallbacks;
  return result;
}

}  // namespace commerge
