// SPDX-License-Identifier: BSD-3-Clause
// commerge: per-submap preprocessing for coarse-to-fine registration (../shared/spec/REGISTRATION.md §1.2 "Pipeline",
// steps 2-7, and §2.1 "Preprocessing"): one bounded neighbour search per point, normals oriented towards the sensor
// origins, GICP covariances, keypoints and 33-D FPFH-style descriptors ("Faster-PFH": normals, covariances and
// descriptors all reuse the same neighbour lists).
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/cloud/kd_tree.hpp"
#include "core/cloud/point.hpp"
#include "core/cloud/radius_neighbors.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

/// Length of one descriptor: three 11-bin histograms [f1 | f2 | f3].
inline constexpr int kFpfhBins = 11;
inline constexpr int kFpfhDims = 3 * kFpfhBins;

struct SubmapFeatureParams {
  /// Normals use the neighbours closer than this [m] (spec: 3 x voxel size).
  double normal_radius_m = 3.0;
  /// Descriptor support and the single neighbour search radius [m] (spec: 5 x voxel size).
  double fpfh_radius_m = 5.0;
  /// Cap on the neighbour list of one point (the closest ones win). Bounds memory (points x cap x 8 bytes) and
  /// the largest single cost, the neighbour search
  /// (core/agent/decisions/016-registration-neighbour-and-keypoint-caps.md).
  int max_neighbors = 48;
  /// Fewer neighbours within normal_radius_m (the point included): no normal.
  int min_normal_neighbors = 3;
  /// A normal is rejected when (s1 - s2) / s1 > this (s: eigenvalues, s1 largest). 1.0 disables the filter.
  double linearity_threshold = 1.0;
  /// GICP covariance from the k nearest neighbours, the point included (spec: 10-20).
  int covariance_neighbors = 20;
  /// Fewer neighbours than this for the covariance: the point gets cov = I (no plane information).
  int min_covariance_neighbors = 5;
};

/// InvalidArgument naming the first bad field: radii must be finite, > 0 and normal <= fpfh radius; the
/// neighbour counts must be in range (max_neighbors 4..1024, covariance_neighbors 5..max_neighbors).
Status ValidateSubmapFeatureParams(const SubmapFeatureParams& params);

/// The three angles of a point pair feature (spec §1.2 step 5): f1 in [-pi, pi], f2 and f3 in [-1, 1].
struct PairFeature {
  float f1 = 0.0f;
  float f2 = 0.0f;
  float f3 = 0.0f;
};

/// Pair feature of (p1, n1) and (p2, n2) with unit normals. The point whose normal makes the smaller angle
/// with the connecting line is the source of the Darboux frame u = n_src, v = (d x u) / |d x u|, w = u x v;
/// f1 = atan2(w.n_other, u.n_other), f2 = v.n_other, f3 = n_src.d_hat (d pointing away from the source).
/// Returns false (feature undefined) when the points coincide or d is parallel to the source normal.
bool ComputePairFeature(const Eigen::Vector3f& p1, const Eigen::Vector3f& n1, const Eigen::Vector3f& p2,
                        const Eigen::Vector3f& n2, PairFeature* feature);

/// What the preprocessing found.
struct SubmapFeatureStats {
  std::size_t num_points = 0;
  std::size_t num_valid_normals = 0;
  std::size_t num_valid_covariances = 0;
  std::size_t num_keypoints = 0;           ///< points with a descriptor
  std::size_t mean_neighbors = 0;          ///< average neighbour list length (the point included)
  std::size_t num_capped_neighborhoods = 0;  ///< lists cut at max_neighbors before reaching fpfh_radius_m
};

/// Preprocessed submap: k-d tree, neighbour lists, normals, GICP covariances, keypoints and descriptors.
/// Non-owning: the points passed to ComputeGeometry must stay alive and unchanged while this object is used.
/// Reusable: buffers keep their capacity between calls. Not thread-safe.
class SubmapFeatures {
 public:
  /// Stage 1 (spec §1.2 steps 2-3, §2.1): the neighbours of every point (capped at
  /// max_neighbors, radius fpfh_radius_m; core/cloud/radius_neighbors), normals, covariances. Each normal is flipped to point towards the
  /// nearest of `sensor_origins_m` (same frame as the points; empty = the frame origin).
  /// Preconditions (the caller checks, see RegisterSubmaps): every point finite, params valid,
  /// points.size() < 2^32.
  void ComputeGeometry(Span<const PointXYZI> points, Span<const Eigen::Vector3d> sensor_origins_m,
                       const SubmapFeatureParams& params);

  /// Stage 2 (spec §1.2 steps 4-7): keypoints (valid normal and >= 3 valid-normal neighbours) and their
  /// descriptors. Call after ComputeGeometry with the same params.
  void ComputeDescriptors(const SubmapFeatureParams& params);

  Span<const PointXYZI> points() const noexcept { return points_; }
  /// k-d tree of points(), built on the first call after ComputeGeometry (GICP needs it for the target only,
  /// so the coarse stage does not pay for it). Not thread-safe, like the rest of the class.
  const KdTree3& tree() const;
  /// Unit normal per point; zero when invalid.
  const std::vector<Eigen::Vector3f>& normals() const noexcept { return normals_; }
  const std::vector<std::uint8_t>& normal_valid() const noexcept { return normal_valid_; }
  /// Regularised covariance per point (V diag(1e-3, 1, 1) V^T), identity when invalid.
  const std::vector<Eigen::Matrix3d>& covariances() const noexcept { return covariances_; }
  /// Point index of each keypoint, ascending.
  const std::vector<std::uint32_t>& keypoints() const noexcept { return keypoints_; }
  /// keypoints().size() x kFpfhDims descriptors, row-major (row k belongs to keypoints()[k]).
  const std::vector<float>& descriptors() const noexcept { return descriptors_; }
  const SubmapFeatureStats& stats() const noexcept { return stats_; }
  /// Bytes held: k-d tree, neighbour lists, normals, covariances, keypoints, SPFH and descriptors (capacities).
  std::size_t workspace_bytes() const;

  /// Neighbours of point i (itself included), closest first: indices and squared distances [m^2].
  Span<const std::uint32_t> neighbor_indices(std::size_t i) const noexcept { return neighbors_.indices(i); }
  Span<const float> neighbor_distances_sq(std::size_t i) const noexcept { return neighbors_.distances_sq(i); }

 private:
  Span<const PointXYZI> points_;
  mutable KdTree3 tree_;
  mutable bool tree_built_ = false;
  RadiusNeighbors neighbors_;
  std::vector<Eigen::Vector3f> normals_;
  std::vector<std::uint8_t> normal_valid_;
  std::vector<Eigen::Matrix3d> covariances_;
  std::vector<std::uint32_t> keypoints_;
  std::vector<std::int32_t> keypoint_of_point_;  // -1 when the point is not a keypoint
  std::vector<float> spfh_;
  std::vector<float> pair_soa_;  // one keypoint's valid-normal neighbours (x, y, z, nx, ny, nz rows)
  std::vector<float> descriptors_;
  SubmapFeatureStats stats_;
};

}  // namespace commerge
