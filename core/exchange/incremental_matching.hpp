// SPDX-License-Identifier: BSD-3-Clause
// commerge: incremental stage A for one robot pair (paper "Inter-Robot Place Recognition" / "Inter-Robot
// Sequential Matching", issue: "when new keyframes arrive, only new rows/columns are computed").
//
// The server receives keyframe batches of robots alpha and beta over time. The matcher copies them into
// descriptor storage of fixed capacity (chosen at creation; appending beyond it is an error) and keeps a
// sorted store of the below-threshold cells found so far ("hits": alpha index, beta index, distance). An
// Update() computes only the affinity tiles of the new rows x all columns and of the old rows x the new
// columns, merges their hits and relabels the hit list (RunSequentialMatchingOnHits, which replays the
// streaming labelling), so its result equals the full RunSequentialMatching on the complete sets, field for
// field. The distance kernel is position independent (affinity.hpp), so the incrementally computed cells are
// the same floats as in a full pass.
//
// Memory bound: descriptors (capacity x dim floats each, reserved at creation, resident as they fill), the
// kernel's norms and beta pack (same order), one tile, and at most max_hits hits (<= 144 bytes each with
// the relabelling scratch, kIncrementalBytesPerHit). When an update would exceed max_hits (a too-loose tau_inter), the hit store is
// released and that update - and every later one, since hits only accumulate - is answered by the exact full
// streaming pass (O(N x M) time, O(N + M) memory); stats() counts these fallbacks.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/affinity.hpp"
#include "core/exchange/sequential_matching.hpp"

namespace commerge {

/// Bytes one stored hit may cost at worst: the store, its growth copy, the new-hit buffer and the merge
/// buffer (4 x 12), the relabelling's label, visit order and row directory (16), one union-find node (72).
constexpr std::size_t kIncrementalBytesPerHit = 144;
/// Default hit budget: 16 MiB, ~116k hits - a revisit band of 2000 keyframes x 50 cells wide fits.
constexpr std::size_t kDefaultIncrementalHitBudgetBytes = std::size_t{16} << 20;

/// Hit capacity that fits a byte budget (budget / kIncrementalBytesPerHit).
constexpr std::size_t IncrementalHitCapacityForBudget(std::size_t bytes) { return bytes / kIncrementalBytesPerHit; }

struct IncrementalMatchParams {
  SequentialMatchParams stage_a;    ///< tau_inter, tau_area and the tile grid (the result follows this grid)
  std::size_t dim = 40;             ///< descriptor length D, >= 1
  std::size_t alpha_capacity = 0;   ///< keyframes robot alpha may ever contribute, < 2^32
  std::size_t beta_capacity = 0;    ///< keyframes robot beta may ever contribute, < 2^32
  std::size_t max_hits = IncrementalHitCapacityForBudget(kDefaultIncrementalHitBudgetBytes);  ///< < 2^31
};

struct IncrementalMatchStats {
  std::size_t num_alpha = 0;               ///< alpha keyframes matched (as of the last Update)
  std::size_t num_beta = 0;                ///< beta keyframes matched
  std::uint64_t updates = 0;               ///< successful Update() calls
  std::uint64_t last_update_cells = 0;     ///< affinity cells the last Update computed
  std::uint64_t total_cells = 0;           ///< affinity cells computed since creation
  std::size_t num_hits = 0;                ///< hits in the store (0 once overflowed)
  bool overflowed = false;                 ///< the store hit max_hits: Updates now run the full pass
  bool last_update_full_pass = false;      ///< the last Update was answered by the full streaming pass
  std::uint64_t full_pass_fallbacks = 0;   ///< Updates answered by the full streaming pass
};

/// Incremental stage A of one robot pair. Not thread-safe; movable.
class IncrementalSequentialMatcher {
 public:
  /// Reserves the descriptor storage for the capacities (a start-up allocation; may throw std::bad_alloc).
  /// Errors: bad stage A parameters, a sequence_half_window other than 0 (not supported incrementally),
  /// dim 0, a capacity >= 2^32 or whose storage size overflows, max_hits >= 2^31.
  static Result<IncrementalSequentialMatcher> Create(const IncrementalMatchParams& params);

  /// Appends a batch of keyframes (copied; matched at the next Update). An empty batch is a no-op. Errors,
  /// with nothing appended: a malformed batch (ValidateDescriptorSet), another dim, the capacity exceeded.
  Status AppendAlpha(const DescriptorSetView& batch);
  Status AppendBeta(const DescriptorSetView& batch);

  /// Matches the keyframes appended since the last Update and returns stage A on everything received so far:
  /// the same result as RunSequentialMatching(alpha(), beta(), params.stage_a). Computes only the new cells
  /// (new_rows x M + N_old x new_cols), unless the hit store overflowed (see the file comment).
  Result<SequentialMatchResult> Update();

  DescriptorSetView alpha() const noexcept;  ///< every alpha keyframe appended (matched or not)
  DescriptorSetView beta() const noexcept;
  const IncrementalMatchStats& stats() const noexcept { return stats_; }
  Span<const CompactHit> hits() const noexcept { return hits_; }  ///< sorted row-major
  const IncrementalMatchParams& params() const noexcept { return params_; }

 private:
  Status Append(const DescriptorSetView& batch, std::size_t capacity, const char* name, std::vector<float>* values,
                std::vector<std::uint8_t>* flags);
  // Computes the tiles of [r0, r1) x [c0, c1); collects the hits into new_hits_. False when the store would
  // exceed max_hits.
  Result<bool> ComputeRegion(std::size_t r0, std::size_t r1, std::size_t c0, std::size_t c1);

  IncrementalMatchParams params_;
  std::vector<float> alpha_values_, beta_values_;  // reserved to capacity x dim: never reallocate
  std::vector<std::uint8_t> alpha_flags_, beta_flags_;
  AffinityTileKernel kernel_;
  std::vector<CompactHit> hits_, new_hits_;
  double min_distance_ = 0.0;  // smallest finite distance of the cells computed so far
  IncrementalMatchStats stats_;
};

}  // namespace commerge
