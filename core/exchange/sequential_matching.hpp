// SPDX-License-Identifier: BSD-3-Clause
// commerge: stage A, inter-robot sequential matching (paper "Inter-Robot Sequential Matching"). Streams the
// affinity tiles in row-major tile order, thresholds B = [A <= tau_inter], labels the 8-connected components
// with a streaming union-find that keeps only the previous label row (O(M)) plus one tile of labels, and
// picks the cluster of lowest mean distance among those whose span area >= tau_area. The cells of the chosen
// cluster (L_seq) are collected in a second pass over the tiles that intersect its span only. The N x M
// matrix is never stored. Tiles whose reported minimum (AffinityTile::min_distance) is above tau_inter are
// skipped by the labeller.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/affinity.hpp"
#include "core/exchange/neighbour_rank.hpp"
#include "core/exchange/sequence_smoothing.hpp"

namespace commerge {

struct SequentialMatchParams {
  double tau_inter = 0.10;        ///< unit-L2 distance threshold: B_ij = [A_ij <= tau_inter] (compared in float)
  std::uint64_t tau_area = 10000; ///< minimal span area in cells (rows x cols of the inclusive bounding box)
  std::size_t tile_rows = 256;    ///< tile height of the streaming pass, >= 1
  std::size_t tile_cols = 256;    ///< tile width, >= 1
  /// 0 = the paper's B_ij = [A_ij <= tau_inter]. w >= 1 (at most kMaxSequenceHalfWindow): threshold the
  /// sequence-smoothed V_ij instead: the smaller of the means of A along the diagonal and the anti-diagonal
  /// through (i, j) over k = -w .. w, at its lowest over the 3 x 3 cells around (i, j)
  /// (sequence_smoothing.hpp). Clusters, means, L_seq's cell distances and min_distance are then those of V.
  std::size_t sequence_half_window = 0;
  /// 0 = every cell is a candidate when at most tau_inter (the paper). k >= 1 (at most kMaxNeighbourRank): only
  /// cells among the k smallest of their row or of their column (after the smoothing above) can be candidates,
  /// tau_inter becomes a cap (neighbour_rank.hpp).
  std::size_t neighbour_rank = 0;
  /// 0 = tau_area as given (the paper). f > 0 (ours): the span area asked of a cluster scales with the shorter
  /// mission, EffectiveTauArea: robots of a few dozen keyframes cannot share a 20 x 20 span
  /// (core/agent/decisions/001-server-stage-a-defaults.md).
  double tau_area_fraction = 0.0;
  /// With tau_area_fraction: the scaled area never drops below this many cells.
  std::uint64_t min_tau_area = 100;
  /// 0 = only S*'s cells (the paper). c > 0 (ours): when at most c cells are below threshold, one more pass
  /// returns every cluster with its cells (SequentialMatchResult::clusters), for the cascade's place consensus
  /// (place_consensus.hpp); above c the clusters are not collected (clusters_skipped says so). Memory O(c).
  std::size_t all_clusters_max_cells = 0;
};

/// The span area stage A asks for on an n x m matrix: tau_area, or with tau_area_fraction f > 0
/// min(tau_area, max(min_tau_area, ceil((f * min(n, m))^2))).
std::uint64_t EffectiveTauArea(const SequentialMatchParams& params, std::size_t n, std::size_t m) noexcept;

/// Errors (invalid argument): tau_inter negative or not finite, a zero tile size, sequence_half_window above
/// kMaxSequenceHalfWindow, neighbour_rank above kMaxNeighbourRank, tau_area_fraction negative or not finite.
Status ValidateSequentialMatchParams(const SequentialMatchParams& params);

/// One 8-connected cluster S_l of B. Span bounds are INCLUSIVE indices: the cluster's cells lie in rows
/// [row_min, row_max] (alpha keyframes) and columns [col_min, col_max] (beta keyframes); the paper's
/// half-open [i_min, i_max) is [row_min, row_max + 1).
struct SequentialCluster {
  std::size_t row_min = 0, row_max = 0;  ///< alpha keyframe index range, inclusive
  std::size_t col_min = 0, col_max = 0;  ///< beta keyframe index range, inclusive
  std::uint64_t cell_count = 0;          ///< |S_l|
  double distance_sum = 0.0;             ///< sum of A_ij over the cells (double accumulation)

