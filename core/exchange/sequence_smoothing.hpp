// SPDX-License-Identifier: BSD-3-Clause
// commerge: sequence-smoothed affinity for stage A (an option, off by default; not in the paper's stage A).
//
// The paper thresholds each cell, B_ij = [A_ij <= tau_inter]. Where single keyframes jump above tau_inter
// (corridors, open terrain with a tilting sensor) every jump cuts the 8-connected diagonal of a revisit,
// and no cluster reaches tau_area. With a half window w >= 1, stage A thresholds instead
//
//   S_ij = min( mean_k A(i+k, j+k), mean_k A(i+k, j-k) ),   k = -w .. w,
//
// the mean along the diagonal (same direction of travel) or the anti-diagonal (opposite direction) through
// (i, j): the sequence principle of SeqSLAM. Each mean is taken over the finite cells of that line inside the
// matrix (the windows are truncated at the borders; invalid pairs, +inf, are left out) and S_ij = +inf when
// A_ij itself is +inf. w = 0 gives S = A exactly.
//
// Stage A thresholds V_ij = min of S over the 3 x 3 cells around (i, j) (inside the matrix), and +inf where
// A_ij is +inf: a sequence match admits the keyframes next to it as loops too. Without that widening a
// smoothed revisit is often one cell wide, its exchange graph a matching, and a balanced vertex cover of a
// matching selects no loop with both endpoints, which stage C needs
// (core/agent/decisions/001-server-stage-a-defaults.md). V depends only on A, never on the tile grid, so the source
// is as deterministic and position independent as its inner source.
#pragma once

#include <cstddef>
#include <vector>

#include "core/common/status.hpp"
#include "core/exchange/affinity.hpp"

namespace commerge {

/// Largest accepted half window (a 65-keyframe sequence); bounds the halo of the inner tiles.
constexpr std::size_t kMaxSequenceHalfWindow = 32;

/// S_ij of one cell from a dense row-major N x M matrix `a` (double sums in ascending k; the source below
/// computes S the same way). Precondition: i < n, j < m, a.size() == n * m.
float SequenceSmoothedCell(const float* a, std::size_t n, std::size_t m, std::size_t i, std::size_t j,
                           std::size_t half_window);

/// An AffinityTileSource serving V (above) computed from an inner source. A tile of rows x cols asks the
/// inner source for the block grown by w + 1 on every side (clipped to the matrix), so the inner source must
/// accept blocks of up to (max_tile_rows + 2w + 2) x (max_tile_cols + 2w + 2). Memory: one output tile and
/// one of S grown by a cell, a few rows of sums. Every tile reports its exact minimum.
class SequenceSmoothedTileSource final : public AffinityTileSource {
 public:
  /// Errors: half_window above kMaxSequenceHalfWindow, a zero tile capacity. `inner` is borrowed.
  static Result<SequenceSmoothedTileSource> Create(AffinityTileSource* inner, std::size_t half_window,
                                                   std::size_t max_tile_rows, std::size_t max_tile_cols);

  std::size_t num_rows() const noexcept override { return inner_->num_rows(); }
  std::size_t num_cols() const noexcept override { return inner_->num_cols(); }
  Status ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows, std::size_t cols,
                     AffinityTile* tile) override;

 private:
  AffinityTileSource* inner_ = nullptr;
  std::size_t w_ = 0;
  std::size_t max_rows_ = 0, max_cols_ = 0;
  std::vector<float> out_;       // V of the tile
  std::vector<float> smoothed_;  // S of the tile grown by one cell
  std::vector<float> row_min_;   // S's minimum over 3 columns, tile columns x grown rows
  std::vector<double> diag_, anti_, diag_next_, anti_next_;  // window sums of one row (running sums)
};

}  // namespace commerge
