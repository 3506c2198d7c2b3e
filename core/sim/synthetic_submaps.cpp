// SPDX-License-Identifier: BSD-3-Clause
#include "core/sim/synthetic_submaps.hpp"

#include <algorithm>
#include <cmath>

#include "core/geometry/angles.hpp"
#include "core/cloud/voxel_grid.hpp"

namespace commerge {

Eigen::Isometry3d ScanPoseToIsometry(const ScanPose& pose) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(static_cast<double>(pose.yaw_rad), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() =
      Eigen::Vector3d(static_cast<double>(pose.x_m), static_cast<double>(pose.y_m), static_cast<double>(pose.z_m));
  return T;
}

Status MakeSyntheticSubmap(const BoxScene& scene, const SpinningLidar& lidar, Span<const ScanPose> poses,
                           const Eigen::Isometry3d& T_gt_submap, double voxel_size_m, std::uint32_t seed,
                           SyntheticSubmap* out) {
  out->points.clear();
  out->sensor_origins_m.clear();
  const Eigen::Isometry3d T_submap_gt = T_gt_submap.inverse();
  std::vector<PointXYZI> merged, scan;
  BoxScene local;
  local.ground_z_m = scene.ground_z_m;
  for (std::size_t s = 0; s < poses.size(); ++s) {
    const ScanPose& pose = poses[s];
    // Only boxes that a ray can reach (horizontal distance to the box <= max range) are cast against: the same
    // hits, far less work on long scenes.
    local.boxes.clear();
    for (const Box& b : scene.boxes) {
      const float dx = std::max({b.min_x - pose.x_m, 0.0f, pose.x_m - b.max_x});
      const float dy = std::max({b.min_y - pose.y_m, 0.0f, pose.y_m - b.max_y});
      if (dx * dx + dy * dy <= lidar.max_range_m * lidar.max_range_m) local.boxes.push_back(b);
    }
    CastScan(local, lidar, pose.x_m, pose.y_m, pose.z_m, pose.yaw_rad, seed + static_cast<std::uint32_t>(s), &scan);
    const Eigen::Isometry3d T_submap_sensor = T_submap_gt * ScanPoseToIsometry(pose);
    out->sensor_origins_m.push_back(T_submap_sensor.translation());
    merged.reserve(merged.size() + scan.size());
    for (const PointXYZI& p : scan) {
      const Eigen::Vector3d q =
          T_submap_sensor * Eigen::Vector3d(static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z));
      merged.push_back(PointXYZI{static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()),
                                 p.intensity});
    }
  }
  auto stats = VoxelDownsample(merged, VoxelGridParams{voxel_size_m}, &out->points);
  return stats.ok() ? Status::Ok() : stats.status();
}

Status MakeStreetSubmapPairInScene(const BoxScene& scene, const StreetPairSpec& spec, SyntheticSubmapPair* out) {
  const int n = spec.scans_per_submap;
  if (n < 1) return InvalidArgument("street submap pair: scans_per_submap must be >= 1");
  std::vector<ScanPose> target_poses, source_poses;
  const float source_dir = spec.source_reversed ? -1.0f : 1.0f;
  const float source_yaw = spec.source_reversed ? kPiF : 0.0f;
  for (int i = 0; i < n; ++i) {
    const float step = static_cast<float>(i) * spec.scan_spacing_m;
    target_poses.push_back(ScanPose{spec.target_start_x_m + step, spec.target_lane_y_m, 1.73f, 0.0f});
    source_poses.push_back(ScanPose{spec.source_start_x_m + source_dir * step, spec.source_lane_y_m, 1.73f, source_yaw});
  }
  const Eigen::Isometry3d T_gt_target = ScanPoseToIsometry(target_poses[static_cast<std::size_t>(n / 2)]);
  const Eigen::Isometry3d T_gt_source =
      ScanPoseToIsometry(source_poses[static_cast<std::size_t>(n / 2)]) * spec.T_anchor_offset;
  Status s = MakeSyntheticSubmap(scene, spec.lidar, target_poses, T_gt_target, spec.voxel_size_m, spec.scan_seed,
                                 &out->target);
  if (!s.ok()) return s;
  s = MakeSyntheticSubmap(scene, spec.lidar, source_poses, T_gt_source, spec.voxel_size_m,
                          spec.scan_seed + 1000u, &out->source);
  if (!s.ok()) return s;
  out->T_target_source = T_gt_target.inverse() * T_gt_source;
  return Status::Ok();
}

Status MakeStreetSubmapPair(const StreetPairSpec& spec, SyntheticSubmapPair* out) {
  return MakeStreetSubmapPairInScene(MakeStreetScene(spec.scene_seed, spec.street_length_m), spec, out);
}

}  // namespace commerge
