// SPDX-License-Identifier: BSD-3-Clause
// commerge: the ring-occupancy place descriptor (ours, not in the paper): which range rings hold structure at
// which heights above the local ground. For every point of a levelled cloud around the keyframe (z up along
// gravity, the sensor at the origin), its horizontal range picks a ring (num_rings over [0, max_range_m)), its
// height above the ground a band (band_edges_m; the top band is open), its azimuth a sector (num_sectors over
// 360 deg). The descriptor holds, per ring and band, the fraction of sectors with at least one point, L2-
// normalised: num_rings x num_bands values, ring-major ([ring][band]).
// Why: R-SOLiD counts points per beam elevation, so the same place looks different after a roll or pitch of
// a fraction of a degree, from a sensor of another density, or with a forward-looking non-repetitive sensor.
// Counting occupied cells instead of points makes the descriptor independent of density and beam layout;
// heights above the local ground make it independent of the sensor's mounting height and, once the cloud is
// levelled, of roll and pitch; like R-SOLiD it is invariant to yaw. The ground height is a low percentile of the
// points' z near the sensor. With the default 8 rings x 5 bands it has R-SOLiD's 40 values and travels in the
// same keyframe record (core/descriptor/descriptor_codec.hpp).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/place_descriptor.hpp"

namespace commerge {

/// Largest band count and ring x band product accepted.
constexpr int kRingOccupancyMaxBands = 8;
constexpr int kRingOccupancyMaxValues = 256;

struct RingOccupancyParams {
  int num_rings = 8;            ///< rings over [0, max_range_m), >= 1
  double max_range_m = 40.0;    ///< horizontal range of the outer ring's edge [m], > 0
  int num_sectors = 60;         ///< azimuth sectors over [0, 360) deg, in [4, 360]
  /// Lower edges of the height bands above the ground [m], ascending; points below the first are not counted
  /// (the ground itself); the last band is open above.
  std::array<double, kRingOccupancyMaxBands> band_edges_m = {0.3, 1.0, 2.0, 4.0, 8.0};
  int num_bands = 5;            ///< bands used (the first num_bands edges), in [1, kRingOccupancyMaxBands]
  /// The ground height is this percentile of the z of the points whose horizontal range lies in
  /// [ground_min_range_m, ground_max_range_m); with fewer than min_ground_points of them, of every point.
  double ground_percentile = 5.0;
  double ground_min_range_m = 2.0;
  double ground_max_range_m = 20.0;
  std::size_t min_ground_points = 30;
  /// A descriptor with fewer occupied cells than this is invalid (too little structure to compare).
  std::size_t min_occupied_cells = 4;
};

/// OK, or invalid argument naming the field: counts in range, num_rings x num_bands <= kRingOccupancyMaxValues,
/// lengths finite and > 0, band edges ascending and finite, percentile in [0, 100], ground ranges ordered.
Status ValidateRingOccupancyParams(const RingOccupancyParams& params);

/// Stable 32-bit id: FNV-1a over the kind byte (3 = ring occupancy), then every field in declaration order
/// (counts as little-endian int32, lengths as binary64 bit patterns, the used band edges only).
std::uint32_t RingOccupancyParameterId(const RingOccupancyParams& params) noexcept;

class RingOccupancyDescriptor final : public PlaceDescriptor {
 public:
  /// The default parameters.
  RingOccupancyDescriptor();
  static Result<RingOccupancyDescriptor> Create(const RingOccupancyParams& params);

  DescriptorKind kind() const noexcept override { return DescriptorKind::kRingOccupancy; }
  std::size_t dimension() const noexcept override {
    return static_cast<std::size_t>(params_.num_rings) * static_cast<std::size_t>(params_.num_bands);
  }
  std::uint32_t parameter_id() const noexcept override { return parameter_id_; }
  /// `scan`: the levelled cloud, sensor at the origin. Non-finite points are skipped and counted; points beyond
  /// max_range_m count as out of range; points below the first band as below min z (the ground). Invalid (out
  /// all zeros): fewer than min_occupied_cells occupied cells. Error only for a wrong out size or more than
  /// 2^32 - 1 points. The workspace grows to the largest cloud seen (the ground-height selection).
  Result<DescriptorInfo> Compute(Span<const PointXYZI> scan, Span<float> out) override;
  /// L2 distance of the two unit vectors, in [0, sqrt 2].
  double Distance(Span<const float> a, Span<const float> b) const override;

  const RingOccupancyParams& params() const noexcept { return params_; }
  /// Ground height [m] of the last Compute().
  double last_ground_z_m() const noexcept { return ground_z_m_; }
  std::size_t workspace_capacity_bytes() const noexcept;

 private:
  explicit RingOccupancyDescriptor(const RingOccupancyParams& params);

  RingOccupancyParams params_;
  std::uint32_t parameter_id_ = 0;
  std::vector<float> ground_z_;           ///< z of the ground candidates (selection workspace)
  std::vector<std::uint64_t> occupied_;   ///< one bit per (ring, band, sector)
  double ground_z_m_ = 0.0;
};

}  // namespace commerge
