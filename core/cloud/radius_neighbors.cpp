// SPDX-License-Identifier: BSD-3-Clause
#include "core/cloud/radius_neighbors.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace commerge {
namespace {

// Cell coordinates are packed into 21 bits each; coordinates beyond +-2^20 cells are clamped to the border
// cell (still exact: every candidate's distance is checked, a far-away point only shares a crowded cell).
constexpr std::int64_t kHalfRange = std::int64_t{1} << 20;
constexpr std::int64_t kBits = 21;
// Cells are radius / kSplit wide, so a ball around any point of a cell lies in the (2 kSplit + 1)^3 cells around
// it: smaller cells mean fewer candidates outside the ball but more (cheap, per-cell) lookups.
constexpr std::int64_t kSplit = 2;
// Distances are computed four candidates at a time with the compiler's portable 16-byte vectors (SSE, NEON).
constexpr std::size_t kLanes = 4;
using Vec4f = float __attribute__((vector_size(16)));
using Vec4i = std::int32_t __attribute__((vector_size(16)));

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
  const float inner_r2 = 0.49f * r2, middle_r2 = 0.72f * r2;  // (0.7 r)^2, (0.85 r)^2

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
    // Keys hold z in their lowest bits, so the cells (x, y, z - kSplit .. z + kSplit) are one sorted range: one
    // binary search per column of cells, then a short forward scan.
    const std::int64_t z_lo = std::max<std::int64_t>(cz - kSplit, 0);
    const std::int64_t z_hi = std::min<std::int64_t>(cz + kSplit, 2 * kHalfRange - 1);
    auto from = cell_key_.begin();
    for (std::int64_t dx = -kSplit; dx <= kSplit; ++dx) {
      for (std::int64_t dy = -kSplit; dy <= kSplit; ++dy) {
        const std::int64_t x = cx + dx, y = cy + dy;
        if (x < 0 || y < 0 || x >= 2 * kHalfRange || y >= 2 * kHalfRange) continue;
        const std::uint64_t last = PackCell(x, y, z_hi);
        // Columns come in ascending key order, so each search starts where the previous one ended.
        from = std::lower_bound(from, cell_key_.end(), PackCell(x, y, z_lo));
        for (auto it = from; it != cell_key_.end() && *it <= last; ++it) {
          const auto k = static_cast<std::size_t>(it - cell_key_.begin());
          runs_.emplace_back(cell_begin_[k], cell_begin_[k + 1]);
          num_candidates += cell_begin_[k + 1] - cell_begin_[k];
        }
      }
    }
    // The candidates of this cell gathered once into contiguous arrays, padded to whole vectors with points at
    // infinity (never in the ball), so that each of the cell's points computes its distances kLanes at a time.
    const std::size_t padded = (num_candidates + kLanes - 1) / kLanes * kLanes;
    cand_x_.resize(padded);
    cand_y_.resize(padded);
    cand_z_.resize(padded);
    cand_id_.resize(padded);
    cand_d2_.resize(padded);
    std::size_t g = 0;
    for (const auto& run : runs_) {
      for (std::uint32_t t = run.first; t < run.second; ++t, ++g) {
        cand_x_[g] = xs_[t], cand_y_[g] = ys_[t], cand_z_[g] = zs_[t], cand_id_[g] = ids_[t];
      }
    }
    for (; g < padded; ++g) {
      cand_x_[g] = cand_y_[g] = cand_z_[g] = std::numeric_limits<float>::infinity();
      cand_id_[g] = 0;
    }
    candidates_.resize(num_candidates);
    for (std::uint32_t s = cell_begin_[c]; s < cell_begin_[c + 1]; ++s) {
      const float qx = xs_[s], qy = ys_[s], qz = zs_[s];
      // Distances, and how many candidates lie within two inner radii and within the radius.
      Vec4i within_inner = {}, within_middle = {}, within_radius = {};  // -1 per hit and lane
      for (std::size_t t = 0; t < padded; t += kLanes) {
        Vec4f x, y, z;
        std::memcpy(&x, cand_x_.data() + t, sizeof(x));
        std::memcpy(&y, cand_y_.data() + t, sizeof(y));
        std::memcpy(&z, cand_z_.data() + t, sizeof(z));
        const Vec4f ex = x - qx, ey = y - qy, ez = z - qz;
        const Vec4f d2 = ex * ex + ey * ey + ez * ez;
        std::memcpy(cand_d2_.data() + t, &d2, sizeof(d2));
        within_inner += d2 <= inner_r2;
        within_middle += d2 <= middle_r2;
        within_radius += d2 <= r2;
      }
      const auto count = [](const Vec4i& v) { return static_cast<std::size_t>(-(v[0] + v[1] + v[2] + v[3])); };
      const std::size_t in_ball = count(within_radius);
      // When an inner ball already holds max_neighbors points, the list is the closest of those: only they
      // enter the selection below (fewer elements to partition; the result is the same).
      const float limit = count(within_inner) >= stride_ ? inner_r2 : count(within_middle) >= stride_ ? middle_r2 : r2;
      // Branch-free compaction: every candidate is written, the cursor advances only when it is kept.
      std::size_t w = 0;
      for (std::size_t t = 0; t < num_candidates; ++t) {
        const float d2 = cand_d2_[t];
        // A non-negative float's bit pattern orders like its value, so one integer key sorts by
        // (distance, index) without floating-point compares.
        std::uint32_t bits;
        std::memcpy(&bits, &d2, sizeof(bits));
        candidates_[w] = (static_cast<std::uint64_t>(bits) << 32) | cand_id_[t];
        w += d2 <= limit ? 1 : 0;
      }
      const std::size_t m = std::min(w, stride_);
      const auto first = candidates_.begin();
      if (w > m) std::nth_element(first, first + static_cast<std::ptrdiff_t>(m), first + static_cast<std::ptrdiff_t>(w));
      if (in_ball > stride_) ++capped_;
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
         held(ids_) + held(cell_key_) + held(cell_begin_) + held(runs_) + held(cand_x_) + held(cand_y_) + held(cand_z_) +
         held(cand_id_) + held(cand_d2_) + held(candidates_);
}

}  // namespace commerge
