// SPDX-License-Identifier: BSD-3-Clause
#include "core/descriptor/ring_occupancy.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "core/descriptor/sensor_presets.hpp"
#include "core/geometry/angles.hpp"

namespace commerge {

namespace {

bool FinitePositive(double v) { return std::isfinite(v) && v > 0.0; }

}  // namespace

Status ValidateRingOccupancyParams(const RingOccupancyParams& p) {
  if (p.num_rings < 1 || p.num_bands < 1 || p.num_bands > kRingOccupancyMaxBands ||
      p.num_rings * p.num_bands > kRingOccupancyMaxValues) {
    return InvalidArgument("ring occupancy: num_rings = " + std::to_string(p.num_rings) + " and num_bands = " +
                           std::to_string(p.num_bands) + " must be >= 1, num_bands <= " +
                           std::to_string(kRingOccupancyMaxBands) + ", their product <= " +
                           std::to_string(kRingOccupancyMaxValues));
  }
  if (p.num_sectors < 4 || p.num_sectors > 360) {
    return InvalidArgument("ring occupancy: num_sectors = " + std::to_string(p.num_sectors) + " is outside 4..360");
  }
  if (!FinitePositive(p.max_range_m)) return InvalidArgument("ring occupancy: max_range_m must be finite and > 0");
  for (int b = 0; b < p.num_bands; ++b) {
    const double e = p.band_edges_m[static_cast<std::size_t>(b)];
    if (!std::isfinite(e) || (b > 0 && !(e > p.band_edges_m[static_cast<std::size_t>(b - 1)]))) {
      return InvalidArgument("ring occupancy: band_edges_m must be finite and ascending (edge " + std::to_string(b) + ")");
    }
  }
  if (!(p.ground_percentile >= 0.0 && p.ground_percentile <= 100.0)) {
    return InvalidArgument("ring occupancy: ground_percentile must be in [0, 100]");
  }
  if (!(p.ground_min_range_m >= 0.0) || !(p.ground_max_range_m > p.ground_min_range_m) ||
      !std::isfinite(p.ground_max_range_m)) {
    return InvalidArgument("ring occupancy: need 0 <= ground_min_range_m < ground_max_range_m (finite)");
  }
  return Status::Ok();
}

std::uint32_t RingOccupancyParameterId(const RingOccupancyParams& p) noexcept {
  using namespace detail;
  std::uint32_t h = Fnv1aByte(kFnv1aOffset, static_cast<std::uint8_t>(DescriptorKind::kRingOccupancy));
  h = Fnv1aInt32(h, p.num_rings);
  h = Fnv1aDouble(h, p.max_range_m);
  h = Fnv1aInt32(h, p.num_sectors);
  h = Fnv1aInt32(h, p.num_bands);
  for (int b = 0; b < p.num_bands; ++b) h = Fnv1aDouble(h, p.band_edges_m[static_cast<std::size_t>(b)]);
  h = Fnv1aDouble(h, p.ground_percentile);
  h = Fnv1aDouble(h, p.ground_min_range_m);
  h = Fnv1aDouble(h, p.ground_max_range_m);
  h = Fnv1aInt32(h, static_cast<std::int32_t>(p.min_ground_points));
  h = Fnv1aInt32(h, static_cast<std::int32_t>(p.min_occupied_cells));
  return h;
}

Result<RingOccupancyDescriptor> RingOccupancyDescriptor::Create(const RingOccupancyParams& params) {
  if (Status st = ValidateRingOccupancyParams(params); !st.ok()) return st;
  return RingOccupancyDescriptor(params);
}

RingOccupancyDescriptor::RingOccupancyDescriptor() : RingOccupancyDescriptor(RingOccupancyParams{}) {}

RingOccupancyDescriptor::RingOccupancyDescriptor(const RingOccupancyParams& params)
    : params_(params), parameter_id_(RingOccupancyParameterId(params)) {
  const std::size_t bits = dimension() * static_cast<std::size_t>(params_.num_sectors);
  occupied_.assign((bits + 63) / 64, 0);
}

std::size_t RingOccupancyDescriptor::workspace_capacity_bytes() const noexcept {
  return ground_z_.capacity() * sizeof(float) + occupied_.capacity() * sizeof(std::uint64_t);
}

Result<DescriptorInfo> RingOccupancyDescriptor::Compute(Span<const PointXYZI> scan, Span<float> out) {
  if (out.size() != dimension()) {
    return InvalidArgument("ring occupancy: output holds " + std::to_string(out.size()) + " values, expected " +
                           std::to_string(dimension()));
  }
  if (scan.size() > std::numeric_limits<std::uint32_t>::max()) {
    return InvalidArgument("ring occupancy: more than 2^32 - 1 points");
  }
  DescriptorInfo info;
  info.num_points_in = static_cast<std::uint32_t>(scan.size());
  std::fill(out.begin(), out.end(), 0.0f);
  // 1. Ground height: a low percentile of z near the sensor (of every point when too few are near).
  const double gmin2 = params_.ground_min_range_m * params_.ground_min_range_m;
  const double gmax2 = params_.ground_max_range_m * params_.ground_max_range_m;
  ground_z_.clear();
  for (const PointXYZI& p : scan) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) continue;
    const double x = static_cast<double>(p.x), y = static_cast<double>(p.y);
    const double r2 = x * x + y * y;
    if (r2 >= gmin2 && r2 < gmax2) ground_z_.push_back(p.z);
  }
  if (ground_z_.size() < params_.min_ground_points) {
    ground_z_.clear();
    for (const PointXYZI& p : scan) {
      if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z)) ground_z_.push_back(p.z);
    }
  }
  if (ground_z_.empty()) {
    info.num_nonfinite = info.num_points_in;
    return info;
  }
  const std::size_t k = std::min(ground_z_.size() - 1, static_cast<std::size_t>(params_.ground_percentile / 100.0 *
                                                                              static_cast<double>(ground_z_.size())));
  std::nth_element(ground_z_.begin(), ground_z_.begin() + static_cast<std::ptrdiff_t>(k), ground_z_.end());
  ground_z_m_ = static_cast<double>(ground_z_[k]);

  // 2. Occupancy of (ring, band, sector).
  std::fill(occupied_.begin(), occupied_.end(), 0);
  const int rings = params_.num_rings, bands = params_.num_bands, sectors = params_.num_sectors;
  const double ring_width = params_.max_range_m / rings;
  const double max2 = params_.max_range_m * params_.max_range_m;
  const double sector_width = 2.0 * kPi / sectors;
  for (const PointXYZI& p : scan) {
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) {
      ++info.num_nonfinite;
      continue;
    }
    const double x = static_cast<double>(p.x), y = static_cast<double>(p.y);
    const double r2 = x * x + y * y;
    if (r2 >= max2) {
      ++info.num_out_of_range;
      continue;
    }
    const double h = static_cast<double>(p.z) - ground_z_m_;
    if (h < params_.band_edges_m[0]) {
      ++info.num_below_min_z;
      continue;
    }
    int band = bands - 1;
    while (band > 0 && h < params_.band_edges_m[static_cast<std::size_t>(band)]) --band;
    const int ring = std::min(rings - 1, static_cast<int>(std::sqrt(r2) / ring_width));
    double theta = std::atan2(y, x);
    if (theta < 0.0) theta += 2.0 * kPi;
    const int sector = std::min(sectors - 1, static_cast<int>(theta / sector_width));
    const std::size_t bit = (static_cast<std::size_t>(ring * bands + band)) * static_cast<std::size_t>(sectors) +
                            static_cast<std::size_t>(sector);
    occupied_[bit / 64] |= std::uint64_t{1} << (bit % 64);
    ++info.num_counted;
  }
  // 3. Fraction of occupied sectors per (ring, band), L2-normalised.
  std::size_t cells = 0;
  double norm2 = 0.0;
  for (std::size_t v = 0; v < dimension(); ++v) {
    std::size_t count = 0;
    for (int s = 0; s < sectors; ++s) {
      const std::size_t bit = v * static_cast<std::size_t>(sectors) + static_cast<std::size_t>(s);
      count += (occupied_[bit / 64] >> (bit % 64)) & 1u;
    }
    cells += count;
    const double f = static_cast<double>(count) / sectors;
    out[v] = static_cast<float>(f);
    norm2 += f * f;
  }
  if (cells < params_.min_occupied_cells || !(norm2 > 0.0)) {
    std::fill(out.begin(), out.end(), 0.0f);
    return info;
  }
  const double inv = 1.0 / std::sqrt(norm2);
  for (float& v : out) v = static_cast<float>(static_cast<double>(v) * inv);
  info.valid = true;
  return info;
}

double RingOccupancyDescriptor::Distance(Span<const float> a, Span<const float> b) const {
  double d2 = 0.0;
  for (std::size_t i = 0; i < a.size() && i < b.size(); ++i) {
    const double d = static_cast<double>(a[i]) - static_cast<double>(b[i]);
    d2 += d * d;
  }
  return std::sqrt(d2);
}

}  // namespace commerge
