// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/sequence_smoothing.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/common/float_limits.hpp"

namespace commerge {
namespace {

// S of cell (i, j) (global indices) from a block holding rows [r0, r1) x cols [c0, c1) of the matrix, where
// the block covers every in-matrix cell of the window (the caller's halo). at(ii, jj) reads global indices.
template <class At>
float SmoothCell(At&& at, std::size_t r0, std::size_t r1, std::size_t c0, std::size_t c1, std::size_t i,
                 std::size_t j, std::size_t w) {
  const float center = at(i, j);
  if (!std::isfinite(center)) return kFloatInf;
  double sum_diag = 0.0, sum_anti = 0.0;
  std::size_t n_diag = 0, n_anti = 0;
  // k = -w .. w with unsigned arithmetic: row ii = i + k runs over [i - w, i + w] clipped to [r0, r1).
  const std::size_t ii_begin = i >= r0 + w ? i - w : r0;
  const std::size_t ii_end = std::min(r1, i + w + 1);
  for (std::size_t ii = ii_begin; ii < ii_end; ++ii) {
    // diagonal: column j + (ii - i); anti-diagonal: column j - (ii - i)
    const std::size_t jd = j + ii - i;  // modular arithmetic gives the right value when ii < i
    if (jd >= c0 && jd < c1 && j + ii >= i) {
      const float v = at(ii, jd);
      if (std::isfinite(v)) {
        sum_diag += static_cast<double>(v);
        ++n_diag;
      }
    }
    if (i + j >= ii) {
      const std::size_t ja = i + j - ii;
      if (ja >= c0 && ja < c1) {
        const float v = at(ii, ja);
        if (std::isfinite(v)) {
          sum_anti += static_cast<double>(v);
          ++n_anti;
        }
      }
    }
  }
  // Both lines contain the finite centre, so both counts are >= 1.
  const double mean_diag = sum_diag / static_cast<double>(n_diag);
  const double mean_anti = sum_anti / static_cast<double>(n_anti);
  return static_cast<float>(std::min(mean_diag, mean_anti));
}

// S for the B contiguous columns j0 .. j0 + B - 1 of one row i whose windows lie inside the matrix and hold no
// +inf: rows_k points at row i - w of the block (column c0 first), rows follow at `stride`. Same additions in
// the same order as SmoothCell.
constexpr std::size_t kBlock = 8;
template <std::size_t B>
void SweepBlock(const float* rows_k, std::size_t stride, std::size_t j0, std::size_t w, std::size_t c0, double count,
                float* out) {
  double diag[B] = {}, anti[B] = {};
  for (std::size_t kk = 0; kk <= 2 * w; ++kk, rows_k += stride) {  // k = kk - w
    const float* d = rows_k + (j0 + kk - w - c0);  // A(i + k, j + k)
    const float* a = rows_k + (j0 + w - kk - c0);  // A(i + k, j - k)
    for (std::size_t q = 0; q < B; ++q) {
      diag[q] += static_cast<double>(d[q]);
      anti[q] += static_cast<double>(a[q]);
    }
  }
  for (std::size_t q = 0; q < B; ++q) out[q] = static_cast<float>(std::min(diag[q] / count, anti[q] / count));
}

}  // namespace

float SequenceSmoothedCell(const float* a, std::size_t n, std::size_t m, std::size_t i, std::size_t j,
                           std::size_t half_window) {
  return SmoothCell([&](std::size_t ii, std::size_t jj) { return a[ii * m + jj]; }, 0, n, 0, m, i, j, half_window);
}

Result<SequenceSmoothedTileSource> SequenceSmoothedTileSource::Create(AffinityTileSource* inner,
                                                                      std::size_t half_window,
                                                                      std::size_t max_tile_rows,
                                                                      std::size_t max_tile_cols) {
  if (inner == nullptr) return InvalidArgument("sequence smoothing: no inner tile source");
  if (half_window > kMaxSequenceHalfWindow) {
    return InvalidArgument("sequence smoothing: half window " + std::to_string(half_window) + " is above " +
                           std::to_string(kMaxSequenceHalfWindow));
  }
  if (max_tile_rows == 0 || max_tile_cols == 0) return InvalidArgument("sequence smoothing: tile size must be >= 1 x 1");
  SequenceSmoothedTileSource s;
  s.inner_ = inner;
  s.w_ = half_window;
  s.max_rows_ = max_tile_rows;
  s.max_cols_ = max_tile_cols;
  s.out_.resize(max_tile_rows * max_tile_cols);  // start-up allocations
  s.smoothed_.resize((max_tile_rows + 2) * (max_tile_cols + 2));
  return s;
}

Status SequenceSmoothedTileSource::ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows,
                                               std::size_t cols, AffinityTile* tile) {
  const std::size_t n = num_rows(), m = num_cols();
  if (rows == 0 || cols == 0 || row_begin > n || rows > n - row_begin || col_begin > m || cols > m - col_begin ||
      rows > max_rows_ || cols > max_cols_) {
    return InvalidArgument("sequence smoothing: tile " + std::to_string(rows) + " x " + std::to_string(cols) + " at (" +
                           std::to_string(row_begin) + ", " + std::to_string(col_begin) + ") is outside the " +
                           std::to_string(n) + " x " + std::to_string(m) + " matrix or above the capacity " +
                           std::to_string(max_rows_) + " x " + std::to_string(max_cols_));
  }
  // S over the tile grown by one cell (the 3 x 3 minimum's reach), from A over the tile grown by w + 1.
  const std::size_t e_r0 = row_begin > 0 ? row_begin - 1 : 0, e_r1 = std::min(n, row_begin + rows + 1);
  const std::size_t e_c0 = col_begin > 0 ? col_begin - 1 : 0, e_c1 = std::min(m, col_begin + cols + 1);
  const std::size_t r0 = e_r0 >= w_ ? e_r0 - w_ : 0, r1 = std::min(n, e_r1 + w_);
  const std::size_t c0 = e_c0 >= w_ ? e_c0 - w_ : 0, c1 = std::min(m, e_c1 + w_);
  AffinityTile in;
  Status s = inner_->ComputeTile(r0, c0, r1 - r0, c1 - c0, &in);
  if (!s.ok()) return s;
  const auto at = [&](std::size_t ii, std::size_t jj) { return in.at(ii - r0, jj - c0); };
  const std::size_t e_cols = e_c1 - e_c0;
  bool all_finite = true;  // then the row sweep below may skip the per-cell checks
  for (std::size_t ii = r0; ii < r1 && all_finite; ++ii) {
    for (std::size_t jj = c0; jj < c1; ++jj) all_finite &= std::isfinite(at(ii, jj));
  }
  // Cells whose whole window lies inside the matrix: columns [j_lo, j_hi) of a row i with w <= i < n - w.
  const std::size_t j_lo = std::max(e_c0, w_), j_hi = m > w_ ? std::min(e_c1, m - w_) : 0;
  const double count = static_cast<double>(2 * w_ + 1);
  for (std::size_t i = e_r0; i < e_r1; ++i) {
    float* s_row = smoothed_.data() + (i - e_r0) * e_cols;
    const bool sweep = all_finite && i >= w_ && i + w_ < n && j_lo < j_hi;
    if (!sweep) {
      for (std::size_t j = e_c0; j < e_c1; ++j) s_row[j - e_c0] = SmoothCell(at, r0, r1, c0, c1, i, j, w_);
      continue;
    }
    for (std::size_t j = e_c0; j < j_lo; ++j) s_row[j - e_c0] = SmoothCell(at, r0, r1, c0, c1, i, j, w_);
    for (std::size_t j = j_hi; j < e_c1; ++j) s_row[j - e_c0] = SmoothCell(at, r0, r1, c0, c1, i, j, w_);
    // The same double additions in the same order (ascending k) as SmoothCell, so the result is bit-identical;
    // blocks of 8 contiguous columns keep the sums in registers (vectorised).
    const float* rows_k = in.distances + (i - w_ - r0) * in.stride;  // row i + k for k = -w, then + stride
    std::size_t t = j_lo;
    for (; t + kBlock <= j_hi; t += kBlock) SweepBlock<kBlock>(rows_k, in.stride, t, w_, c0, count, s_row + (t - e_c0));
    for (; t < j_hi; ++t) SweepBlock<1>(rows_k, in.stride, t, w_, c0, count, s_row + (t - e_c0));
  }
  float min_value = kFloatInf;
  for (std::size_t r = 0; r < rows; ++r) {
    const std::size_t i = row_begin + r;
    float* out_row = out_.data() + r * cols;
    for (std::size_t c = 0; c < cols; ++c) {
      const std::size_t j = col_begin + c;
      float v = kFloatInf;
      if (std::isfinite(at(i, j))) {  // an invalid pair never matches, whatever its neighbours
        for (std::size_t ii = (i > e_r0 ? i - 1 : i); ii <= i + 1 && ii < e_r1; ++ii) {
          const float* s_row = smoothed_.data() + (ii - e_r0) * e_cols;
          for (std::size_t jj = (j > e_c0 ? j - 1 : j); jj <= j + 1 && jj < e_c1; ++jj) {
            v = std::min(v, s_row[jj - e_c0]);
          }
        }
      }
      out_row[c] = v;
      min_value = std::min(min_value, v);
    }
  }
  *tile = AffinityTile{row_begin, col_begin, rows, cols, cols, out_.data(), min_value};
  return Status::Ok();
}

}  // namespace commerge
