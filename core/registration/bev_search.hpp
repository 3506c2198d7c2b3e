// SPDX-License-Identifier: BSD-3-Clause
// commerge: global yaw + translation search on bird's-eye-view structure grids, the fallback coarse stage of
// submap registration for ground robots (ours, not in ../shared/spec/REGISTRATION.md).
//
// Why: submaps that share a place but saw it from far apart give no true FPFH match, while their bird's-eye views
// still agree (core/agent/decisions/015-bev-search-peak-ratio.md).
//
// How: each submap becomes an n x n grid of cells (cell_size_m) marking "structure" (the points of the cell
// span more than min_vertical_extent_m in z). For every yaw step the rotated source grid is correlated with
// the target grid by FFT (two yaws packed in one complex transform); the correlation peak gives the cell shift.
// The best distinct (yaw, shift) peaks are returned, each with a z offset (median ground-height difference of
// the cells both submaps observe). The caller verifies each candidate with GICP and the usual gates.
//
// Assumption: both submap frames have z up (gravity-aligned odometry, as on our ground robots). Submaps
// turned about another axis are not found; disable the search for such data.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <complex>
#include <cstdint>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/geometry/angles.hpp"
#include "core/registration/fft2d.hpp"

namespace commerge {

struct BevSearchParams {
  /// Run the search when the feature-based coarse stage fails (SubmapRegistration).
  bool enabled = true;
  /// Grid cell edge [m] (1 x voxel size).
  double cell_size_m = 1.0;
  /// Grid edge in cells, a power of two in [16, 1024]; the grid covers grid_cells x cell_size_m around each
  /// submap's frame origin (points outside wrap around, which only adds noise to the correlation).
  int grid_cells = 256;
  /// Yaw hypotheses over 360 deg (even, in [8, 720]); 120 = 3 deg steps.
  int yaw_steps = 120;
  /// A cell is structure when its points span more than this in z [m] (0.5 x voxel size).
  double min_vertical_extent_m = 0.5;
  /// Cells with points but no structure (open ground) count -free_cell_weight, unobserved cells 0: a wall placed
  /// on the other submap's open road is penalised, so the dense surroundings of both frame origins do not win at
  /// small shifts (core/agent/decisions/015-bev-search-peak-ratio.md).
  double free_cell_weight = 0.5;
  /// Candidates returned, best correlation first (1..8).
  int max_candidates = 2;
  /// SubmapRegistration verifies only the best candidate, and only when its score is at least this times the
  /// best distinct runner-up's (or there is none): a repetitive street correlates almost equally at several
  /// shifts, which GICP and the overlap gates cannot always tell apart
  /// (core/agent/decisions/015-bev-search-peak-ratio.md).
  double min_peak_ratio = 2.0;
  /// Two peaks are distinct when their yaws differ by more than this [rad] or their shifts by more than
  /// min_separation_m [m].
  double min_separation_rad = 10.0 * kPi / 180.0;
  double min_separation_m = 4.0;
};

/// InvalidArgument naming the first field out of range.
Status ValidateBevSearchParams(const BevSearchParams& params);

struct BevCandidate {
  /// p_target = T_target_source p_source: Rz(yaw) and (x, y) from the peak, z from the ground heights.
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();
  double yaw_rad = 0.0;
  /// Structure cells that coincide at the peak.
  double score = 0.0;
};

/// Reusable search (keeps its grids between calls: 2 complex and 7 float grids, about 44 x grid_cells^2 bytes,
/// 2.9 MB at 256). Not thread-safe.
class BevSearch {
 public:
  /// Fills *candidates (best first, at most max_candidates, empty when either grid has no structure cell).
  /// Points must be finite. Errors: invalid params.
  Status Search(Span<const PointXYZI> source, Span<const PointXYZI> target, const BevSearchParams& params,
                std::vector<BevCandidate>* candidates);

  /// Correlation of the source grid turned by yaw_steps[k] with the target grid at every cell shift, for tests:
  /// *scores receives n x n values, (dy mod n) * n + (dx mod n), of the last Search's yaw step `step`.
  /// Only valid after Search with the same inputs.
  Status CorrelationForYawStep(Span<const PointXYZI> source, const BevSearchParams& params, int step,
                               std::vector<float>* scores);

  /// Bytes held: the FFT tables and the grids (capacities; kept between calls).
  std::size_t workspace_bytes() const noexcept;

 private:
  void Rasterise(Span<const PointXYZI> points, double yaw_rad, const BevSearchParams& params,
                 std::vector<float>* structure, std::vector<float>* zmin);
  double GroundOffset(Span<const PointXYZI> source, double yaw_rad, int dx, int dy, const BevSearchParams& params);

  Fft2d fft_;
  std::vector<std::complex<float>> target_spectrum_;
  std::vector<std::complex<float>> work_;
  std::vector<float> structure_a_, structure_b_, zmin_a_, zmin_b_, target_zmin_;
  std::vector<float> zmax_;
  std::vector<float> offsets_;
};

}  // namespace commerge
