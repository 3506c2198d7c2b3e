// SPDX-License-Identifier: BSD-3-Clause
#include "core/cloud/radius_neighbors.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

namespace commerge {
namespace {

// Cell coordinates are packed into 21 bits each; coordinates beyond +-2^20 cells are clamped to the border
// cell (still exact: every candidate's distance is checked, a far-away point only shares a crowded cell).
constexpr std::int64_t kHalfRange = std::int64_t{1} << 20;
constexpr std::int64_t kBits = 21;
// Cells are radius / kSplit wide, so a ball around any point of a cell lies in the (2 kSplit + 1)^3 cells around
// it: smaller cells mean fewer candidates outside the ball but more (cheap, per-cell) lookups.
constexpr std::int64_t kSplit = 2;

std::int64_t CellCoord(float v, double inv_cell) {
  const double c = std::floor(static_cast<double>(v) * inv_cell);
  return static_cast<std::int64_t>(std::min(std::max(c, -static_cast<double>(kHalfRange)),
                                            static_cast<double>(kHalfRange - 1))) + kHalfRange;
}

std::uint64_t PackCell(std::int64_t cx, std::int64_t cy, std::int64_t cz) {
  return (static_cast<std::uint64_t>(cx) << (2 * kBits)) | (static_cast<std::uint64_t>(cy) << kBits) |
         static_cast<std::uint64_t>(cz);
}

}  // namespace

void RadiusNeighbors::Compute(Span<const PointXYZI> points, float radius_m, std::size_t max_neighbors) {
  const std::size_t n = points.size();
  stride_ = max_neighbors;
  count_.assign(n, 0);
  index_.resize(n * stride_);
  dist_sq_.resize(n * stride_);
  total_ = 0;
  capped_ = 0;
  if (n == 0) return;
  const double inv_cell = static_cast<double>(kSplit) / static_cast<double>(radius_m);
  const float r2 = radius_m * radius_m;

  // Points sorted by cell (then index), as structure of arrays.
  keyed_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const PointXYZI& p = points[i];
    keyed_[i] = {PackCell(CellCoord(p.x, inv_cell), CellCoord(p.y, inv_cell), CellCoord(p.z, inv_cell)),
                 static_cast<std::uint32_t>(i)};
  }
  std::sort(keyed_.begin(), keyed_.end());
  xs_.resize(n);
  ys_.resize(n);
  zs_.resize(n);
  ids_.resize(n);
  cell_key_.clear();
  cell_begin_.clear();
  for (std::size_t s = 0; s < n; ++s) {
    const std::uint32_t i = keyed_[s].second;
    xs_[s] = points[i].x;
    ys_[s] = points[i].y;
    zs_[s] = points[i].z;
    ids_[s] = i;
    if (s == 0 || keyed_[s].first != keyed_[s - 1].first) {
      cell_key_.push_back(keyed_[s].first);
      cell_begin_.push_back(static_cast<std::uint32_t>(s));
    }
  }
  cell_begin_.push_back(static_cast<std::uint32_t>(n));
  const std::uint64_t mask = (std::uint64_t{1} << kBits) - 1;

  for (std::size_t c = 0; c < cell_key_.size(); ++c) {
    // The runs of the cells around cell c, found by binary search in the sorted keys.
    const std::uint64_t key = cell_key_[c];
    const auto cx = static_cast<std::int64_t>(key >> (2 * kBits));
    const auto cy = static_cast<std::int64_t>((key >> kBits) & mask);
    const auto cz = static_cast<std::int64_t>(key & mask);
    runs_.clear();
    std::size_t num_candidates = 0;
    for (std::int64_t dx = -kSplit; dx <= kSplit; ++dx) {
      for (std::int64_t dy = -kSplit; dy <= kSplit; ++dy) {
        for (std::int64_t dz = -kSplit; dz <= kSplit; ++dz) {
          const std::int64_t x = cx + dx, y = cy + dy, z = cz + dz;
          if (x < 0 || y < 0 || z < 0 || x >= 2 * kHalfRange || y >= 2 * kHalfRange || z >= 2 * kHalfRange) continue;
          const auto it = std::lower_bound(cell_key_.begin(), cell_key_.end(), PackCell(x, y, z));
          if (it == cell_key_.end() || *it != PackCell(x, y, z)) continue;
          const auto k = static_cast<std::size_t>(it - cell_key_.begin());
          runs_.emplace_back(cell_begin_[k], cell_begin_[k + 1]);
          num_candidates += cell_begin_[k + 1] - cell_begin_[k];
        }
      }
    }
    candidates_.resize(num_candidates);
    for (std::uint32_t s = cell_begin_[c]; s < cell_begin_[c + 1]; ++s) {
      const float qx = xs_[s], qy = ys_[s], qz = zs_[s];
      // Branch-free compaction: every candidate is written, the cursor advances only when it is in the ball.
      std::size_t w = 0;
      for (const auto& run : runs_) {
        for (std::uint32_t t = run.first; t < run.second; ++t) {
          const float ex = xs_[t] - qx, ey = ys_[t] - qy, ez = zs_[t] - qz;
          const float d2 = ex * ex + ey * ey + ez * ez;
          // A non-negative float's bit pattern orders like its value, so one integer key sorts by
          // (distance, index) without floating-point compares.
          std::uint32_t bits;
          std::memcpy(&bits, &d2, sizeof(bits));
          candidates_[w] = (static_cast<std::uint64_t>(bits) << 32) | ids_[t];
          w += d2 <= r2 ? 1 : 0;
        }
      }
      const std::size_t m = std::min(w, stride_);
      const auto first = candidates_.begin();
      if (w > m) {
        std::nth_element(first, first + static_cast<std::ptrdiff_t>(m), first + static_cast<std::ptrdiff_t>(w));
        ++capped_;
      }
      std::sort(first, first + static_cast<std::ptrdiff_t>(m));
      const std::uint32_t i = ids_[s];
      std::uint32_t* out_index = index_.data() + static_cast<std::size_t>(i) * stride_;
      float* out_d2 = dist_sq_.data() + static_cast<std::size_t>(i) * stride_;
      for (std::size_t k = 0; k < m; ++k) {
        out_index[k] = static_cast<std::uint32_t>(candidates_[k]);
        const auto bits = static_cast<std::uint32_t>(candidates_[k] >> 32);
        std::memcpy(out_d2 + k, &bits, sizeof(bits));
      }
      count_[i] = static_cast<std::uint32_t>(m);
      total_ += m;
    }
  }
}

std::size_t RadiusNeighbors::workspace_bytes() const noexcept {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  return held(count_) + held(index_) + held(dist_sq_) + held(keyed_) + held(xs_) + held(ys_) + held(zs_) +
         held(ids_) + held(cell_key_) + held(cell_begin_) + held(runs_) + held(candidates_);
}

}  // namespace commerge
