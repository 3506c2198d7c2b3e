// SPDX-License-Identifier: BSD-3-Clause
// commerge: capped radius neighbours of EVERY point of a cloud (an all-points query, as normals, covariances
// and FPFH descriptors need), by a uniform grid whose cells are half the radius. All points of a cell share one
// candidate set (its 5 x 5 x 5 cells, gathered once), so the per-point work is a flat, vectorised distance pass
// plus a partial sort, with no tree descent and no insertion into a sorted k-list. On 1 m voxelised submaps
// (5 m radius, 48 neighbours) this is about twice as fast as 10 000 capped k-d tree searches.
#pragma once

#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"

namespace commerge {

class RadiusNeighbors {
 public:
  /// For every point i: the points j with |p_j - p_i|^2 <= radius_m^2 (i itself included), closest first,
  /// ties by lower index, at most max_neighbors of them. Preconditions: every point finite, radius_m > 0 and
  /// finite, max_neighbors >= 1, points.size() < 2^32. Buffers keep their capacity between calls.
  void Compute(Span<const PointXYZI> points, float radius_m, std::size_t max_neighbors);

  std::size_t size() const noexcept { return count_.size(); }
  /// Neighbours of point i, closest first, and their squared distances [m^2].
  Span<const std::uint32_t> indices(std::size_t i) const noexcept {
    return {index_.data() + i * stride_, count_[i]};
  }
  Span<const float> distances_sq(std::size_t i) const noexcept { return {dist_sq_.data() + i * stride_, count_[i]}; }
  /// Total list length over all points, and how many lists were cut at max_neighbors.
  std::size_t total() const noexcept { return total_; }
  std::size_t num_capped() const noexcept { return capped_; }
  /// Bytes held: the lists and the scratch (capacities; kept between calls).
  std::size_t workspace_bytes() const noexcept;

 private:
  std::size_t stride_ = 0;
  std::vector<std::uint32_t> count_;
  std::vector<std::uint32_t> index_;  // stride_ slots per point
  std::vector<float> dist_sq_;
  std::size_t total_ = 0;
  std::size_t capped_ = 0;
  // Scratch: points sorted by cell (structure of arrays), the cells' keys and runs, the candidate buffer.
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keyed_;
  std::vector<float> xs_, ys_, zs_;
  std::vector<std::uint32_t> ids_;
  std::vector<std::uint64_t> cell_key_;
  std::vector<std::uint32_t> cell_begin_;
  std::vector<std::pair<std::uint32_t, std::uint32_t>> runs_;
  std::vector<float> cand_x_, cand_y_, cand_z_, cand_d2_;  // one cell's candidates, contiguous
  std::vector<std::uint32_t> cand_id_;
  std::vector<std::uint64_t> candidates_;  // (bits of d^2 << 32) | index: sorts as (distance, index)
};

}  // namespace commerge
