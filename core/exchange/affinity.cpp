// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/affinity.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/descriptor/solid.hpp"

namespace commerge {
namespace {

using RowMajorMatrixF = Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// ||v||^2 of an effectively valid keyframe, or -1 (flag 0, a non-finite value, or a zero vector).
std::vector<float> EffectiveNorms2(const DescriptorSetView& set) {
  const std::size_t n = set.count();
  std::vector<float> norms(n, -1.0f);
  for (std::size_t i = 0; i < n; ++i) {
    if (!set.valid.empty() && set.valid[i] == 0) continue;
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
    if (finite && s > 0.0 && std::isfinite(s)) norms[i] = static_cast<float>(s);
  }
  return norms;
}

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
  k.alpha_ = alpha.values.data();
  k.beta_ = beta.values.data();
  k.dim_ = alpha.dim;
  k.alpha_count_ = alpha.count();
  k.beta_count_ = beta.count();
  k.max_tile_rows_ = max_tile_rows;
  k.max_tile_cols_ = max_tile_cols;
  k.alpha_norm2_ = EffectiveNorms2(alpha);
  k.beta_norm2_ = EffectiveNorms2(beta);
  // Never larger than the matrix itself (a 1 x 1000 problem does not need a 256 x 256 buffer).
  const std::size_t rows = std::min(max_tile_rows, std::max<std::size_t>(k.alpha_count_, 1));
  const std::size_t cols = std::min(max_tile_cols, std::max<std::size_t>(k.beta_count_, 1));
  k.tile_.assign(rows * cols, 0.0f);
  return k;
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
  const auto dim = static_cast<Eigen::Index>(dim_);
  Eigen::Map<const RowMajorMatrixF> a(alpha_ + row_begin * dim_, static_cast<Eigen::Index>(rows), dim);
  Eigen::Map<const RowMajorMatrixF> b(beta_ + col_begin * dim_, static_cast<Eigen::Index>(cols), dim);
  Eigen::Map<RowMajorMatrixF> g(tile_.data(), static_cast<Eigen::Index>(rows), static_cast<Eigen::Index>(cols));
  g.noalias() = a * b.transpose();  // Gram block a_i . b_j
  constexpr float kInf = std::numeric_limits<float>::infinity();
  for (std::size_t r = 0; r < rows; ++r) {
    float* out = tile_.data() + r * cols;
    const float na = alpha_norm2_[row_begin + r];
    if (na < 0.0f) {
      for (std::size_t c = 0; c < cols; ++c) out[c] = kInf;
      continue;
    }
    const float* nb = beta_norm2_.data() + col_begin;
    for (std::size_t c = 0; c < cols; ++c) {
      const float d2 = na + nb[c] - 2.0f * out[c];
      out[c] = nb[c] < 0.0f ? kInf : std::sqrt(d2 > 0.0f ? d2 : 0.0f);
    }
  }
  tile->row_begin = row_begin;
  tile->col_begin = col_begin;
  tile->rows = rows;
  tile->cols = cols;
  tile->stride = cols;
  tile->distances = tile_.data();
  return Status::Ok();
}

Status ComputeAffinityNaive(const DescriptorSetView& alpha, const DescriptorSetView& beta, std::vector<double>* out) {
  Status s = ValidateDescriptorSet(alpha, "affinity alpha");
  if (!s.ok()) return s;
  s = ValidateDescriptorSet(beta, "affinity beta");
  if (!s.ok()) return s;
  if (alpha.dim != beta.dim) return InvalidArgument("affinity: descriptor dimensions differ");
  const std::vector<float> na = EffectiveNorms2(alpha), nb = EffectiveNorms2(beta);
  const std::size_t n = alpha.count(), m = beta.count(), d = alpha.dim;
  out->assign(n * m, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < n; ++i) {
    if (na[i] < 0.0f) continue;
    for (std::size_t j = 0; j < m; ++j) {
      if (nb[j] < 0.0f) continue;
      (*out)[i * m + j] = SolidDistance(alpha.values.subspan(i * d, d), beta.values.subspan(j * d, d));
    }
  }
  return Status::Ok();
}

}  // namespace commerge
