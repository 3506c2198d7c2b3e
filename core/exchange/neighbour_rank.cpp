// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/neighbour_rank.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>

#include "core/common/float_limits.hpp"
#include "core/common/simd4.hpp"

namespace commerge {

namespace {

// Inserts v into the ascending list [list, list + k) of the k smallest values so far.
void KeepSmallest(float v, float* list, std::size_t k) {
  if (!(v < list[k - 1])) return;
  std::size_t pos = k - 1;
  while (pos > 0 && v < list[pos - 1]) {
    list[pos] = list[pos - 1];
    --pos;
  }
  list[pos] = v;
}

typedef std::int32_t V4i __attribute__((vector_size(16)));  // the lane masks of V4f comparisons

// True when one of the 8 values v[q] is at or below row_kth or at or below col_kth[q * k] (NaN never is).
bool AnyAtOrBelow(const float* v, float row_kth, const float* col_kth, std::size_t k) noexcept {
  if (k == 1) {
    const V4f a = Load4f(v), b = Load4f(v + 4), ca = Load4f(col_kth), cb = Load4f(col_kth + 4);
    const V4f r = {row_kth, row_kth, row_kth, row_kth};
    const V4i m = (a <= r) | (a <= ca) | (b <= r) | (b <= cb);
    return (m[0] | m[1] | m[2] | m[3]) != 0;
  }
  bool any = false;
  for (std::size_t q = 0; q < 8; ++q) any |= (v[q] <= row_kth) | (v[q] <= col_kth[q * k]);
  return any;
}

}  // namespace

Result<NeighbourRankTileSource> NeighbourRankTileSource::Create(AffinityTileSource* inner, std::size_t k,
                                                                std::size_t max_tile_rows, std::size_t max_tile_cols) {
  if (inner == nullptr) return InvalidArgument("neighbour rank: no inner source");
  if (k < 1 || k > kMaxNeighbourRank) {
    return InvalidArgument("neighbour rank: k must be in 1.." + std::to_string(kMaxNeighbourRank) + ", got " +
                           std::to_string(k));
  }
  if (max_tile_rows == 0 || max_tile_cols == 0) return InvalidArgument("neighbour rank: tile size must be >= 1 x 1");
  NeighbourRankTileSource s;
  s.inner_ = inner;
  s.k_ = k;
  s.max_rows_ = max_tile_rows;
  s.max_cols_ = max_tile_cols;
  return s;
}

namespace {

// Appends (index, v) to a candidate list of capacity cap (`size` entries in use) when v can still end up at or
// below the list's k-th smallest value `kth` (the value before v is taken into account: the final k-th smallest is
// never above it). A full list first drops the entries above kth; false when the list is full of entries at or
// below kth (ties), so the candidates cannot be kept in the fixed space.
bool NoteCandidate(std::uint32_t index, float v, float kth, NeighbourRankTileSource::Candidate* list,
                   std::uint32_t* size, std::size_t cap) {
  if (!(v <= kth)) return true;
  if (*size == cap) {
    std::uint32_t kept = 0;
    for (std::uint32_t q = 0; q < *size; ++q) {
      if (list[q].value <= kth) list[kept++] = list[q];
    }
    *size = kept;
    if (kept == cap) return false;
  }
  list[(*size)++] = {index, v};
  return true;
}

}  // namespace

Status NeighbourRankTileSource::Prepare() {
  const std::size_t n = inner_->num_rows(), m = inner_->num_cols();
  row_kth_.assign(n * k_, kFloatInf);
  col_kth_.assign(m * k_, kFloatInf);
  prepared_ = false;
  sparse_ = false;
  cells_.clear();
  row_cells_.clear();
  if (n == 0 || m == 0) {
    prepared_ = true;
    return Status::Ok();
  }
  // The candidates of every row and column: the cells that were at or below the k-th smallest value seen so far
  // when the pass reached them. Every kept cell is among them (the k-th smallest only decreases).
  const std::size_t cap = kCandidateSlotsPerRank * k_;
  bool fits = n <= kMaxSparseIndex && m <= kMaxSparseIndex;
  if (fits) {
    row_cand_.assign(n * cap, Candidate{});
    col_cand_.assign(m * cap, Candidate{});
    row_cand_size_.assign(n, 0);
    col_cand_size_.assign(m, 0);
  }
  const auto visit = [&](std::size_t i, std::size_t j, float v, float* row_list) {
    if (!std::isfinite(v)) return;
    float* col_list = col_kth_.data() + j * k_;
    if (fits) {
      fits = NoteCandidate(static_cast<std::uint32_t>(j), v, row_list[k_ - 1], row_cand_.data() + i * cap,
                           &row_cand_size_[i], cap) &&
             NoteCandidate(static_cast<std::uint32_t>(i), v, col_list[k_ - 1], col_cand_.data() + j * cap,
                           &col_cand_size_[j], cap);
    }
    KeepSmallest(v, row_list, k_);
    KeepSmallest(v, col_list, k_);
  };
  Status s = ForEachAffinityTile(*inner_, max_rows_, max_cols_, [&](const AffinityTile& t) -> Status {
    for (std::size_t r = 0; r < t.rows; ++r) {
      const std::size_t i = t.row_begin + r;
      float* row_list = row_kth_.data() + i * k_;
      const float* row = t.distances + r * t.stride;
      std::size_t c = 0;
      // Groups of 8 cells none of which is at or below its row's or its column's current k-th smallest value
      // change nothing (neither list nor candidate): skipped after one comparison each. The row's value may
      // only decrease within the group, so comparing with its value at the group's start skips no cell that
      // matters.
      for (; c + 8 <= t.cols; c += 8) {
        const float row_kth = row_list[k_ - 1];
        const float* col_kth = col_kth_.data() + (t.col_begin + c) * k_ + (k_ - 1);
        if (!AnyAtOrBelow(row + c, row_kth, col_kth, k_)) continue;
        for (std::size_t q = 0; q < 8; ++q) visit(i, t.col_begin + c + q, row[c + q], row_list);
      }
      for (; c < t.cols; ++c) visit(i, t.col_begin + c, row[c], row_list);
    }
    return Status::Ok();
  });
  if (!s.ok()) return s;
  if (fits) {
    // The kept cells (at or below their row's or column's k-th smallest value), row-major, each once.
    for (std::size_t i = 0; i < n; ++i) {
      for (std::uint32_t q = 0; q < row_cand_size_[i]; ++q) {
        const Candidate& c = row_cand_[i * cap + q];
        if (c.value <= row_threshold(i)) cells_.push_back({static_cast<std::uint32_t>(i), c.index, c.value});
      }
    }
    for (std::size_t j = 0; j < m; ++j) {
      for (std::uint32_t q = 0; q < col_cand_size_[j]; ++q) {
        const Candidate& c = col_cand_[j * cap + q];
        if (c.value <= col_threshold(j)) cells_.push_back({c.index, static_cast<std::uint32_t>(j), c.value});
      }
    }
    std::sort(cells_.begin(), cells_.end(), [](const KeptCell& a, const KeptCell& b) {
      return a.row != b.row ? a.row < b.row : a.col < b.col;
    });
    cells_.erase(std::unique(cells_.begin(), cells_.end(),
                             [](const KeptCell& a, const KeptCell& b) { return a.row == b.row && a.col == b.col; }),
                 cells_.end());
    row_cells_.assign(n + 1, 0);
    for (const KeptCell& c : cells_) ++row_cells_[c.row + 1];
    for (std::size_t i = 0; i < n; ++i) row_cells_[i + 1] += row_cells_[i];
    sparse_ = true;
  }
  row_cand_.clear();
  col_cand_.clear();
  row_cand_.shrink_to_fit();
  col_cand_.shrink_to_fit();
  prepared_ = true;
  return Status::Ok();
}

Span<const NeighbourRankTileSource::KeptCell> NeighbourRankTileSource::RowCells(std::size_t i, std::size_t col_begin,
                                                                              std::size_t col_end) const {
  const KeptCell* first = cells_.data() + row_cells_[i];
  const KeptCell* last = cells_.data() + row_cells_[i + 1];
  const auto by_col = [](const KeptCell& c, std::size_t j) { return c.col < j; };
  const KeptCell* b = std::lower_bound(first, last, col_begin, by_col);
  const KeptCell* e = std::lower_bound(b, last, col_end, by_col);
  return Span<const KeptCell>(b, static_cast<std::size_t>(e - b));
}

Status NeighbourRankTileSource::ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows,
                                            std::size_t cols, AffinityTile* tile) {
  if (!prepared_) return Status(StatusCode::kInternal, "neighbour rank: ComputeTile before Prepare");
  if (rows > max_rows_ || cols > max_cols_) {
    return InvalidArgument("neighbour rank: tile " + std::to_string(rows) + " x " + std::to_string(cols) +
                           " exceeds the capacity " + std::to_string(max_rows_) + " x " + std::to_string(max_cols_));
  }
  out_.resize(rows * cols);
  float lowest = kFloatInf;
  if (sparse_) {  // every other cell is +inf
    if (row_begin + rows > num_rows() || col_begin + cols > num_cols() || rows == 0 || cols == 0) {
      return InvalidArgument("neighbour rank: tile " + std::to_string(rows) + " x " + std::to_string(cols) + " at (" +
                             std::to_string(row_begin) + ", " + std::to_string(col_begin) + ") is outside the matrix");
    }
    std::fill(out_.begin(), out_.end(), kFloatInf);
    for (std::size_t r = 0; r < rows; ++r) {
      const Span<const KeptCell> row = RowCells(row_begin + r, col_begin, col_begin + cols);
      for (const KeptCell& c : row) {
        out_[r * cols + (c.col - col_begin)] = c.value;
        lowest = std::min(lowest, c.value);
      }
    }
  } else {
    AffinityTile in;
    Status s = inner_->ComputeTile(row_begin, col_begin, rows, cols, &in);
    if (!s.ok()) return s;
    for (std::size_t r = 0; r < rows; ++r) {
      const float row_thr = row_threshold(row_begin + r);
      for (std::size_t c = 0; c < cols; ++c) {
        const float v = in.at(r, c);
        const bool kept = std::isfinite(v) && (v <= row_thr || v <= col_threshold(col_begin + c));
        const float o = kept ? v : kFloatInf;
        out_[r * cols + c] = o;
        lowest = std::min(lowest, o);
      }
    }
  }
  tile->row_begin = row_begin;
  tile->col_begin = col_begin;
  tile->rows = rows;
  tile->cols = cols;
  tile->stride = cols;
  tile->distances = out_.data();
  tile->min_distance = lowest;
  return Status::Ok();
}

}  // namespace commerge
