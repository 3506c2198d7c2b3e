// SPDX-License-Identifier: BSD-3-Clause
// commerge: stage A's relative acceptance (ours, not in the paper): a cell (i, j) stays a candidate only when
// its distance is among the k smallest of row i or among the k smallest of column j; every other cell becomes
// +inf before stage A thresholds and labels.
//
// Why: no absolute tau_inter separates true from false pairs for every sensor and scene, while on a shared path
// the nearest neighbours of consecutive keyframes form one diagonal (or anti-diagonal) cluster and elsewhere
// scatter (the rank-based matching of SeqSLAM and Scan Context); tau_inter then acts as a loose cap only
// (core/agent/decisions/001-server-stage-a-defaults.md).
//
// The k-th smallest value per row and column is found in one pass over the inner source (Prepare), with
// O((N + M) k) memory. The same pass keeps, per row and column, the cells that were at or below the k-th smallest
// value seen so far when reached (a fixed number of slots each); afterwards the kept cells (at most about
// (N + M) k of them, more only with ties) are stored row-major and ComputeTile serves tiles from them without
// reading the inner source again: one pass over the inner source instead of one per tile request. When ties
// overflow the slots, ComputeTile serves the inner tile with the rejected cells set to +inf instead (same values).
// Values depend only on the inner matrix, never on the tile grid, so the source is as deterministic as the inner
// one.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/affinity.hpp"

namespace commerge {

/// Largest accepted k.
constexpr std::size_t kMaxNeighbourRank = 8;

class NeighbourRankTileSource final : public AffinityTileSource {
 public:
  /// Errors: k outside 1..kMaxNeighbourRank, a zero tile capacity. `inner` is borrowed and must accept blocks
  /// of max_tile_rows x max_tile_cols. Prepare() must run before ComputeTile().
  static Result<NeighbourRankTileSource> Create(AffinityTileSource* inner, std::size_t k, std::size_t max_tile_rows,
                                                std::size_t max_tile_cols);

  /// One pass over the inner source: the k-th smallest finite value of every row and column (+inf when a row
  /// or column holds fewer than k finite values, so all of its finite cells stay), and the kept cells (sparse()).
  /// Memory O((N + M) k) plus the kept cells.
  Status Prepare();

  std::size_t num_rows() const noexcept override { return inner_->num_rows(); }
  std::size_t num_cols() const noexcept override { return inner_->num_cols(); }
  /// The inner tile with every cell above both its row's and its column's k-th smallest value set to +inf.
  /// Reports the tile's exact minimum. Error before Prepare(), or when the inner source fails.
  Status ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows, std::size_t cols,
                     AffinityTile* tile) override;

  /// k-th smallest value of row i / column j (after Prepare()).
  float row_threshold(std::size_t i) const noexcept { return row_kth_[i * k_ + k_ - 1]; }
  float col_threshold(std::size_t j) const noexcept { return col_kth_[j * k_ + k_ - 1]; }

  /// A cell kept by the rank test: its finite value (every other cell of the served matrix is +inf).
  struct KeptCell {
    std::uint32_t row = 0, col = 0;
    float value = 0.0f;
  };
  /// After Prepare(): true when the kept cells are stored (the usual case; false when ties overflowed the
  /// candidate slots or an index does not fit 32 bits). Then tiles are served from them.
  bool sparse() const noexcept { return sparse_; }
  /// With sparse(): the kept cells of row i with columns in [col_begin, col_end), by ascending column.
  Span<const KeptCell> RowCells(std::size_t i, std::size_t col_begin, std::size_t col_end) const;

  /// A candidate slot of Prepare(): a column (of a row's list) or row (of a column's list) and its value.
  struct Candidate {
    std::uint32_t index = 0;
    float value = 0.0f;
  };

 private:
  AffinityTileSource* inner_ = nullptr;
  std::size_t k_ = 1;
  std::size_t max_rows_ = 0, max_cols_ = 0;
  bool prepared_ = false;
  std::vector<float> row_kth_;  ///< per row, its k smallest values ascending (+inf padded)
  std::vector<float> col_kth_;  ///< per column, likewise
  std::vector<float> out_;      ///< the served tile
  bool sparse_ = false;
  std::vector<KeptCell> cells_;             ///< the kept cells, row-major (sparse_)
  std::vector<std::size_t> row_cells_;      ///< N + 1 offsets of each row's kept cells in cells_
  std::vector<Candidate> row_cand_, col_cand_;  ///< Prepare's candidate slots (released after it)
  std::vector<std::uint32_t> row_cand_size_, col_cand_size_;
  static constexpr std::size_t kCandidateSlotsPerRank = 8;  ///< slots per row / column: 8 k
  static constexpr std::size_t kMaxSparseIndex = 0xFFFFFFFFu;
};

}  // namespace commerge
