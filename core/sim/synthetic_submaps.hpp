// SPDX-License-Identifier: BSD-3-Clause
// commerge: generated submaps with known ground truth for registration tests and benchmarks: several
// ray-cast scans (core/sim/synthetic_scan) of one scene merged in a submap frame and voxelised, as the server
// builds them from requested keyframe scans (paper "Submap-Based Map Merging"). Part of the simulator, not of
// core/registration, so that registration does not depend on core/sim.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <vector>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/sim/synthetic_scan.hpp"

namespace commerge {

/// Sensor pose of one generated scan in the scene's ground-truth frame gt: position [m] and heading [rad].
struct ScanPose {
  float x_m = 0.0f;
  float y_m = 0.0f;
  float z_m = 1.73f;
  float yaw_rad = 0.0f;
};

/// T_gt_sensor of a ScanPose.
Eigen::Isometry3d ScanPoseToIsometry(const ScanPose& pose);

struct SyntheticSubmap {
  std::vector<PointXYZI> points;                  ///< voxelised, in the submap frame
  std::vector<Eigen::Vector3d> sensor_origins_m;  ///< scan positions in the submap frame
};

/// Casts one scan per pose (seeds seed, seed + 1, ...), moves every point into the submap frame
/// (p_submap = T_gt_submap^-1 T_gt_sensor p_sensor) and voxelises the union at voxel_size_m.
/// Errors: voxel grid errors (e.g. voxel_size_m <= 0).
Status MakeSyntheticSubmap(const BoxScene& scene, const SpinningLidar& lidar, Span<const ScanPose> poses,
                           const Eigen::Isometry3d& T_gt_submap, double voxel_size_m, std::uint32_t seed,
                           SyntheticSubmap* out);

/// Two robots driving a straight street (MakeStreetScene, road along x): the target robot scans at
/// target_start_x_m, + scan_spacing_m, ... in lane target_lane_y_m, the source robot from source_start_x_m in
/// lane source_lane_y_m, heading +x or, when source_reversed, -x. Each submap frame is its middle scan's
/// pose; the source frame is additionally moved by T_anchor_offset (e.g. a yaw and a 20 m shift) so that the
/// unknown transform is large.
struct StreetPairSpec {
  std::uint32_t scene_seed = 1;
  float street_length_m = 300.0f;
  SpinningLidar lidar;
  int scans_per_submap = 5;
  float scan_spacing_m = 4.0f;
  float target_start_x_m = -10.0f;
  float source_start_x_m = 0.0f;
  float target_lane_y_m = -1.75f;
  float source_lane_y_m = 1.75f;
  bool source_reversed = false;
  Eigen::Isometry3d T_anchor_offset = Eigen::Isometry3d::Identity();
  double voxel_size_m = 1.0;
  std::uint32_t scan_seed = 100;
};

struct SyntheticSubmapPair {
  SyntheticSubmap source;
  SyntheticSubmap target;
  Eigen::Isometry3d T_target_source = Eigen::Isometry3d::Identity();  ///< ground truth
};

/// Builds the pair described by `spec` (the scene is generated from spec.scene_seed).
Status MakeStreetSubmapPair(const StreetPairSpec& spec, SyntheticSubmapPair* out);

/// Same pair construction on an already generated scene (scene_seed and street_length_m ignored).
Status MakeStreetSubmapPairInScene(const BoxScene& scene, const StreetPairSpec& spec, SyntheticSubmapPair* out);

}  // namespace commerge
