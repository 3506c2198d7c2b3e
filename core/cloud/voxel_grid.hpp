// SPDX-License-Identifier: BSD-3-Clause
// commerge: voxel-grid downsampling (one centroid per occupied voxel).
//
// Voxel boundaries are absolute: the voxel of coordinate c is floor(c / voxel_size_m), computed in double,
// so two scans expressed in the same frame voxelise consistently. Each occupied voxel yields one point, the
// mean of x, y, z and intensity of the finite input points inside it (accumulated in double, in input order,
// then rounded to float). Only x, y, z are checked for finiteness: a NaN intensity makes its voxel's
// intensity NaN. Output order is ascending lexicographic (ix, iy, iz) of the voxel indices.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct VoxelGridParams {
  /// Edge length of the cubic voxels [m]; finite and > 0 (the paper's Delta-nu = 1.0 m).
  double voxel_size_m = 1.0;
};

struct VoxelGridStats {
  std::size_t num_input = 0;          ///< points passed in, finite or not
  std::size_t num_voxels = 0;         ///< occupied voxels = output points
  std::size_t dropped_nonfinite = 0;  ///< input points skipped because x, y or z was NaN or inf
};

/// Reusable voxel-grid downsampler. Keeps its sort workspace between calls: once the capacities fit the
/// largest cloud seen, Downsample() performs no allocation (given an `out` vector with enough capacity).
/// Not thread-safe; use one instance per thread.
class VoxelGrid {
 public:
  /// Largest voxel extent per axis, in voxels: the cloud's voxel indices must span at most this many
  /// distinct values per axis (21 bits each, packed into one 64-bit sort key).
  static constexpr std::int64_t kMaxVoxelsPerAxis = std::int64_t{1} << 21;

  /// Reserves the workspace for `expected_points` input points.
  explicit VoxelGrid(std::size_t expected_points = 0);
  /// Reserves the workspace for clouds of up to `points` input points (no allocation in Downsample up to them).
  void Reserve(std::size_t points);

  /// Clears `*out` and fills it with one centroid per occupied voxel, ordered by ascending (ix, iy, iz).
  /// Errors (invalid argument, `*out` cleared): `out` is null; voxel_size_m is not finite or <= 0; more
  /// than 2^32 - 1 input points; the finite points span more than kMaxVoxelsPerAxis voxels on an axis.
  /// Empty input (or only non-finite points) gives an empty output and OK.
  Result<VoxelGridStats> Downsample(Span<const PointXYZI> in, const VoxelGridParams& params,
                                    std::vector<PointXYZI>* out);

  /// Bytes currently reserved by the workspace (grows to fit the largest cloud, never shrinks).
  std::size_t workspace_capacity_bytes() const noexcept;
  /// Workspace per input point (two sort entries): a grid made for N points holds N times this.
  static constexpr std::size_t kWorkspaceBytesPerPoint = 32;

 private:
  struct Entry {
    std::uint64_t key;    // packed voxel index relative to the cloud's minimum voxel
    std::uint32_t index;  // position in the input
  };
  static_assert(2 * sizeof(Entry) == kWorkspaceBytesPerPoint, "kWorkspaceBytesPerPoint is the entries' size");
  static constexpr int kRadixBits = 8;
  static constexpr int kMaxRadixPasses = 8;  // 64-bit keys
  static constexpr std::size_t kRadixBuckets = std::size_t{1} << kRadixBits;

  std::vector<Entry> entries_;  // sort input and, after sorting, the result
  std::vector<Entry> scratch_;  // radix-sort ping-pong buffer
  std::array<std::array<std::uint32_t, kRadixBuckets>, kMaxRadixPasses> histograms_{};
};

/// Voxel size that follows the scene's scale (ours; the paper keeps one Delta nu = 1 m). A 1 m grid leaves a
/// spinning sensor's street scan a few thousand points but a corridor, a courtyard or a forward-looking sensor's
/// cone a few hundred, too few for FPFH and GICP. The sizes tried are voxel_size_m, voxel_size_m / sqrt(2),
/// voxel_size_m / 2, ... down to min_voxel_size_m (each step about doubles the points of a surface); the first
/// that keeps at least min_points is taken. A step is not taken when it would exceed max_points, or when it
/// gains less than 10 % points (the input is no denser than the coarser grid: finer only costs bytes).
/// min_points = 0 is the fixed grid.
struct AdaptiveVoxelParams {
  double voxel_size_m = 1.0;       ///< the coarsest size, tried first [m]
  double min_voxel_size_m = 0.25;  ///< the finest size tried [m], in (0, voxel_size_m]
  std::size_t min_points = 0;      ///< points wanted; 0: voxel_size_m only
  std::size_t max_points = static_cast<std::size_t>(-1);  ///< a finer size with more points is not taken
};

Status ValidateAdaptiveVoxelParams(const AdaptiveVoxelParams& params);

/// The k-th size of the ladder: voxel_size_m / sqrt(2)^k (k = 0 is voxel_size_m).
double AdaptiveVoxelStep(double voxel_size_m, int k) noexcept;

/// What DownsampleAdaptive chose.
struct AdaptiveVoxelStats {
  double voxel_size_m = 0.0;  ///< the size of the points returned
  int finer_steps = 0;        ///< ladder steps below voxel_size_m taken
  VoxelGridStats grid;        ///< of the returned grid
};

/// Downsamples `in` at the size chosen by AdaptiveVoxelParams into `*out`; `*scratch` holds the finer attempts
/// (its contents are unspecified afterwards). No allocation once both vectors and the grid's workspace fit.
/// Errors: invalid parameters, or those of VoxelGrid::Downsample.
Result<AdaptiveVoxelStats> DownsampleAdaptive(VoxelGrid* grid, Span<const PointXYZI> in,
                                              const AdaptiveVoxelParams& params, std::vector<PointXYZI>* out,
                                              std::vector<PointXYZI>* scratch);

/// One-shot VoxelGrid(in.size()).Downsample(in, params, out): allocates its workspace on every call.
Result<VoxelGridStats> VoxelDownsample(Span<const PointXYZI> in, const VoxelGridParams& params,
                                       std::vector<PointXYZI>* out);

}  // namespace commerge
