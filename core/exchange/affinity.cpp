// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/affinity.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#if defined(__SSE2__)
#include <emmintrin.h>
#elif defined(__ARM_NEON) && defined(__aarch64__)
#include <arm_neon.h>
#endif

#include "core/common/float_limits.hpp"
#include "core/common/simd4.hpp"
#include "core/descriptor/scan_context.hpp"
#include "core/descriptor/solid.hpp"

namespace commerge {

double DescriptorDistance(const DescriptorMetric& metric, Span<const float> a, Span<const float> b) noexcept {
  if (metric.kind == DescriptorMetric::Kind::kScanContext) {
    return MatchScanContext(a, b, metric.scan_context_rings, metric.scan_context_sectors).distance;
  }
  return SolidDistance(a, b);
}
namespace {

constexpr std::size_t kMr = 6;  // alpha rows per micro block (6 x 8: 12 accumulators + 3 in 16 registers)
constexpr std::size_t kNr = 8;  // beta columns per panel (two 4-float vectors)
constexpr std::size_t kChunkBytes = 16384;  // packed beta swept by all row blocks of a tile, L1 resident

// Four floats in one SIMD register (core/common/simd4.hpp).
using V4 = V4f;
inline V4 Load4(const float* p) noexcept { return Load4f(p); }
inline void Store4(float* p, V4 v) noexcept { Store4f(p, v); }
inline V4 Splat4(float x) noexcept { return V4{x, x, x, x}; }

// The finishing operations, lane by lane correctly rounded (identical in every lane and position).
inline V4 Max4(V4 a, V4 b) noexcept {
#if defined(__SSE2__)
  return _mm_max_ps(a, b);
#elif defined(__ARM_NEON) && defined(__aarch64__)
  return (V4)vmaxq_f32((float32x4_t)a, (float32x4_t)b);
#else
  return V4{a[0] > b[0] ? a[0] : b[0], a[1] > b[1] ? a[1] : b[1], a[2] > b[2] ? a[2] : b[2],
            a[3] > b[3] ? a[3] : b[3]};
#endif
}
inline V4 Min4(V4 a, V4 b) noexcept {
#if defined(__SSE2__)
  return _mm_min_ps(a, b);
#elif defined(__ARM_NEON) && defined(__aarch64__)
  return (V4)vminq_f32((float32x4_t)a, (float32x4_t)b);
#else
  return V4{a[0] < b[0] ? a[0] : b[0], a[1] < b[1] ? a[1] : b[1], a[2] < b[2] ? a[2] : b[2],
            a[3] < b[3] ? a[3] : b[3]};
#endif
}
inline V4 Sqrt4(V4 a) noexcept {
#if defined(__SSE2__)
  return _mm_sqrt_ps(a);
#elif defined(__ARM_NEON) && defined(__aarch64__)
  return (V4)vsqrtq_f32((float32x4_t)a);
#else
  return V4{std::sqrt(a[0]), std::sqrt(a[1]), std::sqrt(a[2]), std::sqrt(a[3])};
#endif
}

// ||v||^2 (double sum rounded to float) of an effectively valid keyframe, else +inf: flag 0, a non-finite
// value, a squared norm that rounds to 0 or exceeds kMaxDescriptorNorm2. Appends rows [begin, end).
void AppendEffectiveNorms2(const DescriptorSetView& set, std::size_t begin, std::size_t end, std::vector<float>* out) {
  for (std::size_t i = begin; i < end; ++i) {
    float norm2 = kFloatInf;
    if (set.valid.empty() || set.valid[i] != 0) {
      const float* row = set.values.data() + i * set.dim;
      double s = 0.0;
      bool finite = true;
      for (std::size_t k = 0; k < set.dim; ++k) {
        const double x = static_cast<double>(row[k]);
        if (!std::isfinite(x)) {
          finite = false;
          break;
        }
        s += x * x;
      }
      const double kMax = static_cast<double>(kMaxDescriptorNorm2);
      if (finite && s <= kMax) {  // s <= 1e30: the float rounding below stays finite
        const auto f = static_cast<float>(s);
        if (f > 0.0f && f <= kMaxDescriptorNorm2) norm2 = f;
      }
    }
    out->push_back(norm2);
  }
}

std::size_t NumPanels(std::size_t cols) { return (cols + kNr - 1) / kNr; }

}  // namespace

Status ValidateDescriptorSet(const DescriptorSetView& set, const char* name) {
  if (set.dim == 0) return InvalidArgument(std::string(name) + ": descriptor dimension must be >= 1");
  if (set.values.size() % set.dim != 0) {
    return InvalidArgument(std::string(name) + ": " + std::to_string(set.values.size()) +
                           " values are not a multiple of the dimension " + std::to_string(set.dim));
  }
  if (!set.valid.empty() && set.valid.size() != set.count()) {
    return InvalidArgument(std::string(name) + ": " + std::to_string(set.valid.size()) + " validity flags for " +
                           std::to_string(set.count()) + " keyframes");
  }
  return Status::Ok();
}

Result<AffinityTileKernel> AffinityTileKernel::Create(const DescriptorSetView& alpha, const DescriptorSetView& beta,
                                                      std::size_t max_tile_rows, std::size_t max_tile_cols) {
  Status s = ValidateDescriptorSet(alpha, "affinity alpha");
  if (!s.ok()) return s;
  s = ValidateDescriptorSet(beta, "affinity beta");
  if (!s.ok()) return s;
  if (alpha.dim != beta.dim) {
    return InvalidArgument("affinity: descriptor dimensions differ (alpha " + std::to_string(alpha.dim) +
                           ", beta " + std::to_string(beta.dim) + ")");
  }
  if (max_tile_rows == 0 || max_tile_cols == 0) return InvalidArgument("affinity: tile size must be >= 1 x 1");
  AffinityTileKernel k;
  k.dim_ = alpha.dim;
  k.max_tile_rows_ = max_tile_rows;
  k.max_tile_cols_ = max_tile_cols;
  k.alpha_pack_.assign(k.dim_ * kMr * 4, 0.0f);
  s = k.Extend(alpha, beta);
  if (!s.ok()) return s;
  return k;
}

void AffinityTileKernel::Reserve(std::size_t alpha_count, std::size_t beta_count) {
  alpha_norm2_.reserve(alpha_count);
  beta_norm2_.reserve(beta_count);
  beta_pack_.reserve(NumPanels(beta_count) * kNr * dim_);
  beta_norm_pack_.reserve(NumPanels(beta_count) * kNr);
}

Status AffinityTileKernel::Extend(const DescriptorSetView& alpha, const DescriptorSetView& beta) {
  Status s = ValidateDescriptorSet(alpha, "affinity alpha");
  if (!s.ok()) return s;
  s = ValidateDescriptorSet(beta, "affinity beta");
  if (!s.ok()) return s;
  if (alpha.dim != dim_ || beta.dim != dim_) {
    return InvalidArgument("affinity: descriptor dimension changed (kernel " + std::to_string(dim_) + ", alpha " +
                           std::to_string(alpha.dim) + ", beta " + std::to_string(beta.dim) + ")");
  }
  if (alpha.count() < alpha_count_ || beta.count() < beta_count_) {
    return InvalidArgument("affinity: a descriptor set shrank (alpha " + std::to_string(alpha_count_) + " -> " +
                           std::to_string(alpha.count()) + ", beta " + std::to_string(beta_count_) + " -> " +
                           std::to_string(beta.count()) + ")");
  }
  alpha_ = alpha.values.data();
  beta_ = beta.values.data();
  AppendEffectiveNorms2(alpha, alpha_count_, alpha.count(), &alpha_norm2_);
  AppendEffectiveNorms2(beta, beta_count_, beta.count(), &beta_norm2_);
  const std::size_t first_new_col = beta_count_;
  alpha_count_ = alpha.count();
  beta_count_ = beta.count();
  PackBetaFrom(first_new_col);
  return Status::Ok();
}

void AffinityTileKernel::PackBetaFrom(std::size_t first_col) {
  const std::size_t panels = NumPanels(beta_count_);
  beta_pack_.resize(panels * kNr * dim_, 0.0f);      // new panels: every column zero
  beta_norm_pack_.resize(panels * kNr, kFloatInf);   // new panels: every column padding
  for (std::size_t j = first_col; j < beta_count_; ++j) {
    const std::size_t p = j / kNr, lane = j % kNr;
    float* dst = beta_pack_.data() + p * kNr * dim_ + lane;
    const bool valid = beta_norm2_[j] <= kMaxDescriptorNorm2;
    const float* src = beta_ + j * dim_;
    for (std::size_t k = 0; k < dim_; ++k) dst[k * kNr] = valid ? src[k] : 0.0f;  // invalid: 0, never NaN
    beta_norm_pack_[p * kNr + lane] = beta_norm2_[j];
  }
}

Status AffinityTileKernel::ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows,
                                       std::size_t cols, AffinityTile* tile) {
  if (rows == 0 || cols == 0 || row_begin > alpha_count_ || rows > alpha_count_ - row_begin ||
      col_begin > beta_count_ || cols > beta_count_ - col_begin || rows > max_tile_rows_ || cols > max_tile_cols_) {
    return InvalidArgument("affinity: tile " + std::to_string(rows) + " x " + std::to_string(cols) + " at (" +
                           std::to_string(row_begin) + ", " + std::to_string(col_begin) + ") is empty, outside the " +
                           std::to_string(alpha_count_) + " x " + std::to_string(beta_count_) +
                           " matrix or above the tile capacity");
  }
  if (tile_.size() < rows * cols) tile_.resize(rows * cols);  // grows to at most one full tile, once
  const std::size_t dim = dim_, col_end = col_begin + cols;
  const std::size_t p_begin = col_begin / kNr, p_end = NumPanels(col_end);
  V4 vmin = Splat4(kFloatInf);
  float smin = kFloatInf;
  float block[kMr * kNr];
  float* const apack = alpha_pack_.data();
  // Column chunks of packed beta small enough to stay in L1 (~16 KiB) while every row block sweeps them.
  const std::size_t chunk_panels = std::max<std::size_t>(1, kChunkBytes / (kNr * dim * sizeof(float)));

  for (std::size_t chunk_begin = p_begin; chunk_begin < p_end; chunk_begin += chunk_panels) {
    const std::size_t chunk_end = std::min(p_end, chunk_begin + chunk_panels);
    for (std::size_t rb = 0; rb < rows; rb += kMr) {
      // Micro block of kMr alpha rows, a_ik broadcast to 4 lanes; padding / invalid rows are 0 with norm +inf.
      const std::size_t live = std::min(kMr, rows - rb);
      float na[kMr];
      for (std::size_t r = 0; r < kMr; ++r) {
        const std::size_t i = row_begin + rb + r;
        na[r] = r < live ? alpha_norm2_[i] : kFloatInf;
        const float* src = r < live && na[r] <= kMaxDescriptorNorm2 ? alpha_ + i * dim : nullptr;
        for (std::size_t k = 0; k < dim; ++k) Store4(apack + (k * kMr + r) * 4, Splat4(src ? src[k] : 0.0f));
      }
      for (std::size_t p = chunk_begin; p < chunk_end; ++p) {
        // acc[r][h] = a_r . b_(8p + 4h + lane), accumulated over k in order: one code path for every cell.
        const float* ap = apack;
        const float* bp = beta_pack_.data() + p * kNr * dim;
        V4 c00 = Splat4(0.0f), c01 = c00, c10 = c00, c11 = c00, c20 = c00, c21 = c00, c30 = c00, c31 = c00;
        V4 c40 = c00, c41 = c00, c50 = c00, c51 = c00;
        for (std::size_t k = 0; k < dim; ++k) {
          const V4 b0 = Load4(bp), b1 = Load4(bp + 4);
          const V4 a0 = Load4(ap), a1 = Load4(ap + 4), a2 = Load4(ap + 8), a3 = Load4(ap + 12);
          const V4 a4 = Load4(ap + 16), a5 = Load4(ap + 20);
          c00 += a0 * b0;
          c01 += a0 * b1;
          c10 += a1 * b0;
          c11 += a1 * b1;
          c20 += a2 * b0;
          c21 += a2 * b1;
          c30 += a3 * b0;
          c31 += a3 * b1;
          c40 += a4 * b0;
          c41 += a4 * b1;
          c50 += a5 * b0;
          c51 += a5 * b1;
          bp += kNr;
          ap += 4 * kMr;
        }
        // d = sqrt(max(0, (||a||^2 + ||b||^2) - 2 a.b)); a +inf norm (invalid / padding) gives +inf.
        const V4 nb0 = Load4(beta_norm_pack_.data() + p * kNr), nb1 = Load4(beta_norm_pack_.data() + p * kNr + 4);
        const V4 zero = Splat4(0.0f);
        const V4 acc[kMr][2] = {{c00, c01}, {c10, c11}, {c20, c21}, {c30, c31}, {c40, c41}, {c50, c51}};
        for (std::size_t r = 0; r < kMr; ++r) {
          const V4 nr = Splat4(na[r]);
          const V4 d0 = Sqrt4(Max4((nr + nb0) - acc[r][0] * 2.0f, zero));
          const V4 d1 = Sqrt4(Max4((nr + nb1) - acc[r][1] * 2.0f, zero));
          Store4(block + r * kNr, d0);
          Store4(block + r * kNr + 4, d1);
          if (p * kNr >= col_begin && (p + 1) * kNr <= col_end) vmin = Min4(vmin, Min4(d0, d1));
        }
        const std::size_t c0 = std::max(p * kNr, col_begin), c1 = std::min((p + 1) * kNr, col_end);
        for (std::size_t r = 0; r < live; ++r) {
          const float* src = block + r * kNr + (c0 - p * kNr);
          std::memcpy(tile_.data() + (rb + r) * cols + (c0 - col_begin), src, (c1 - c0) * sizeof(float));
          if (c0 != p * kNr || c1 != (p + 1) * kNr) {  // edge panel: only the requested columns count
            for (std::size_t c = 0; c < c1 - c0; ++c) smin = std::min(smin, src[c]);
          }
        }
      }
    }
  }
  float vm[4];
  Store4(vm, vmin);
  for (const float x : vm) smin = std::min(smin, x);
  cells_computed_ += static_cast<std::uint64_t>(rows) * static_cast<std::uint64_t>(cols);
  *tile = AffinityTile::Dense(row_begin, col_begin, rows, cols, tile_.data(), smin);
  return Status::Ok();
}

Status ComputeAffinityNaive(const DescriptorSetView& alpha, const DescriptorSetView& beta, std::vector<double>* out) {
  Status s = ValidateDescriptorSet(alpha, "affinity alpha");
  if (!s.ok()) return s;
  s = ValidateDescriptorSet(beta, "affinity beta");
  if (!s.ok()) return s;
  if (alpha.dim != beta.dim) return InvalidArgument("affinity: descriptor dimensions differ");
  std::vector<float> na, nb;
  AppendEffectiveNorms2(alpha, 0, alpha.count(), &na);
  AppendEffectiveNorms2(beta, 0, beta.count(), &nb);
  const std::size_t n = alpha.count(), m = beta.count(), d = alpha.dim;
  out->assign(n * m, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < n; ++i) {
    if (!(na[i] <= kMaxDescriptorNorm2)) continue;
    for (std::size_t j = 0; j < m; ++j) {
      if (!(nb[j] <= kMaxDescriptorNorm2)) continue;
      (*out)[i * m + j] = SolidDistance(alpha.values.subspan(i * d, d), beta.values.subspan(j * d, d));
    }
  }
  return Status::Ok();
}

}  // namespace commerge
