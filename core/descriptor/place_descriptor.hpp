// SPDX-License-Identifier: BSD-3-Clause
// commerge: the interface every place descriptor implements (SOLiD, Scan Context), so the loop detector
// and the server cascade are descriptor-agnostic. A descriptor is a fixed number of floats per keyframe;
// its kind and parameter id say which descriptors are comparable (only those of one id). The id travels in
// every keyframe_batch_t, and the server compares only robots of one id.
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

enum class DescriptorKind : std::uint8_t { kSolid = 1, kScanContext = 2, kRingOccupancy = 3 };

/// Diagnostics of one descriptor computation.
struct DescriptorInfo {
  bool valid = false;                 ///< false: never sent, never compared (empty scan, flat histogram, ...)
  std::uint32_t num_points_in = 0;    ///< points passed in
  std::uint32_t num_counted = 0;      ///< points that entered the descriptor
  std::uint32_t num_nonfinite = 0;    ///< NaN/inf points skipped
  std::uint32_t num_out_of_range = 0; ///< outside [min_range, max_range]
  std::uint32_t num_below_fov = 0;    ///< below the vertical field of view (skipped)
  std::uint32_t num_above_fov = 0;    ///< above the vertical field of view (skipped)
  std::uint32_t num_below_min_z = 0;  ///< SOLiD with min_z_m set: in range but below min_z_m (skipped)
};

class PlaceDescriptor {
 public:
  virtual ~PlaceDescriptor() = default;

  virtual DescriptorKind kind() const noexcept = 0;
  /// Floats per descriptor (SOLiD: 40 unit-normalised R-SOLiD values; Scan Context: 20 x 60).
  virtual std::size_t dimension() const noexcept = 0;
  /// Identifies the parameters that make two descriptors comparable (a hash of them).
  virtual std::uint32_t parameter_id() const noexcept = 0;

  /// Computes the descriptor of one raw (not voxelised) scan in the sensor frame into `out`, which holds
  /// dimension() floats. Uses a workspace owned by the object: no allocation in steady state.
  /// Invalid descriptors are reported in the result (out is then all zeros), not as an error; errors are
  /// reserved for a wrong `out` size.
  virtual Result<DescriptorInfo> Compute(Span<const PointXYZI> scan, Span<float> out) = 0;

  /// Distance between two valid descriptors of this kind and parameter id (smaller = more alike; SOLiD:
  /// L2 of unit vectors in [0, sqrt 2]; Scan Context: best column-shift cosine distance in [0, 1]).
  virtual double Distance(Span<const float> a, Span<const float> b) const = 0;
};

}  // namespace commerge
