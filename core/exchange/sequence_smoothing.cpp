// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/sequence_smoothing.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "core/common/float_limits.hpp"
#include "core/common/simd4.hpp"

namespace commerge {
namespace {

// Small SIMD vectors (GCC/Clang vector extensions; V4f in core/common/simd4.hpp); every lane operation is the
// correctly rounded scalar one, so results equal the scalar code's bit for bit. Loads and stores go through memcpy.
typedef std::int32_t V4i __attribute__((vector_size(16)));
typedef float V2f __attribute__((vector_size(8)));
typedef double V2d __attribute__((vector_size(16)));

inline V2d Load2d(const double* p) noexcept {
  V2d v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void Store2d(double* p, V2d v) noexcept { std::memcpy(p, &v, sizeof v); }
inline V2d LoadWiden2(const float* p) noexcept {  // two floats converted to double (exact)
  V2f v;
  std::memcpy(&v, p, sizeof v);
  return __builtin_convertvector(v, V2d);
}
inline void StoreNarrow2(float* p, V2d v) noexcept {  // rounded to float as static_cast<float>
  const V2f f = __builtin_convertvector(v, V2f);
  std::memcpy(p, &f, sizeof f);
}
// std::min(a, b) lane by lane: b < a ? b : a (a when equal).
inline V4f Min4f(V4f a, V4f b) noexcept {
#if defined(__SSE2__)
  return _mm_min_ps(b, a);
#else
  return V4f{b[0] < a[0] ? b[0] : a[0], b[1] < a[1] ? b[1] : a[1], b[2] < a[2] ? b[2] : a[2],
             b[3] < a[3] ? b[3] : a[3]};
#endif
}
inline V2d Min2d(V2d a, V2d b) noexcept {
#if defined(__SSE2__)
  return _mm_min_pd(b, a);
#else
  return V2d{b[0] < a[0] ? b[0] : a[0], b[1] < a[1] ? b[1] : a[1]};
#endif
}

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
// the same order as SmoothCell. One division: for finite sums and count > 0, min(d / c, a / c) == min(d, a) / c
// (correctly rounded division by a positive number is monotone; equal quotients are the same value).
constexpr std::size_t kBlock = 8;
template <std::size_t B>
void SweepBlock(const float* rows_k, std::size_t stride, std::size_t j0, std::size_t w, std::size_t c0, double count,
                double* diag_out, double* anti_out, float* out) {
  double diag[B] = {}, anti[B] = {};
  for (std::size_t kk = 0; kk <= 2 * w; ++kk, rows_k += stride) {  // k = kk - w
    const float* d = rows_k + (j0 + kk - w - c0);  // A(i + k, j + k)
    const float* a = rows_k + (j0 + w - kk - c0);  // A(i + k, j - k)
    for (std::size_t q = 0; q < B; ++q) {
      diag[q] += static_cast<double>(d[q]);
      anti[q] += static_cast<double>(a[q]);
    }
  }
  for (std::size_t q = 0; q < B; ++q) {
    out[q] = static_cast<float>(std::min(diag[q], anti[q]) / count);
    if (diag_out != nullptr) {
      diag_out[q] = diag[q];
      anti_out[q] = anti[q];
    }
  }
}

// Values for which the double sums of a window are exact whatever the order of the additions: 0 or a float in
// [2^-16, 16]. Such floats are multiples of 2^-39; a sum of at most 2 * kMaxSequenceHalfWindow + 1 = 65 of them
// (and every partial sum or difference of such sums) is a multiple of 2^-39 below 2^11, which a double (53-bit
// significand) holds exactly. Then running sums along the diagonals equal SmoothCell's sums bit for bit.
bool ExactlySummable(float v) noexcept { return v == 0.0f || (v >= 0x1p-16f && v <= 16.0f); }

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
  s.row_min_.resize((max_tile_rows + 2) * max_tile_cols);
  for (std::vector<double>* v : {&s.diag_, &s.anti_, &s.diag_next_, &s.anti_next_}) v->resize(max_tile_cols + 2);
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
  // exact: every value ExactlySummable (then finite too), so the sweep may use running sums. all_finite: then the
  // row sweep below may skip the per-cell checks.
  bool exact = true;
  {
    const V4f lo = {0x1p-16f, 0x1p-16f, 0x1p-16f, 0x1p-16f}, hi = {16.0f, 16.0f, 16.0f, 16.0f}, zero = {};
    V4i bad = {};
    for (std::size_t ii = r0; ii < r1; ++ii) {
      const float* row = in.distances + (ii - r0) * in.stride;
      std::size_t q = 0;
      for (; q + 4 <= c1 - c0; q += 4) {
        const V4f v = Load4f(row + q);
        bad |= ~(((v >= lo) & (v <= hi)) | (v == zero));
      }
      for (; q < c1 - c0; ++q) exact &= ExactlySummable(row[q]);
    }
    exact &= (bad[0] | bad[1] | bad[2] | bad[3]) == 0;
  }
  bool all_finite = exact;
  if (!exact) {
    all_finite = true;
    for (std::size_t ii = r0; ii < r1 && all_finite; ++ii) {
      for (std::size_t jj = c0; jj < c1; ++jj) all_finite &= std::isfinite(at(ii, jj));
    }
  }
  // Cells whose whole window lies inside the matrix: columns [j_lo, j_hi) of a row i with w <= i < n - w.
  const std::size_t j_lo = std::max(e_c0, w_), j_hi = m > w_ ? std::min(e_c1, m - w_) : 0;
  const double count = static_cast<double>(2 * w_ + 1);
  bool have_sums = false;  // diag_/anti_ hold the window sums of the previous row's columns [j_lo, j_hi)
  for (std::size_t i = e_r0; i < e_r1; ++i) {
    float* s_row = smoothed_.data() + (i - e_r0) * e_cols;
    const bool sweep = all_finite && i >= w_ && i + w_ < n && j_lo < j_hi;
    if (!sweep) {
      for (std::size_t j = e_c0; j < e_c1; ++j) s_row[j - e_c0] = SmoothCell(at, r0, r1, c0, c1, i, j, w_);
      have_sums = false;
      continue;
    }
    for (std::size_t j = e_c0; j < j_lo; ++j) s_row[j - e_c0] = SmoothCell(at, r0, r1, c0, c1, i, j, w_);
    for (std::size_t j = j_hi; j < e_c1; ++j) s_row[j - e_c0] = SmoothCell(at, r0, r1, c0, c1, i, j, w_);
    const float* rows_k = in.distances + (i - w_ - r0) * in.stride;  // row i + k for k = -w, then + stride
    const std::size_t width = j_hi - j_lo;
    if (exact && have_sums && width >= 2) {
      // Running sums (exact, see ExactlySummable): diag(i, j) = diag(i - 1, j - 1) - A(i - 1 - w, j - 1 - w)
      // + A(i + w, j + w); anti(i, j) = anti(i - 1, j + 1) - A(i - 1 - w, j + 1 + w) + A(i + w, j - w). The
      // first column's diagonal and the last column's anti-diagonal start outside the previous row's range:
      // summed directly.
      // Row i - 1 - w and row i + w of the block, offset so that [j] reads global column j (j >= c0).
      const float* old_base = rows_k - in.stride;
      const float* new_base = rows_k + 2 * w_ * in.stride;
      const auto old_row = [&](std::size_t j) { return static_cast<double>(old_base[j - c0]); };
      const auto new_row = [&](std::size_t j) { return static_cast<double>(new_base[j - c0]); };
      const double* dp = diag_.data();
      const double* ap = anti_.data();
      double* dc = diag_next_.data();
      double* ac = anti_next_.data();
      float* o = s_row + (j_lo - e_c0);
      double d_first = 0.0, a_last = 0.0;
      {
        double dd[1], aa[1];
        float tmp[1];
        SweepBlock<1>(rows_k, in.stride, j_lo, w_, c0, count, dd, aa, tmp);
        d_first = dd[0];
        SweepBlock<1>(rows_k, in.stride, j_hi - 1, w_, c0, count, dd, aa, tmp);
        a_last = aa[0];
      }
      dc[0] = d_first;
      ac[0] = ap[1] - old_row(j_lo + 1 + w_) + new_row(j_lo - w_);
      {
        // q = 1 .. width - 2, column j = j_lo + q; pointers so that the loop vectorises.
        const float* od = old_base + (j_lo - w_ - c0);      // A(i - 1 - w, j - 1 - w) at [q - 1]
        const float* nd = new_base + (j_lo + w_ - c0);      // A(i + w, j + w) at [q]
        const float* oa = old_base + (j_lo + 1 + w_ - c0);  // A(i - 1 - w, j + 1 + w) at [q]
        const float* na = new_base + (j_lo - w_ - c0);      // A(i + w, j - w) at [q]
        std::size_t q = 1;
        for (; q + 2 < width; q += 2) {  // lanes q, q + 1 (both <= width - 2)
          Store2d(dc + q, Load2d(dp + q - 1) - LoadWiden2(od + q - 1) + LoadWiden2(nd + q));
          Store2d(ac + q, Load2d(ap + q + 1) - LoadWiden2(oa + q) + LoadWiden2(na + q));
        }
        for (; q + 1 < width; ++q) {
          dc[q] = dp[q - 1] - static_cast<double>(od[q - 1]) + static_cast<double>(nd[q]);
          ac[q] = ap[q + 1] - static_cast<double>(oa[q]) + static_cast<double>(na[q]);
        }
      }
      dc[width - 1] = dp[width - 2] - old_row(j_hi - 2 - w_) + new_row(j_hi - 1 + w_);
      ac[width - 1] = a_last;
      const V2d cnt = {count, count};
      std::size_t q = 0;
      for (; q + 2 <= width; q += 2) StoreNarrow2(o + q, Min2d(Load2d(dc + q), Load2d(ac + q)) / cnt);
      for (; q < width; ++q) o[q] = static_cast<float>(std::min(dc[q], ac[q]) / count);
      diag_.swap(diag_next_);
      anti_.swap(anti_next_);
      continue;
    }
    // The same double additions in the same order (ascending k) as SmoothCell, so the result is bit-identical;
    // blocks of 8 contiguous columns keep the sums in registers (vectorised).
    double* dsum = exact ? diag_.data() : nullptr;
    double* asum = exact ? anti_.data() : nullptr;
    std::size_t t = j_lo;
    for (; t + kBlock <= j_hi; t += kBlock) {
      SweepBlock<kBlock>(rows_k, in.stride, t, w_, c0, count, dsum ? dsum + (t - j_lo) : nullptr,
                         asum ? asum + (t - j_lo) : nullptr, s_row + (t - e_c0));
    }
    for (; t < j_hi; ++t) {
      SweepBlock<1>(rows_k, in.stride, t, w_, c0, count, dsum ? dsum + (t - j_lo) : nullptr,
                    asum ? asum + (t - j_lo) : nullptr, s_row + (t - e_c0));
    }
    have_sums = exact;
  }
  // V = the 3 x 3 minimum of S (clipped to the grown tile, which is clipped to the matrix only), separably:
  // row minimum over 3 columns, then column minimum over 3 rows. Both keep the first minimal value in row-major
  // order, as the direct 3 x 3 loop does, so even the sign of a zero is the same.
  const std::size_t e_rows = e_r1 - e_r0;
  const std::size_t dc0 = col_begin - e_c0;  // tile column 0 in the grown tile
  for (std::size_t r = 0; r < e_rows; ++r) {
    const float* s_row = smoothed_.data() + r * e_cols;
    float* h = row_min_.data() + r * cols;
    // Cells c with both neighbours inside the grown tile: [c_lo, c_hi); the others are clipped.
    const std::size_t c_lo = dc0 > 0 ? 0 : 1;
    const std::size_t c_hi = std::max(c_lo, dc0 + cols + 1 <= e_cols ? cols : cols - 1);
    const auto clipped = [&](std::size_t c) {
      const std::size_t x = dc0 + c;  // grown-tile column of cell c
      const std::size_t lo = x > 0 ? x - 1 : x, hi = x + 1 < e_cols ? x + 1 : x;
      float v = s_row[lo];
      for (std::size_t xx = lo + 1; xx <= hi; ++xx) v = std::min(v, s_row[xx]);
      return v;
    };
    for (std::size_t c = 0; c < std::min(c_lo, cols); ++c) h[c] = clipped(c);
    const float* sl = s_row + dc0;  // sl[c - 1], sl[c], sl[c + 1] are the 3 columns of cell c
    std::size_t c = c_lo;
    for (; c + 4 <= c_hi; c += 4) {
      Store4f(h + c, Min4f(Min4f(Load4f(sl + c - 1), Load4f(sl + c)), Load4f(sl + c + 1)));
    }
    for (; c < c_hi; ++c) h[c] = std::min(std::min(*(sl + c - 1), sl[c]), sl[c + 1]);  // (sl + c) - 1: c may be 0
    for (c = std::max(c_hi, c_lo); c < cols; ++c) h[c] = clipped(c);
  }
  float min_value = kFloatInf;
  const std::size_t dr0 = row_begin - e_r0;
  for (std::size_t r = 0; r < rows; ++r) {
    const std::size_t y = dr0 + r;
    const std::size_t lo = y > 0 ? y - 1 : y, hi = y + 1 < e_rows ? y + 1 : y;
    float* out_row = out_.data() + r * cols;
    const float* a_row = in.distances + (row_begin + r - r0) * in.stride + (col_begin - c0);
    const float* h_lo = row_min_.data() + lo * cols;
    std::copy(h_lo, h_lo + cols, out_row);
    for (std::size_t yy = lo + 1; yy <= hi; ++yy) {
      const float* h = row_min_.data() + yy * cols;
      std::size_t c = 0;
      for (; c + 4 <= cols; c += 4) Store4f(out_row + c, Min4f(Load4f(out_row + c), Load4f(h + c)));
      for (; c < cols; ++c) out_row[c] = std::min(out_row[c], h[c]);
    }
    // An invalid pair never matches, whatever its neighbours. The tile minimum: S holds no NaN and no -0 (its
    // sums start at +0), so the order in which the minimum is taken does not matter.
    const V4f inf4 = {kFloatInf, kFloatInf, kFloatInf, kFloatInf};
    const V4f big = {std::numeric_limits<float>::max(), std::numeric_limits<float>::max(),
                     std::numeric_limits<float>::max(), std::numeric_limits<float>::max()};
    V4f low = inf4;
    std::size_t c = 0;
    for (; c + 4 <= cols; c += 4) {
      const V4f a = Load4f(a_row + c);
      const V4i finite = (a <= big) & (a >= -big);
      const V4f v = (V4f)(((V4i)Load4f(out_row + c) & finite) | ((V4i)inf4 & ~finite));
      Store4f(out_row + c, v);
      low = Min4f(low, v);
    }
    for (; c < cols; ++c) {
      if (!std::isfinite(a_row[c])) out_row[c] = kFloatInf;
      min_value = std::min(min_value, out_row[c]);
    }
    for (int q = 0; q < 4; ++q) min_value = std::min(min_value, low[q]);
  }
  *tile = AffinityTile{row_begin, col_begin, rows, cols, cols, out_.data(), min_value};
  return Status::Ok();
}

}  // namespace commerge
