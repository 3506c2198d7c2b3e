// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/neighbour_rank.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/common/float_limits.hpp"

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

Status NeighbourRankTileSource::Prepare() {
  const std::size_t n = inner_->num_rows(), m = inner_->num_cols();
  row_kth_.assign(n * k_, kFloatInf);
  col_kth_.assign(m * k_, kFloatInf);
  prepared_ = false;
  if (n == 0 || m == 0) {
    prepared_ = true;
    return Status::Ok();
  }
  Status s = ForEachAffinityTile(*inner_, max_rows_, max_cols_, [&](const AffinityTile& t) -> Status {
    for (std::size_t r = 0; r < t.rows; ++r) {
      float* row_list = row_kth_.data() + (t.row_begin + r) * k_;
      for (std::size_t c = 0; c < t.cols; ++c) {
        const float v = t.at(r, c);
        if (!std::isfinite(v)) continue;
        KeepSmallest(v, row_list, k_);
        KeepSmallest(v, col_kth_.data() + (t.col_begin + c) * k_, k_);
      }
    }
    return Status::Ok();
  });
  if (!s.ok()) return s;
  prepared_ = true;
  return Status::Ok();
}

Status NeighbourRankTileSource::ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows,
                                            std::size_t cols, AffinityTile* tile) {
  if (!prepared_) return Status(StatusCode::kInternal, "neighbour rank: ComputeTile before Prepare");
  if (rows > max_rows_ || cols > max_cols_) {
    return InvalidArgument("neighbour rank: tile " + std::to_string(rows) + " x " + std::to_string(cols) +
                           " exceeds the capacity " + std::to_string(max_rows_) + " x " + std::to_string(max_cols_));
  }
  AffinityTile in;
  Status s = inner_->ComputeTile(row_begin, col_begin, rows, cols, &in);
  if (!s.ok()) return s;
  out_.resize(rows * cols);
  float lowest = kFloatInf;
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
