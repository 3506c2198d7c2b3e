// SPDX-License-Identifier: BSD-3-Clause
// The flags of commerge-ros1-bridge and the small parsers behind them (the extrinsic, the robot frame format).
#pragma once

#include <CLI/CLI.hpp>

#include <string>

#include <Eigen/Geometry>

#include "apps/app_auth.hpp"
#include "core/common/status.hpp"

namespace commerge::ros1_bridge {

/// The prefix of every line on stderr.
inline constexpr const char* kTag = "commerge-ros1-bridge";

enum class ScanType { kAuto, kPointCloud2, kLivox };

struct BridgeOptions {
  // ROS -> LCM: the robot's odometry stack to `commerge robot --live`. Off when both topics are empty.
  std::string scan_topic;
  std::string odom_topic;
  ScanType scan_type = ScanType::kAuto;
  std::string extrinsic;  ///< "x y z roll pitch yaw" [m, deg]: T_body_sensor (as `commerge import --extrinsic`)
  std::string lcm_url;    ///< board-local input URL (default platform::kDefaultInputLcmUrl)
  std::string scan_channel;
  std::string odometry_channel;
  int scan_queue = 8;       ///< roscpp subscriber queue of the scan topic [messages]
  int odom_queue = 200;     ///< roscpp subscriber queue of the odometry topic [messages]

  // LCM -> ROS: the server's results. On with --results or --server-out.
  bool results = false;
  std::string results_lcm_url;  ///< "" = LCM_DEFAULT_URL (as `commerge robot --lcm-url`)
  app::AuthFlags auth;          ///< --auth-key of the team bus (verifies the server's merge results)
  std::string server_out;       ///< the server's --out directory: merged_map.pcd is published as the map
  std::string world_frame = "world";
  std::string robot_frame_format = "robot_%d/map";
  std::string map_topic = "/commerge/merged_map";
  double map_poll_s = 1.0;

  double report_s = 10.0;  ///< counters on stderr this often [s] (0 = only at exit)
  bool quiet = false;

  bool input_on() const { return !scan_topic.empty() || !odom_topic.empty(); }
  bool results_on() const { return results || !server_out.empty(); }
};

/// Adds every flag to `app` (the bridge's whole command line).
void AddBridgeOptions(CLI::App* app, BridgeOptions* o);
/// Checks what CLI11 cannot: both topics or neither, at least one direction, the frame format. The error names
/// the flag.
Status ValidateBridgeOptions(const BridgeOptions& o);

/// `format` with its one "%d" replaced by `robot_id` ("%%" is a literal '%'). Errors (InvalidArgument naming
/// --robot-frame-format): no "%d", more than one, or any other '%' conversion.
Result<std::string> FormatRobotFrame(const std::string& format, int robot_id);

const char* ScanTypeName(ScanType type) noexcept;

}  // namespace commerge::ros1_bridge
