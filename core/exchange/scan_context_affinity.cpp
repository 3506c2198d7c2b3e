// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/scan_context_affinity.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "core/common/float_limits.hpp"
#include "core/descriptor/scan_context.hpp"

namespace commerge {
namespace {
// A named namespace of its own: unity builds compile this file with affinity.cpp, which has a V4 too.
namespace sc_kernel {

// Four floats in one SIMD register (GCC/Clang vector extension: SSE2 on x86-64, NEON on aarch64), loads through
// memcpy (no alignment or aliasing assumption), as in affinity.cpp.
typedef float V4 __attribute__((vector_size(16)));

inline V4 Load4(const float* p) noexcept {
  V4 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

// A dot product with four independent vector accumulators (the add latency would otherwise bound the loop) and
// a scalar tail. The order of operations depends only on the lengths added, never on the caller, so every cell
// and every mode that adds the same lengths gets the same float.
struct DotAccumulator {
  V4 a0{0.0f, 0.0f, 0.0f, 0.0f}, a1 = a0, a2 = a0, a3 = a0;
  float tail = 0.0f;

  void Add(const float* x, const float* y, std::size_t n) noexcept {
    std::size_t t = 0;
    for (; t + 16 <= n; t += 16) {
      a0 += Load4(x + t) * Load4(y + t);
      a1 += Load4(x + t + 4) * Load4(y + t + 4);
      a2 += Load4(x + t + 8) * Load4(y + t + 8);
      a3 += Load4(x + t + 12) * Load4(y + t + 12);
    }
    for (; t + 4 <= n; t += 4) a0 += Load4(x + t) * Load4(y + t);
    for (; t < n; ++t) tail += x[t] * y[t];
  }
  float Sum() const noexcept {
    const V4 s = (a0 + a1) + (a2 + a3);
    return ((s[0] + s[1]) + (s[2] + s[3])) + tail;
  }
};

std::size_t RoundUp4(std::size_t n) { return (n + 3) / 4 * 4; }

}  // namespace sc_kernel
}  // namespace

const char* ScanContextAffinityModeName(ScanContextAffinityMode mode) noexcept {
  return mode == ScanContextAffinityMode::kExact ? "exact" : "sector-key";
}

Status ValidateScanContextAffinityParams(const ScanContextAffinityParams& p) {
  if (p.num_rings < 1 || p.num_rings > kScanContextMaxRings) {
    return InvalidArgument("Scan Context affinity: num_rings must be in [1, " + std::to_string(kScanContextMaxRings) +
                           "], got " + std::to_string(p.num_rings));
  }
  if (p.num_sectors < 1 || p.num_sectors > kScanContextMaxSectors || 360 % p.num_sectors != 0) {
    return InvalidArgument("Scan Context affinity: num_sectors must be in [1, 360] and divide 360, got " +
                           std::to_string(p.num_sectors));
  }
  if (p.mode != ScanContextAffinityMode::kExact && p.mode != ScanContextAffinityMode::kSectorKeyShift) {
    return InvalidArgument("Scan Context affinity: unknown mode " + std::to_string(static_cast<int>(p.mode)));
  }
  if (p.num_candidate_shifts < 1 || p.num_candidate_shifts > kScanContextMaxSectors) {
    return InvalidArgument("Scan Context affinity: num_candidate_shifts must be in [1, " +
                           std::to_string(kScanContextMaxSectors) + "], got " + std::to_string(p.num_candidate_shifts));
  }
  if (p.shift_window_sectors < 0 || p.shift_window_sectors > kScanContextMaxSectors / 2) {
    return InvalidArgument("Scan Context affinity: shift_window_sectors must be in [0, " +
                           std::to_string(kScanContextMaxSectors / 2) + "], got " +
                           std::to_string(p.shift_window_sectors));
  }
  return Status::Ok();
}

void ScanContextTileSource::Prepare(const DescriptorSetView& set, int num_rings, int num_sectors,
                                    std::size_t padded_rings, int key_copies, Prepared* out) {
  const std::size_t n = set.count(), nr = static_cast<std::size_t>(num_rings), ns = static_cast<std::size_t>(num_sectors);
  const std::size_t key_len = ns * static_cast<std::size_t>(key_copies);
  out->count = n;
  out->columns.assign(n * ns * padded_rings, 0.0f);
  out->masks.assign(n * key_len, 0.0f);  // the masks are stored as many times as the keys
  out->keys.assign(n * key_len, 0.0f);
  out->valid.assign(n, 0);
  double means[kScanContextMaxSectors];
  for (std::size_t k = 0; k < n; ++k) {
    const float* row = set.values.data() + k * set.dim;
    bool valid = set.valid.empty() || set.valid[k] != 0;
    bool any_nonzero = false;
    for (std::size_t t = 0; valid && t < set.dim; ++t) {
      valid = std::isfinite(row[t]);
      any_nonzero = any_nonzero || row[t] != 0.0f;
    }
    if (!valid || !any_nonzero) continue;  // invalid: zeros, never read (the cell is +inf)
    out->valid[k] = 1;
    float* cols = out->columns.data() + k * ns * padded_rings;
    float* mask = out->masks.data() + k * key_len;
    double max_abs_mean = 0.0;
    for (std::size_t c = 0; c < ns; ++c) {
      double norm2 = 0.0, sum = 0.0;
      for (std::size_t r = 0; r < nr; ++r) {
        const double v = static_cast<double>(row[r * ns + c]);
        norm2 += v * v;
        sum += v;
      }
      means[c] = sum / static_cast<double>(nr);
      max_abs_mean = std::max(max_abs_mean, std::fabs(means[c]));
      if (!(norm2 > 0.0)) continue;
      const double inv = 1.0 / std::sqrt(norm2);
      for (std::size_t r = 0; r < nr; ++r) {
        cols[c * padded_rings + r] = static_cast<float>(static_cast<double>(row[r * ns + c]) * inv);
      }
      for (int copy = 0; copy < key_copies; ++copy) mask[static_cast<std::size_t>(copy) * ns + c] = 1.0f;
    }
    // The key scaled to max |key| = 1: the alignment (an argmax of the correlation) is unchanged, and the
    // correlation stays finite whatever the cell values.
    float* key = out->keys.data() + k * key_len;
    for (std::size_t c = 0; c < ns; ++c) {
      const auto v = static_cast<float>(max_abs_mean > 0.0 ? means[c] / max_abs_mean : 0.0);
      for (int copy = 0; copy < key_copies; ++copy) key[static_cast<std::size_t>(copy) * ns + c] = v;
    }
  }
}

Result<ScanContextTileSource> ScanContextTileSource::Create(const DescriptorSetView& alpha,
                                                            const DescriptorSetView& beta,
                                                            const ScanContextAffinityParams& params,
                                                            std::size_t max_tile_rows, std::size_t max_tile_cols) {
  if (Status s = ValidateScanContextAffinityParams(params); !s.ok()) return s;
  if (Status s = ValidateDescriptorSet(alpha, "Scan Context affinity alpha"); !s.ok()) return s;
  if (Status s = ValidateDescriptorSet(beta, "Scan Context affinity beta"); !s.ok()) return s;
  const std::size_t dim = static_cast<std::size_t>(params.num_rings) * static_cast<std::size_t>(params.num_sectors);
  if (alpha.dim != dim || beta.dim != dim) {
    return InvalidArgument("Scan Context affinity: descriptor dimensions alpha " + std::to_string(alpha.dim) +
                           ", beta " + std::to_string(beta.dim) + ", expected num_rings x num_sectors = " +
                           std::to_string(params.num_rings) + " x " + std::to_string(params.num_sectors) + " = " +
                           std::to_string(dim));
  }
  if (max_tile_rows == 0 || max_tile_cols == 0) {
    return InvalidArgument("Scan Context affinity: tile capacity must be >= 1 x 1, got " +
                           std::to_string(max_tile_rows) + " x " + std::to_string(max_tile_cols));
  }
  ScanContextTileSource src;
  src.params_ = params;
  src.padded_rings_ = sc_kernel::RoundUp4(static_cast<std::size_t>(params.num_rings));
  src.max_tile_rows_ = max_tile_rows;
  src.max_tile_cols_ = max_tile_cols;
  // Query keys once; candidate keys and masks twice, so that every shift is one contiguous run.
  Prepare(alpha, params.num_rings, params.num_sectors, src.padded_rings_, 1, &src.alpha_);
  Prepare(beta, params.num_rings, params.num_sectors, src.padded_rings_, 2, &src.beta_);
  // No tile is larger than the matrix: the buffer never exceeds N x M whatever capacity is asked for.
  src.tile_.assign(std::min(max_tile_rows, alpha.count()) * std::min(max_tile_cols, beta.count()), 0.0f);
  return src;
}

// d_s of one pair: query column c against candidate column (c + s) mod N_s. The candidate columns wrap, so the
// sum is two contiguous runs: query columns [0, N_s - s) with candidate [s, N_s), then [N_s - s, N_s) with [0, s).
float ScanContextTileSource::ShiftDistance(const float* q_cols, const float* q_mask, const float* c_cols,
                                           const float* c_mask2, int shift) const noexcept {
  const auto ns = static_cast<std::size_t>(params_.num_sectors), s = static_cast<std::size_t>(shift);
  const std::size_t head = (ns - s) * padded_rings_, tail = s * padded_rings_;
  sc_kernel::DotAccumulator cos_sum;
  cos_sum.Add(q_cols, c_cols + tail, head);
  cos_sum.Add(q_cols + head, c_cols, tail);
  sc_kernel::DotAccumulator columns;  // |C_s|: an exact integer in float
  columns.Add(q_mask, c_mask2 + s, ns);
  const float count = columns.Sum();
  if (!(count > 0.5f)) return 1.0f;  // no column non-empty in both
  const float d = 1.0f - cos_sum.Sum() / count;
  return std::min(2.0f, std::max(0.0f, d));  // rounding may step just outside [0, 2]
}

float ScanContextTileSource::CellDistance(std::size_t i, std::size_t j) noexcept {
  if (alpha_.valid[i] == 0 || beta_.valid[j] == 0) return kFloatInf;
  const int ns = params_.num_sectors;
  const std::size_t nsz = static_cast<std::size_t>(ns), col_floats = nsz * padded_rings_;
  const float* q_cols = alpha_.columns.data() + i * col_floats;
  const float* q_mask = alpha_.masks.data() + i * nsz;
  const float* c_cols = beta_.columns.data() + j * col_floats;
  const float* c_mask2 = beta_.masks.data() + j * 2 * nsz;
  float best = kFloatInf;
  if (params_.mode == ScanContextAffinityMode::kExact) {
    for (int s = 0; s < ns; ++s) best = std::min(best, ShiftDistance(q_cols, q_mask, c_cols, c_mask2, s));
    shifts_evaluated_ += nsz;
    return best;
  }
  // Sector-key alignment: corr(s) = sum_c key_q[c] key_c[(c + s) mod N_s] (argmax = SC-LIO-SAM's L2 argmin, the
  // keys' norms do not depend on s), then the peaks, each outside the windows of the earlier ones.
  const float* q_key = alpha_.keys.data() + i * nsz;
  const float* c_key2 = beta_.keys.data() + j * 2 * nsz;
  float corr[kScanContextMaxSectors];
  bool evaluate[kScanContextMaxSectors];
  for (int s = 0; s < ns; ++s) {
    sc_kernel::DotAccumulator acc;
    acc.Add(q_key, c_key2 + s, nsz);
    corr[s] = acc.Sum();
    evaluate[s] = false;
  }
  const int w = params_.shift_window_sectors;
  for (int peak = 0; peak < params_.num_candidate_shifts; ++peak) {
    int arg = -1;
    for (int s = 0; s < ns; ++s) {
      if (!evaluate[s] && (arg < 0 || corr[s] > corr[arg])) arg = s;  // first on ties
    }
    if (arg < 0) break;  // every shift is already in a window
    for (int d = -w; d <= w; ++d) evaluate[((arg + d) % ns + ns) % ns] = true;
  }
  for (int s = 0; s < ns; ++s) {
    if (!evaluate[s]) continue;
    best = std::min(best, ShiftDistance(q_cols, q_mask, c_cols, c_mask2, s));
    ++shifts_evaluated_;
  }
  return best;
}

Status ScanContextTileSource::ComputeTile(std::size_t row_begin, std::size_t col_begin, std::size_t rows,
                                          std::size_t cols, AffinityTile* tile) {
  const std::size_t n = alpha_.count, m = beta_.count;
  if (rows == 0 || cols == 0 || row_begin > n || rows > n - row_begin || col_begin > m || cols > m - col_begin ||
      rows > max_tile_rows_ || cols > max_tile_cols_) {
    return InvalidArgument("Scan Context affinity: tile " + std::to_string(rows) + " x " + std::to_string(cols) +
                           " at (" + std::to_string(row_begin) + ", " + std::to_string(col_begin) +
                           ") is empty, outside the " + std::to_string(n) + " x " + std::to_string(m) +
                           " matrix or above the tile capacity " + std::to_string(max_tile_rows_) + " x " +
                           std::to_string(max_tile_cols_));
  }
  float tile_min = kFloatInf;
  for (std::size_t r = 0; r < rows; ++r) {
    float* out = tile_.data() + r * cols;
    for (std::size_t c = 0; c < cols; ++c) {
      out[c] = CellDistance(row_begin + r, col_begin + c);
      tile_min = std::min(tile_min, out[c]);
    }
  }
  cells_computed_ += static_cast<std::uint64_t>(rows) * static_cast<std::uint64_t>(cols);
  *tile = AffinityTile::Dense(row_begin, col_begin, rows, cols, tile_.data(), tile_min);
  return Status::Ok();
}

}  // namespace commerge
