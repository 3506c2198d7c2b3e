// SPDX-License-Identifier: BSD-3-Clause
// A rectangular block drive (MakeBlockLoopScene's road): the ground-truth pose at any arc length, and the LiDAR
// the drives scan with. Shared by the robot mapper and robot agent tests.
#pragma once

#include <Eigen/Geometry>

#include <cmath>

#include "core/geometry/angles.hpp"
#include "core/sim/synthetic_scan.hpp"

namespace commerge::test {

inline constexpr double kWidth = 40.0, kHeight = 30.0, kSensorZ = 1.73;

/// Ground-truth pose at arc length s along the rectangular road (counter-clockwise, heading along the road).
inline Eigen::Isometry3d PoseOnLoop(double s) {
  const double perimeter = 2.0 * (kWidth + kHeight);
  s = std::fmod(s, perimeter);
  double x, y, yaw;
  if (s < kWidth) {
    x = s, y = 0, yaw = 0;
  } else if (s < kWidth + kHeight) {
    x = kWidth, y = s - kWidth, yaw = kPi / 2;
  } else if (s < 2 * kWidth + kHeight) {
    x = kWidth - (s - kWidth - kHeight), y = kHeight, yaw = kPi;
  } else {
    x = 0, y = kHeight - (s - 2 * kWidth - kHeight), yaw = -kPi / 2;
  }
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(x, y, kSensorZ);
  return T;
}

/// VLP-16-like (16 beams, +-15 deg, 80 m) with a coarse azimuth (600 steps) to keep the drives fast under qemu.
inline SpinningLidar BlockLoopLidar() {
  SpinningLidar lidar;
  lidar.beams = 16;
  lidar.min_elevation_deg = -15.0f;
  lidar.max_elevation_deg = 15.0f;
  lidar.azimuth_steps = 600;
  lidar.max_range_m = 80.0f;
  return lidar;
}

}  // namespace commerge::test
