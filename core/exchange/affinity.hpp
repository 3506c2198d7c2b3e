// SPDX-License-Identifier: BSD-3-Clause
// commerge: inter-robot affinity A_ij = ||D^alpha_i - D^beta_j||_2 (paper "Inter-Robot Place Recognition",
// SOLID.md §2) computed tile by tile, so the dense N x M matrix never exists in memory. A tile kernel forms
// the distances of a block of rows x columns GEMM style, d = sqrt(max(0, ||a||^2 + ||b||^2 - 2 a.b)), and hands
// the block to a consumer. Memory: the two descriptor sets (borrowed), O(N + M) norms, one beta copy packed
// for the register-blocked product (~M x D floats), one tile.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// Borrowed descriptors of one robot: `count()` rows of `dim` floats, row-major, each row a unit-normalised
/// R-SOLiD (SOLID.md §2.1). A keyframe is invalid (never matches, distance +inf) when its flag is 0, when a
/// value is not finite, or when its squared norm (rounded to float) is 0 or above kMaxDescriptorNorm2.
/// Largest squared norm of a valid keyframe. Far above any real descriptor (unit R-SOLiD: 1); keeps every
/// float product and sum of the kernel finite, so a huge (untrusted) vector can never produce NaN or 0.
constexpr float kMaxDescriptorNorm2 = 1e30f;

struct DescriptorSetView {
  Span<const float> values;         ///< count x dim floats, row-major
  std::size_t dim = 0;              ///< descriptor length D (40 for the SOLiD presets), >= 1
  Span<const std::uint8_t> valid;   ///< empty = every keyframe flagged valid; else count flags (0 = invalid)

  std::size_t count() const noexcept { return dim == 0 ? 0 : values.size() / dim; }
};

/// How the server compares two descriptors (stage A's affinity, the place ambiguity, the descriptor agreement).
struct DescriptorMetric {
  enum class Kind : std::uint8_t {
    kUnitL2,       ///< L2 distance of unit vectors (R-SOLiD, the ring descriptor): the tile kernel below
    kScanContext,  ///< the Scan Context distance, min over column shifts (ScanContextTileSource, MatchScanContext)
  };
  Kind kind = Kind::kUnitL2;
  int scan_context_rings = 20;    ///< kScanContext: the grid of the descriptors
  int scan_context_sectors = 60;
};

/// The metric's distance of two descriptors of one set's dim (unit L2: SolidDistance, in [0, 2] for unit
/// vectors; Scan Context: MatchScanContext, in [0, 1] for non-negative cells, 1 when no column is non-empty in
/// both).
double DescriptorDistance(const DescriptorMetric& metric, Span<const float> a, Span<const float> b) noexcept;

/// Checks dim >= 1, values.size() a multiple of dim and valid.size() in {0, count}. `name` prefixes messages.
Status ValidateDescriptorSet(const DescriptorSetView& set, const char* name);

/// One block of the affinity matrix: distances of alpha rows [row_begin, row_begin + rows) to beta columns
/// [col_begin, col_begin + cols). Element (r, c) is at distances[r * stride + c]; +inf for an invalid pair.
struct AffinityTile {
  std::size_t row_begin = 0;
  std::size_t col_begin = 0;
  std::size_t rows = 0;
  std::size_t cols = 0;
  std::size_t stride = 0;            ///< floats between consecutive rows, >= cols
  const float* distances = nullptr;  ///< unit-L2 distances in [0, sqrt(2)] or +inf; valid until the next call
  /// Smallest element of the tile (+inf when every pair is invalid); NaN = not provided by the source.
  /// Consumers use it to skip tiles without a cell below their threshold.
  float min_distance = std::numeric_limits<float>::quiet_NaN();

  float at(std::size_t r, std::size_t c) const noexcept { return distances[r * stride + c]; }
  /// A dense block (stride = cols) of `data`, with its minimum.
  static AffinityTile Dense(std::size_t row_begin, std::size_t col_begin, std::size_t rows, std::size_t cols,
                            const float* data, float min_distance) noexcept {
    return {row_begin, col_begin, rows, cols, cols, data, min_distance};
  }
};

/// Anything that can produce affinity tiles on demand (the descriptor kernel; tests use a stored matrix).
/// A source must be deterministic: the same tile request yields bit-identical values.
class AffinityTileSource {
 public:
  virtual ~AffinityTileSource() = default;
  virtual std::size_t num_rows() const noexcept = 0;  ///< N (alpha keyframes)
  virtual std::size_t num_cols() const noexcept = 0;  ///< M (beta keyframes)
  /// Fills *tile with rows [row_begin, row_begin + rows) x cols [col_begin, col_begin + cols). Error when the
  /// block is outside the matrix, empty, or larger than the source's tile capacity.
  virtual Status ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows, std::size_t cols,
                             AffinityTile* tile) = 0;
};

