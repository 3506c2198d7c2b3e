// SPDX-License-Identifier: BSD-3-Clause
// commerge: stage A's relative acceptance (ours, not in the paper): a cell (i, j) stays a candidate only when
// its distance is among the k smallest of row i or among the k smallest of column j; every other cell becomes
// +inf before stage A thresholds and labels.
//
// Why: the paper's B_ij = [A_ij <= tau_inter] needs one absolute distance that separates true from false pairs
// for every sensor, scene and mounting. Measured on our data it does not exist: true pairs of one scenario lie
// above false pairs of another (simulator vs real Livox, same lane vs other lane). Whether a keyframe of beta is
// the nearest of alpha's keyframe i is a relative question instead (the rank-based matching of SeqSLAM and of
// Scan Context's candidate search): on a shared path the nearest neighbours of consecutive keyframes lie on a
// diagonal (or anti-diagonal) of the affinity matrix and form one 8-connected cluster; elsewhere the nearest
// neighbours are scattered and form no large cluster. tau_inter then acts as a loose cap only.
//
// The k-th smallest value per row and column is found in one pass over the inner source (Prepare), with
// O((N + M) k) memory; ComputeTile then serves the inner tile with the rejected cells set to +inf. Values depend
// only on the inner matrix, never on the tile grid, so the source is as deterministic as the inner one.
#pragma once

#include <cstddef>
#include <vector>

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
  /// or column holds fewer than k finite values, so all of its finite cells stay). Memory O((N + M) k).
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

 private:
  AffinityTileSource* inner_ = nullptr;
  std::size_t k_ = 1;
  std::size_t max_rows_ = 0, max_cols_ = 0;
  bool prepared_ = false;
  std::vector<float> row_kth_;  ///< per row, its k smallest values ascending (+inf padded)
  std::vector<float> col_kth_;  ///< per column, likewise
  std::vector<float> out_;      ///< the served tile
};

}  // namespace commerge
