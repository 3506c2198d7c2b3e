// SPDX-License-Identifier: BSD-3-Clause
// commerge: the merged map, built one scan at a time. Each scan of a robot placed in the world frame (robot 0's
// map frame) goes in with T_world_map * T_map_sensor; a robot's points are voxel-downsampled in batches of at most
// batch_points, so the workspace stays bounded whatever the mission's length; the map holds at most max_points
// (its buffers never grow past them), so memory_bytes() stays within MergedMapParamsForBytes's figure; every
// point keeps its robot id. Both apps build merged_map.pcd / .ply with it (platform/io/merge_outputs.hpp) from the scans the
// process holds: in `commerge run` every robot's stored scans, in `commerge server` the scans the robots sent.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "core/cloud/point.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

struct MergedMapParams {
  double voxel_size_m = 1.0;             ///< of the map's voxels [m], >= 0.005
  std::size_t batch_points = 2000000;    ///< points placed before a batch is voxelised, >= 1
  /// Points the map may hold; scans beyond are left out and counted (scans_left_out()), >= 1.
  std::size_t max_points = 400000000;
};

Status ValidateMergedMapParams(const MergedMapParams& params);

/// The map within `bytes` (the merged_map budget module, --merged-map-mb): a quarter for the batch and its voxel
/// workspace (kBatchPointBytes a point), the rest for the map's points (kMapPointBytes). memory_bytes() never
/// exceeds `bytes` (at least one point of each).
MergedMapParams MergedMapParamsForBytes(std::int64_t bytes, double voxel_size_m = 1.0);

class MergedMapBuilder {
 public:
  /// Per point of the batch: the placed point, its voxel output and the voxel grid's two sort entries.
  static constexpr std::size_t kBatchPointBytes = 2 * sizeof(PointXYZI) + VoxelGrid::kWorkspaceBytesPerPoint;
  /// Per point of the map: the point and its robot id.
  static constexpr std::size_t kMapPointBytes = sizeof(PointXYZI) + sizeof(std::uint16_t);

  /// `params` must be valid (ValidateMergedMapParams).
  explicit MergedMapBuilder(const MergedMapParams& params);

  /// Starts robot `robot_id`'s part (the previous robot's batch is voxelised first).
  void BeginRobot(std::uint16_t robot_id, const Eigen::Isometry3d& T_world_map);
  /// One scan of the current robot: points in its sensor frame, T_map_sensor its keyframe pose.
  void AddScan(Span<const PointXYZI> points_sensor, const Eigen::Isometry3d& T_map_sensor);
  /// Voxelises what is left of the current robot's batch and frees the workspace (call before reading the map).
  void Finish();

  const std::vector<PointXYZI>& points() const noexcept { return points_; }
  const std::vector<std::uint16_t>& robot_ids() const noexcept { return robot_ids_; }
  std::size_t scans_added() const noexcept { return scans_added_; }
  std::size_t scans_left_out() const noexcept { return scans_left_out_; }
  /// Bytes held now: the map, the batch and the voxel grid's workspace (the merged_map budget module).
  std::size_t memory_bytes() const noexcept;

 private:
  void Flush();
  void Append(std::size_t n);

  MergedMapParams params_;
  VoxelGridParams voxel_params_;
  VoxelGrid grid_;
  std::uint16_t robot_id_ = 0;
  Eigen::Isometry3d T_world_map_ = Eigen::Isometry3d::Identity();
  std::vector<PointXYZI> points_, batch_, voxels_;
  std::vector<std::uint16_t> robot_ids_;
  std::size_t scans_added_ = 0, scans_left_out_ = 0;
};

}  // namespace commerge
