// SPDX-License-Identifier: BSD-3-Clause
// ROS -> LCM: the robot's odometry stack (a PointCloud2 or Livox CustomMsg topic and an Odometry topic) to the
// live input of `commerge robot --live` (lidar_scan_t, odometry_t on the board-local LCM URL). Messages arrive
// as topic_tools::ShapeShifter, i.e. their ROS 1 serialization, and are converted by platform/ros/ros_messages
// (the decoders `commerge import` uses on bags: one conversion rule for both), then encoded by
// platform/lcm/input_codec. Every message that is not forwarded is counted by reason.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <ros/ros.h>
#include <topic_tools/shape_shifter.h>

#include "apps/ros1_bridge/bridge_options.hpp"
#include "core/agent/live_input.hpp"
#include "core/common/status.hpp"
#include "platform/lcm/lcm_bus.hpp"
#include "platform/ros/ros_messages.hpp"

namespace commerge::ros1_bridge {

struct InputCounters {
  std::uint64_t scans_received = 0, scans_published = 0;
  std::uint64_t scans_wrong_type = 0;        ///< the topic's datatype is no scan kind (--scan-type auto)
  std::uint64_t scans_malformed = 0;         ///< the decoder found the message corrupt or truncated
  std::uint64_t scans_unsupported = 0;       ///< a field layout the decoder does not read, or > 2 097 152 points
  std::uint64_t scans_too_many_points = 0;   ///< more finite points than lidar_scan_t's MAX_POINTS (262 144)
  std::uint64_t scans_not_encodable = 0;     ///< refused by the lidar_scan_t encoder (e.g. a frame name > 256 B)
  std::uint64_t non_finite_points = 0;       ///< points of forwarded scans dropped for a NaN / inf coordinate
  std::uint64_t points_published = 0;
  std::uint64_t odometry_received = 0, odometry_published = 0;
  std::uint64_t odometry_wrong_type = 0;     ///< neither nav_msgs/Odometry nor geometry_msgs/PoseStamped
  std::uint64_t odometry_malformed = 0;      ///< corrupt, non-finite, or a quaternion whose norm is off 1
  std::uint64_t odometry_not_encodable = 0;  ///< refused by the odometry_t encoder (not rigid, long frame name)
  std::uint64_t publish_errors = 0;          ///< LCM refused to send
  std::uint64_t bytes_published = 0;

  std::uint64_t dropped() const noexcept {
    return scans_wrong_type + scans_malformed + scans_unsupported + scans_too_many_points + scans_not_encodable +
           odometry_wrong_type + odometry_malformed + odometry_not_encodable + publish_errors;
  }
};

/// "scans 120 received, 118 published (3 481 920 points; dropped: 1 malformed, 1 too many points, ...)..."
std::string InputCountersText(const InputCounters& c);

class InputForwarder {
 public:
  /// Opens the board-local LCM bus (publish only).
  static Result<std::unique_ptr<InputForwarder>> Create(const BridgeOptions& o, const Eigen::Isometry3d& T_body_sensor);

  /// Subscribes both topics (callbacks run in ros::spinOnce of the caller's thread).
  void Subscribe(ros::NodeHandle* nh);

  const InputCounters& counters() const noexcept { return c_; }
  /// The first error of each kind seen, for the exit summary ("" when none).
  const std::string& first_scan_error() const noexcept { return first_scan_error_; }
  const std::string& first_odometry_error() const noexcept { return first_odometry_error_; }

 private:
  InputForwarder(const BridgeOptions& o, const Eigen::Isometry3d& T_body_sensor,
                 std::unique_ptr<platform::LcmBus> bus);
  void OnScan(const topic_tools::ShapeShifter::ConstPtr& msg);
  void OnOdometry(const topic_tools::ShapeShifter::ConstPtr& msg);
  Status DecodeScan(const std::string& datatype, platform::RosScan* out);
  Status DecodePose(const std::string& datatype, platform::RosPose* out);
  bool Publish(const std::string& channel);
  void NoteScanError(std::uint64_t* counter, const std::string& what);
  void NoteOdometryError(std::uint64_t* counter, const std::string& what);

  BridgeOptions o_;
  Eigen::Isometry3d T_body_sensor_;
  std::unique_ptr<platform::LcmBus> bus_;
  ros::Subscriber scan_sub_, odom_sub_;
  InputCounters c_;
  std::string first_scan_error_, first_odometry_error_;
  std::string sensor_frame_;  ///< the latest scan's frame_id (odometry_t's child frame)
  // Reused between messages: a scan's buffers keep their capacity.
  std::vector<std::uint8_t> ros_bytes_, lcm_bytes_;
  platform::RosScan ros_scan_;
  LidarScan scan_;
};

}  // namespace commerge::ros1_bridge
