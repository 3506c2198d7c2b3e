// SPDX-License-Identifier: BSD-3-Clause
// Voxel-grid downsampling: integer voxel index per point, packed into one 64-bit key relative to the
// cloud's minimum voxel, LSD radix sort of (key, input index) pairs (stable, so each voxel's points keep
// input order), then one centroid per run of equal keys.
#include "core/cloud/voxel_grid.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <string>
#include <utility>

#include "core/common/number_text.hpp"

namespace commerge {
namespace {

constexpr char kAxisNames[3] = {'x', 'y', 'z'};
// Voxel indices beyond this magnitude cannot be converted to int64 safely.
constexpr double kMaxAbsVoxelIndex = 4611686018427387904.0;  // 2^62

int BitWidth(std::uint64_t value) {
  int bits = 0;
  for (; value != 0; value >>= 1) ++bits;
  return bits;
}

// floor(c / voxel_size_m) for a quotient known to lie in [-2^62, 2^62]: truncation, then one step down
// for negative non-integers. Exact: trunc of a double is representable, so the comparison is exact.
inline std::int64_t VoxelIndex(float c, double voxel_size_m) {
  const double t = static_cast<double>(c) / voxel_size_m;
  const auto i = static_cast<std::int64_t>(t);
  return i - static_cast<std::int64_t>(static_cast<double>(i) > t);
}

}  // namespace

VoxelGrid::VoxelGrid(std::size_t expected_points) { Reserve(expected_points); }

void VoxelGrid::Reserve(std::size_t points) {
  entries_.reserve(points);
  scratch_.reserve(points);
}

std::size_t VoxelGrid::workspace_capacity_bytes() const noexcept {
  return (entries_.capacity() + scratch_.capacity()) * sizeof(Entry);
}

Result<VoxelGridStats> VoxelGrid::Downsample(Span<const PointXYZI> in, const VoxelGridParams& params,
                                             std::vector<PointXYZI>* out) {
  if (out == nullptr) return InvalidArgument("voxel grid: the output vector is null");
  out->clear();
  const double voxel_size_m = params.voxel_size_m;
  if (!(std::isfinite(voxel_size_m) && voxel_size_m > 0.0)) {
    return InvalidArgument("voxel grid: voxel_size_m must be finite and > 0, got " + FormatNumber(voxel_size_m, 12));
  }
  if (in.size() > std::numeric_limits<std::uint32_t>::max()) {
    return InvalidArgument("voxel grid: " + std::to_string(in.size()) +
                           " input points, at most 4294967295 are supported per call");
  }

  VoxelGridStats stats;
  stats.num_input = in.size();

  // Bounding box of the finite points. floor(c / v) never decreases as c grows, so the extreme voxel
  // indices are those of the extreme coordinates.
  constexpr float kInf = std::numeric_limits<float>::infinity();
  float lo[3] = {kInf, kInf, kInf};
  float hi[3] = {-kInf, -kInf, -kInf};
  std::size_t num_finite = 0;
  for (const PointXYZI& p : in) {
    if (!IsFinite(p)) continue;
    ++num_finite;
    lo[0] = std::min(lo[0], p.x), hi[0] = std::max(hi[0], p.x);
    lo[1] = std::min(lo[1], p.y), hi[1] = std::max(hi[1], p.y);
    lo[2] = std::min(lo[2], p.z), hi[2] = std::max(hi[2], p.z);
  }
  stats.dropped_nonfinite = in.size() - num_finite;
  if (num_finite == 0) return stats;

  std::int64_t min_index[3];
  int bits[3];
  for (int a = 0; a < 3; ++a) {
    const double first = std::floor(static_cast<double>(lo[a]) / voxel_size_m);
    const double last = std::floor(static_cast<double>(hi[a]) / voxel_size_m);
    const double span = last - first + 1.0;  // inf or NaN when c / v overflowed
    if (!(span <= static_cast<double>(kMaxVoxelsPerAxis)) || !(std::fabs(first) <= kMaxAbsVoxelIndex) ||
        !(std::fabs(last) <= kMaxAbsVoxelIndex)) {
      return InvalidArgument(std::string("voxel grid: the cloud spans ") + FormatNumber(span, 12) + " voxels along " +
                             kAxisNames[a] + " (" + FormatNumber(static_cast<double>(lo[a]), 12) + " .. " +
                             FormatNumber(static_cast<double>(hi[a]), 12) + " m at voxel_size_m = " +
                             FormatNumber(voxel_size_m, 12) + "), more than the " + std::to_string(kMaxVoxelsPerAxis) +
                             " per axis that fit the sort key; use a larger voxel_size_m or crop the cloud");
    }
    min_index[a] = static_cast<std::int64_t>(first);
    bits[a] = BitWidth(static_cast<std::uint64_t>(static_cast<std::int64_t>(last) - min_index[a]));
  }
  // Key = (ix << (by + bz)) | (iy << bz) | iz, relative indices: ascending key = ascending (ix, iy, iz).
  const int shift_x = bits[1] + bits[2];
  const int shift_y = bits[2];
  const int key_bits = bits[0] + bits[1] + bits[2];

  entries_.resize(num_finite);
  scratch_.resize(num_finite);
  std::size_t k = 0;
  for (std::size_t i = 0; i < in.size(); ++i) {
    const PointXYZI& p = in[i];
    if (!IsFinite(p)) continue;
    const auto ix = static_cast<std::uint64_t>(VoxelIndex(p.x, voxel_size_m) - min_index[0]);
    const auto iy = static_cast<std::uint64_t>(VoxelIndex(p.y, voxel_size_m) - min_index[1]);
    const auto iz = static_cast<std::uint64_t>(VoxelIndex(p.z, voxel_size_m) - min_index[2]);
    entries_[k++] = Entry{(ix << shift_x) | (iy << shift_y) | iz, static_cast<std::uint32_t>(i)};
  }

  // LSD radix sort, kRadixBits per pass; a pass whose digit is the same for every key is skipped.
  const int num_passes = (key_bits + kRadixBits - 1) / kRadixBits;
  for (int d = 0; d < num_passes; ++d) histograms_[d].fill(0);
  for (const Entry& e : entries_) {
    for (int d = 0; d < num_passes; ++d) ++histograms_[d][(e.key >> (d * kRadixBits)) & (kRadixBuckets - 1)];
  }
  for (int d = 0; d < num_passes; ++d) {
    auto& counts = histograms_[d];
    if (std::find(counts.begin(), counts.end(), static_cast<std::uint32_t>(num_finite)) != counts.end()) continue;
    std::uint32_t offset = 0;
    for (std::uint32_t& c : counts) offset += std::exchange(c, offset);
    for (const Entry& e : entries_) scratch_[counts[(e.key >> (d * kRadixBits)) & (kRadixBuckets - 1)]++] = e;
    entries_.swap(scratch_);
  }

  // One centroid per run of equal keys.
  std::size_t num_voxels = 1;
  for (std::size_t i = 1; i < num_finite; ++i) num_voxels += entries_[i].key != entries_[i - 1].key;
  out->resize(num_voxels);
  std::size_t v = 0;
  for (std::size_t begin = 0; begin < num_finite;) {
    double sx = 0.0, sy = 0.0, sz = 0.0, si = 0.0;
    std::size_t end = begin;
    for (; end < num_finite && entries_[end].key == entries_[begin].key; ++end) {
      const PointXYZI& p = in[entries_[end].index];
      sx += static_cast<double>(p.x);
      sy += static_cast<double>(p.y);
      sz += static_cast<double>(p.z);
      si += static_cast<double>(p.intensity);
    }
    const auto n = static_cast<double>(end - begin);
    (*out)[v++] = PointXYZI{static_cast<float>(sx / n), static_cast<float>(sy / n), static_cast<float>(sz / n),
                            static_cast<float>(si / n)};
    begin = end;
  }
  stats.num_voxels = num_voxels;
  return stats;
}

Status ValidateAdaptiveVoxelParams(const AdaptiveVoxelParams& p) {
  if (!(std::isfinite(p.voxel_size_m) && p.voxel_size_m > 0.0)) {
    return InvalidArgument("adaptive voxel: voxel_size_m must be finite and > 0, got " + std::to_string(p.voxel_size_m));
  }
  if (!(std::isfinite(p.min_voxel_size_m) && p.min_voxel_size_m > 0.0 && p.min_voxel_size_m <= p.voxel_size_m)) {
    return InvalidArgument("adaptive voxel: min_voxel_size_m = " + std::to_string(p.min_voxel_size_m) +
                           " must be in (0, voxel_size_m = " + std::to_string(p.voxel_size_m) + "]");
  }
  return Status::Ok();
}

double AdaptiveVoxelStep(double voxel_size_m, int k) noexcept {
  return voxel_size_m * std::pow(0.5, 0.5 * static_cast<double>(k));
}

Result<AdaptiveVoxelStats> DownsampleAdaptive(VoxelGrid* grid, Span<const PointXYZI> in,
                                              const AdaptiveVoxelParams& params, std::vector<PointXYZI>* out,
                                              std::vector<PointXYZI>* scratch) {
  if (grid == nullptr || out == nullptr || scratch == nullptr) {
    return InvalidArgument("adaptive voxel: grid, out and scratch must not be null");
  }
  if (Status s = ValidateAdaptiveVoxelParams(params); !s.ok()) return s;
  AdaptiveVoxelStats stats;
  VoxelGridParams v;
  v.voxel_size_m = params.voxel_size_m;
  auto first = grid->Downsample(in, v, out);
  if (!first.ok()) return first.status();
  stats.voxel_size_m = v.voxel_size_m;
  stats.grid = *first;
  // Relative tolerance: the ladder's sizes are computed, min_voxel_size_m is often one of them.
  const double finest = params.min_voxel_size_m * (1.0 - 1e-9);
  for (int k = 1; out->size() < params.min_points; ++k) {
    v.voxel_size_m = AdaptiveVoxelStep(params.voxel_size_m, k);
    if (v.voxel_size_m < finest) break;
    auto finer = grid->Downsample(in, v, scratch);
    if (!finer.ok()) return finer.status();
    if (scratch->size() > params.max_points) break;
    if (10 * scratch->size() < 11 * out->size()) break;  // under 10 % more: the input is no denser
    std::swap(*out, *scratch);
    stats.voxel_size_m = v.voxel_size_m;
    stats.finer_steps = k;
    stats.grid = *finer;
  }
  return stats;
}

Result<VoxelGridStats> VoxelDownsample(Span<const PointXYZI> in, const VoxelGridParams& params,
                                       std::vector<PointXYZI>* out) {
  VoxelGrid grid(in.size());
  return grid.Downsample(in, params, out);
}

}  // namespace commerge
