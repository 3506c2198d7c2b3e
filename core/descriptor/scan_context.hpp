// SPDX-License-Identifier: BSD-3-Clause
// commerge: Scan Context (Kim & Kim, IROS 2018), the alternative descriptor (shared/spec/SOLID.md §6).
//
// Grid of num_rings x num_sectors cells over the horizontal disc of radius max_range_m, stored row-major
// [ring][sector] (column c = sector c). Per point (double precision): x == 0 -> 0.001, y == 0 -> 0.001;
// rho = sqrt(x^2 + y^2), points with rho > max_range_m are skipped; theta = atan2(y, x) in [0, 360) deg;
// ring = clamp(ceil(rho / L * N_r), 1, N_r) - 1; sector = clamp(ceil(theta / 360 * N_s), 1, N_s) - 1;
// cell value = max over its points of z + lidar_height_m; empty cells = 0 (a cell whose points all have
// z < -lidar_height_m keeps its negative maximum).
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/place_descriptor.hpp"

namespace commerge {

/// Largest grid accepted (ring and sector counts).
constexpr int kScanContextMaxRings = 100;
constexpr int kScanContextMaxSectors = 360;

struct ScanContextParams {
  int num_rings = 20;             ///< N_r rings over [0, max_range_m] (4 m each by default)
  int num_sectors = 60;           ///< N_s sectors over [0, 360) deg (6 deg each); must divide 360
  double max_range_m = 80.0;      ///< horizontal range limit (inclusive) [m]
  double lidar_height_m = 2.0;    ///< added to z so heights are positive in the sensor frame [m]
};

/// OK, or invalid argument naming the field and value: counts in [1, kScanContextMax*], num_sectors divides
/// 360, max_range_m finite > 0, lidar_height_m finite.
Status ValidateScanContextParams(const ScanContextParams& params);

/// Stable 32-bit id: FNV-1a over the kind byte (2 = Scan Context), the counts as little-endian int32 and the
/// two lengths as little-endian binary64 bit patterns (-0.0 as +0.0), in declaration order.
std::uint32_t ScanContextParameterId(const ScanContextParams& params) noexcept;

/// Computes the Scan Context of one scan (sensor frame) into `out` (num_rings x num_sectors floats,
/// row-major [ring][sector]). No allocation. Fills `info` counters: non-finite points, rho > max_range_m
/// (num_out_of_range), counted points; valid == false (out all zeros) when no cell is non-zero.
/// Errors (invalid argument): invalid params, wrong `out` size, more than 2^32 - 1 points.
Result<DescriptorInfo> ComputeScanContext(Span<const PointXYZI> scan, const ScanContextParams& params,
                                          Span<float> out);

/// Ring key: the mean of each ring (row) over all sectors, yaw-invariant (num_rings values), for retrieval.
/// Error (invalid argument) on size mismatch.
Status ScanContextRingKey(Span<const float> sc, int num_rings, int num_sectors, Span<float> out);

/// Best column shift between a query and a candidate Scan Context.
struct ScanContextMatch {
  double distance = 1.0;  ///< min over shifts of d_s in [0, 2] (in [0, 1] for non-negative cells); 1 if no pair
  int shift = 0;          ///< s*: query column c is compared with candidate column (c + s*) mod N_s
  double yaw_rad = 0.0;   ///< s* x 360 / N_s deg wrapped to (-pi, pi]; T_candidate_query = R_z(+yaw)
  int num_columns = 0;    ///< |C| at s*: columns non-zero in both
};

/// Brute force over all N_s column shifts: d_s = 1 - (1/|C|) sum_{c in C} cos(col_c(query), col_{c+s}(cand)),
/// C = columns where both are non-zero, d_s = 1 when |C| = 0; returns the smallest d_s (first on ties).
/// Convention: a query yawed by +psi relative to the candidate (p_q = R_z(-psi) p_c) gives yaw_rad ~ +psi.
/// Sizes that do not match num_rings x num_sectors (or counts out of range) give the default (distance 1).
ScanContextMatch MatchScanContext(Span<const float> query, Span<const float> candidate, int num_rings,
                                  int num_sectors) noexcept;

/// Scan Context as a PlaceDescriptor (dimension num_rings x num_sectors = 1200 floats by default).
/// Distance() = MatchScanContext(a, b).distance; Match() also gives the shift and yaw.
class ScanContextDescriptor final : public PlaceDescriptor {
 public:
  ScanContextDescriptor();
  /// Validated construction (ValidateScanContextParams).
  static Result<ScanContextDescriptor> Create(const ScanContextParams& params);

  DescriptorKind kind() const noexcept override { return DescriptorKind::kScanContext; }
  std::size_t dimension() const noexcept override {
    return static_cast<std::size_t>(params_.num_rings) * static_cast<std::size_t>(params_.num_sectors);
  }
  std::uint32_t parameter_id() const noexcept override { return parameter_id_; }
  Result<DescriptorInfo> Compute(Span<const PointXYZI> scan, Span<float> out) override;
  double Distance(Span<const float> a, Span<const float> b) const override;
  /// Distance with the best shift and yaw (a = query, b = candidate).
  ScanContextMatch Match(Span<const float> query, Span<const float> candidate) const noexcept;

  const ScanContextParams& params() const noexcept { return params_; }

 private:
  explicit ScanContextDescriptor(const ScanContextParams& params);

  ScanContextParams params_;
  std::uint32_t parameter_id_ = 0;
};

}  // namespace commerge
