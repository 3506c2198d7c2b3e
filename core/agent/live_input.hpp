// SPDX-License-Identifier: BSD-3-Clause
// The live input of `commerge robot` as plain values: one LiDAR scan and one odometry sample from the robot's own
// odometry stack (lcmtypes/lidar_scan_t, odometry_t; platform/lcm/input_codec.hpp converts). The scan and the
// pose arrive on separate channels at different rates; core/agent/scan_odometry_sync.hpp pairs them.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/messages.hpp"
#include "core/cloud/point.hpp"

namespace commerge {

/// Points per scan on the wire (lidar_scan_t::MAX_POINTS): a 128-beam spinning LiDAR at 2048 columns per turn,
/// 128 x 2048 = 262144 points, the largest real sensor.
inline constexpr std::size_t kMaxLidarScanPoints = 262144;
/// Frame names (lidar_scan_t / odometry_t MAX_TEXT_BYTES), without the NUL.
inline constexpr std::size_t kMaxFrameNameBytes = kMaxStatusTextBytes;

struct LidarScan {
  std::int64_t utime_us = 0;       ///< the scan's time stamp [us since the Unix epoch]
  std::string frame;               ///< sensor frame name (at most kMaxFrameNameBytes)
  std::vector<PointXYZI> points;   ///< sensor frame [m]; at most kMaxLidarScanPoints
  /// Set by the decoder: points of the message with a non-finite x, y or z, dropped (not in `points`).
  std::size_t dropped_nonfinite = 0;
};

struct OdometrySample {
  std::int64_t utime_us = 0;       ///< the time the pose holds at [us since the Unix epoch]
  std::string odom_frame;          ///< the odometry stack's fixed frame (at most kMaxFrameNameBytes)
  std::string sensor_frame;        ///< the LiDAR sensor frame (at most kMaxFrameNameBytes)
  Eigen::Isometry3d T_odom_sensor = Eigen::Isometry3d::Identity();
  /// Row-major 6 x 6 over (x, y, z [m], rotation about x, y, z [rad]); all zeros = unknown.
  std::array<double, 36> covariance{};
};

}  // namespace commerge
