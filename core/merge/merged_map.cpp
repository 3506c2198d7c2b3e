// SPDX-License-Identifier: BSD-3-Clause
#include "core/merge/merged_map.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace commerge {

Status ValidateMergedMapParams(const MergedMapParams& params) {
  if (!std::isfinite(params.voxel_size_m) || !(params.voxel_size_m >= 5e-3)) {
    return InvalidArgument("merged map voxel_size_m = " + std::to_string(params.voxel_size_m) +
                           " must be finite and >= 0.005");
  }
  if (params.batch_points < 1) return InvalidArgument("merged map batch_points must be >= 1");
  if (params.max_points < 1) return InvalidArgument("merged map max_points must be >= 1");
  return Status::Ok();
}

MergedMapParams MergedMapParamsForBytes(std::int64_t bytes, double voxel_size_m) {
  MergedMapParams p;
  p.voxel_size_m = voxel_size_m;
  const std::size_t total = bytes > 0 ? static_cast<std::size_t>(bytes) : 0;
  p.batch_points = std::max<std::size_t>(1, total / 4 / MergedMapBuilder::kBatchPointBytes);
  const std::size_t batch_bytes = p.batch_points * MergedMapBuilder::kBatchPointBytes;
  p.max_points = std::max<std::size_t>(
      1, total > batch_bytes ? (total - batch_bytes) / MergedMapBuilder::kMapPointBytes : 0);
  return p;
}

MergedMapBuilder::MergedMapBuilder(const MergedMapParams& params) : params_(params) {
  voxel_params_.voxel_size_m = params.voxel_size_m;
}

void MergedMapBuilder::BeginRobot(std::uint16_t robot_id, const Eigen::Isometry3d& T_world_map) {
  Flush();
  robot_id_ = robot_id;
  T_world_map_ = T_world_map;
}

void MergedMapBuilder::AddScan(Span<const PointXYZI> points_sensor, const Eigen::Isometry3d& T_map_sensor) {
  if (points_.size() >= params_.max_points) {
    ++scans_left_out_;
    return;
  }
  // The batch, its voxels and the grid's workspace are sized once for batch_points and never grow.
  if (batch_.capacity() < params_.batch_points) {
    batch_.reserve(params_.batch_points);
    voxels_.reserve(params_.batch_points);
    grid_ = VoxelGrid(params_.batch_points);
  }
  const Eigen::Isometry3f T_world_sensor = (T_world_map_ * T_map_sensor).cast<float>();
  for (const PointXYZI& p : points_sensor) {
    if (batch_.size() == params_.batch_points) Flush();
    const Eigen::Vector3f q = T_world_sensor * Eigen::Vector3f(p.x, p.y, p.z);
    batch_.push_back({q.x(), q.y(), q.z(), p.intensity});
  }
  ++scans_added_;
}

void MergedMapBuilder::Finish() {
  Flush();
  // The map is complete: give back the batch and the grid's workspace (both sized by the largest batch).
  batch_ = std::vector<PointXYZI>();
  voxels_ = std::vector<PointXYZI>();
  grid_ = VoxelGrid();
}

void MergedMapBuilder::Flush() {
  if (batch_.empty()) return;
  // A batch the grid cannot hold (extent beyond VoxelGrid::kMaxVoxelsPerAxis) is dropped whole.
  if (grid_.Downsample(Span<const PointXYZI>(batch_), voxel_params_, &voxels_).ok()) {
    const std::size_t room = params_.max_points > points_.size() ? params_.max_points - points_.size() : 0;
    Append(voxels_.size() < room ? voxels_.size() : room);
  }
  batch_.clear();
}

void MergedMapBuilder::Append(std::size_t n) {
  // Grown by doubling as a vector would, but never past max_points.
  if (points_.size() + n > points_.capacity()) {
    const std::size_t grown = std::max(2 * points_.capacity(), points_.size() + n);
    points_.reserve(std::min(grown, params_.max_points));
    robot_ids_.reserve(points_.capacity());
  }
  points_.insert(points_.end(), voxels_.begin(), voxels_.begin() + static_cast<std::ptrdiff_t>(n));
  robot_ids_.insert(robot_ids_.end(), n, robot_id_);
}

std::size_t MergedMapBuilder::memory_bytes() const noexcept {
  return (points_.capacity() + batch_.capacity() + voxels_.capacity()) * sizeof(PointXYZI) +
         robot_ids_.capacity() * sizeof(std::uint16_t) + grid_.workspace_capacity_bytes();
}

}  // namespace commerge
