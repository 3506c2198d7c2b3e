// SPDX-License-Identifier: BSD-3-Clause
// Shared by the registration tests (fast and heavy): cheap generated submap pairs, real clouds; the pose errors
// (RotationErrorDeg, TranslationErrorM) come from tests/support/pose_errors.hpp.
#pragma once

#include <Eigen/Geometry>

#include <cmath>
#include <cstdint>
#include <sstream>
#include <string>
#include <vector>

#include "core/cloud/voxel_grid.hpp"
#include "core/geometry/angles.hpp"
#include "core/geometry/se3.hpp"
#include "core/registration/submap_registration.hpp"
#include "core/sim/synthetic_submaps.hpp"
#include "platform/io/kitti_bin.hpp"
#include "tests/support/pose_errors.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::test {

inline Eigen::Isometry3d YawOffset(double yaw_deg, double x_m, double y_m, double z_m) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x_m, y_m, z_m);
  return T;
}

/// A light spinning LiDAR (32 x 512 rays, 80 m) so that a pair costs tens of milliseconds, also under qemu.
inline SpinningLidar LightLidar() {
  SpinningLidar lidar;
  lidar.beams = 32;
  lidar.azimuth_steps = 512;
  lidar.max_range_m = 80.0f;
  return lidar;
}

/// Two robots on street `scene_seed`: target scans from x = -8 m, source from x = -8 + shift_m in the other
/// lane (reversed when asked), 3 scans 5 m apart each; the source frame is moved by T_anchor_offset.
inline StreetPairSpec LightStreetSpec(std::uint32_t scene_seed, const Eigen::Isometry3d& T_anchor_offset,
                                      float shift_m = 3.0f, bool reversed = false) {
  StreetPairSpec spec;
  spec.scene_seed = scene_seed;
  spec.street_length_m = 260.0f;
  spec.lidar = LightLidar();
  spec.scans_per_submap = 3;
  spec.scan_spacing_m = 5.0f;
  spec.target_start_x_m = -8.0f;
  spec.source_reversed = reversed;
  spec.source_start_x_m = reversed ? -8.0f + 10.0f + shift_m : -8.0f + shift_m;
  spec.T_anchor_offset = T_anchor_offset;
  spec.scan_seed = 500u + scene_seed;
  return spec;
}

inline SubmapView View(const SyntheticSubmap& s) { return SubmapView{s.points, s.sensor_origins_m}; }

/// p' = T p for every point.
inline std::vector<PointXYZI> Transformed(const std::vector<PointXYZI>& in, const Eigen::Isometry3d& T) {
  std::vector<PointXYZI> out;
  out.reserve(in.size());
  for (const PointXYZI& p : in) {
    const Eigen::Vector3d q = T * Eigen::Vector3f(p.x, p.y, p.z).cast<double>();
    out.push_back({static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), p.intensity});
  }
  return out;
}

/// A 4 x 4 row-major transform from a text file (e.g. small_gicp_pair/T_target_source.txt).
inline Eigen::Isometry3d ReadTransform4x4(const std::string& path) {
  Eigen::Matrix4d m;
  std::istringstream is(ReadTextFile(path));
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) is >> m(r, c);
  return Eigen::Isometry3d(m);
}

/// A KITTI-layout cloud moved by T and voxelised; empty when the file cannot be read.
inline std::vector<PointXYZI> LoadVoxelised(const std::string& path, const Eigen::Isometry3d& T, double voxel_m) {
  auto scan = platform::ReadKittiBin(path);
  std::vector<PointXYZI> out;
  if (!scan.ok()) return out;
  const std::vector<PointXYZI> moved = Transformed(scan->points, T);
  if (!VoxelDownsample(moved, VoxelGridParams{voxel_m}, &out).ok()) out.clear();
  return out;
}

}  // namespace commerge::test