  std::size_t span_rows() const noexcept { return row_max - row_min + 1; }
  std::size_t span_cols() const noexcept { return col_max - col_min + 1; }
  /// |Span(S_l)| = span_rows x span_cols (the number of cells of the inclusive bounding box).
  std::uint64_t span_area() const noexcept {
    return static_cast<std::uint64_t>(span_rows()) * static_cast<std::uint64_t>(span_cols());
  }
  /// f_avg(S_l) = distance_sum / cell_count.
  double mean_distance() const noexcept {
    return cell_count == 0 ? 0.0 : distance_sum / static_cast<double>(cell_count);
  }
};

/// One loop candidate (i, j) of L_seq: alpha keyframe i, beta keyframe j, and A_ij.
struct SequentialLoopCell {
  std::size_t alpha_index = 0;
  std::size_t beta_index = 0;
  float distance = 0.0f;
};

/// Every cluster of B with its cells (SequentialMatchParams::all_clusters_max_cells): cluster k's cells are
/// cells[begin[k] .. begin[k + 1]), row-major. Clusters in order of their first cell (row-major).
struct SequentialClusterSet {
  std::vector<SequentialCluster> clusters;
  std::vector<std::size_t> begin;  ///< clusters.size() + 1 offsets into cells
  std::vector<SequentialLoopCell> cells;

  Span<const SequentialLoopCell> CellsOf(std::size_t k) const {
    return Span<const SequentialLoopCell>(cells.data() + begin[k], begin[k + 1] - begin[k]);
  }
};

struct SequentialMatchResult {
  bool found = false;                    ///< a cluster qualified (span area >= tau_area)
  SequentialCluster best;                ///< S*, meaningful when found
  std::vector<SequentialLoopCell> cells; ///< L_seq = cells of S*, row-major order (by alpha, then beta)
  std::size_t num_clusters = 0;          ///< N_label, all clusters whatever their area
  std::uint64_t num_cells_below_threshold = 0;  ///< cells with B_ij = 1
  std::uint64_t largest_span_area = 0;   ///< over all clusters (0 when none)
  /// The second largest span area over all clusters (0 with fewer than two; equals largest_span_area when two
  /// clusters tie): how unique the largest cluster is.
  std::uint64_t second_span_area = 0;
  double min_distance = 0.0;             ///< smallest finite A_ij seen (+inf when none)
  std::string no_candidate_reason;       ///< empty when found; else why nothing qualified, in words
  /// Every cluster with its cells, when all_clusters_max_cells > 0 and num_cells_below_threshold is at most
  /// that (else empty and clusters_skipped). Collected whether or not a cluster qualified.
  SequentialClusterSet clusters;
  bool clusters_skipped = false;
};

/// Stage A over any tile source (two passes; the source must be deterministic). With sequence_half_window
/// w >= 1 the source is read through a SequenceSmoothedTileSource, so it must accept blocks of up to
/// (tile_rows + 2w + 2) x (tile_cols + 2w + 2). With neighbour_rank k >= 1 the (smoothed) source is read through
/// a NeighbourRankTileSource: one pass over the (smoothed) source in its Prepare; when it stores its kept cells
/// (NeighbourRankTileSource::sparse()), stage A's passes read those instead of tiles, so the source is read once
/// in all. Tie-break between equal
/// means: smaller row_min, then col_min, then row_max, then col_max. Errors only for bad parameters or a
/// failing source; degenerate inputs (empty sets, nothing below tau_inter, clusters too small) give an OK
/// result with found == false and no_candidate_reason set.
Result<SequentialMatchResult> RunSequentialMatching(AffinityTileSource& source, const SequentialMatchParams& params);

/// Rows and columns a tile source must serve beyond params' tile size for the sequence smoothing's halo (0 without
/// smoothing): create sources with a capacity of (tile_rows + halo) x (tile_cols + halo).
std::size_t SequentialMatchTileHalo(const SequentialMatchParams& params) noexcept;

/// Stage A on two descriptor sets (AffinityTileKernel with the parameter tile size, grown by the smoothing
/// halo when sequence_half_window >= 1). Invalid keyframes (flag 0,
/// NaN/inf values, zero vector) never match. Errors: malformed sets (ValidateDescriptorSet), different dims,
/// bad parameters.
Result<SequentialMatchResult> RunSequentialMatching(const DescriptorSetView& alpha, const DescriptorSetView& beta,
                                                    const SequentialMatchParams& params);

}  // namespace commerge