/// GEMM-style tile kernel over two descriptor sets (float, register-blocked: 6 alpha rows x 8 beta columns
/// per micro block, beta packed once in 8-column panels, swept in L1-sized column chunks). The distance form ||a||^2 + ||b||^2 - 2 a.b cancels
/// near d = 0 (absolute error in d up to ~1e-3 there, ~1e-6 at d = 0.1); irrelevant for the thresholds
/// 0.01 ... 0.10. Every tile reports its minimum (AffinityTile::min_distance).
///
/// Position independence: the value of cell (i, j) is the same float whatever tile it is computed in (same
/// instruction sequence for every cell; partial blocks are padded, never computed by a different code path).
/// So a cell has the same float value whatever tile grid a consumer asks for.
class AffinityTileKernel final : public AffinityTileSource {
 public:
  AffinityTileKernel() = default;
  /// Errors: an invalid set (ValidateDescriptorSet), different dims, a zero tile capacity.
  static Result<AffinityTileKernel> Create(const DescriptorSetView& alpha, const DescriptorSetView& beta,
                                           std::size_t max_tile_rows, std::size_t max_tile_cols);

  /// The sets grew: `alpha` and `beta` are the same sets with keyframes appended (the first num_rows() /
  /// num_cols() keyframes unchanged - the caller's contract; the storage may have moved). Computes the norms
  /// and packs of the new keyframes only. Errors: an invalid set, another dim, a set that shrank.
  Status Extend(const DescriptorSetView& alpha, const DescriptorSetView& beta);

  /// Reserves the per-keyframe arrays (norms, beta pack) for this many keyframes, so Extend() up to them
  /// never reallocates. A start-up allocation (may throw std::bad_alloc).
  void Reserve(std::size_t alpha_count, std::size_t beta_count);

  std::size_t num_rows() const noexcept override { return alpha_count_; }
  std::size_t num_cols() const noexcept override { return beta_count_; }
  Status ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows, std::size_t cols,
                     AffinityTile* tile) override;

  /// Effective validity (flag, finite, 0 < ||v||^2 <= kMaxDescriptorNorm2) of alpha row i / beta column j.
  bool alpha_valid(std::size_t i) const noexcept { return alpha_norm2_[i] <= kMaxDescriptorNorm2; }
  bool beta_valid(std::size_t j) const noexcept { return beta_norm2_[j] <= kMaxDescriptorNorm2; }

  /// Cells computed by ComputeTile since creation (sum of rows x cols of every successful call).
  std::uint64_t cells_computed() const noexcept { return cells_computed_; }

 private:
  void PackBetaFrom(std::size_t first_col);

  const float* alpha_ = nullptr;
  const float* beta_ = nullptr;
  std::size_t dim_ = 0;
  std::size_t alpha_count_ = 0;
  std::size_t beta_count_ = 0;
  std::size_t max_tile_rows_ = 0;
  std::size_t max_tile_cols_ = 0;
  std::uint64_t cells_computed_ = 0;
  std::vector<float> alpha_norm2_;     ///< ||a_i||^2, or +inf for an invalid keyframe
  std::vector<float> beta_norm2_;      ///< ||b_j||^2, or +inf for an invalid keyframe
  std::vector<float> beta_pack_;       ///< panels of 8 columns, [panel][k][8]; invalid/padding columns 0
  std::vector<float> beta_norm_pack_;  ///< [panel][8] copy of beta_norm2_, padding +inf
  std::vector<float> alpha_pack_;      ///< one micro block of 6 rows, a_ik broadcast x4: [k][row][4]
  std::vector<float> tile_;            ///< tile buffer, up to max_tile_rows x max_tile_cols
};

/// Calls consumer(const AffinityTile&) -> Status for every tile of a tile_rows x tile_cols grid over the whole
/// matrix, in row-major tile order (left to right, then top to bottom); stops at the first error.
template <class Consumer>
Status ForEachAffinityTile(AffinityTileSource& source, std::size_t tile_rows, std::size_t tile_cols,
                           Consumer&& consumer) {
  if (tile_rows == 0 || tile_cols == 0) return InvalidArgument("affinity: tile size must be >= 1 x 1");
  const std::size_t n = source.num_rows(), m = source.num_cols();
  AffinityTile tile;
  for (std::size_t r0 = 0; r0 < n;) {
    const std::size_t rows = n - r0 < tile_rows ? n - r0 : tile_rows;
    for (std::size_t c0 = 0; c0 < m;) {
      const std::size_t cols = m - c0 < tile_cols ? m - c0 : tile_cols;
      Status s = source.ComputeTile(r0, c0, rows, cols, &tile);
      if (!s.ok()) return s;
      s = consumer(static_cast<const AffinityTile&>(tile));
      if (!s.ok()) return s;
      c0 += cols;  // never overflows: c0 + cols <= m
    }
    r0 += rows;
  }
  return Status::Ok();
}

/// Naive reference for tests: out (N x M, row-major, resized) = SolidDistance(alpha_i, beta_j) in double, or
/// +inf when either keyframe is invalid (same validity rule as the kernel).
Status ComputeAffinityNaive(const DescriptorSetView& alpha, const DescriptorSetView& beta, std::vector<double>* out);

}  // namespace commerge
