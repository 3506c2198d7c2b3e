// SPDX-License-Identifier: BSD-3-Clause
#include "apps/ros1_bridge/bridge_options.hpp"


#include "platform/ros/extrinsic.hpp"
#include "platform/lcm/input_codec.hpp"

namespace commerge::ros1_bridge {

namespace {

void AddInputOptions(CLI::App* app, BridgeOptions* o) {
  const char* group = "ROS -> LCM: the odometry stack's output to `commerge robot --live` (on this board)";
  app->add_option("--scan-topic", o->scan_topic,
                  "point clouds in the sensor (or body) frame: sensor_msgs/PointCloud2, livox_ros_driver/CustomMsg "
                  "or livox_ros_driver2/CustomMsg (FAST-LIO2 /cloud_registered_body, LIO-SAM "
                  "/lio_sam/deskew/cloud_deskewed, KISS-ICP /kiss/frame)")
      ->group(group);
  app->add_option("--odom-topic", o->odom_topic,
                  "odometry of the body: nav_msgs/Odometry or geometry_msgs/PoseStamped (FAST-LIO2 /Odometry, LIO-SAM "
                  "/lio_sam/mapping/odometry, KISS-ICP /kiss/odometry)")
      ->group(group);
  app->add_option_function<std::string>(
         "--scan-type",
         [o](const std::string& name) {
           o->scan_type = name == "livox" ? ScanType::kLivox
                          : name == "pointcloud2" ? ScanType::kPointCloud2
                                                  : ScanType::kAuto;
         },
         "how to decode --scan-topic: auto (from the publisher's datatype), pointcloud2 or livox (a CustomMsg "
         "of another package name with the same layout)")
      ->check(CLI::IsMember({"auto", "pointcloud2", "livox"}))
      ->default_str("auto")
      ->group(group);
  app->add_option("--extrinsic", o->extrinsic,
                  "T_body_sensor as \"x y z roll pitch yaw\" [m, deg], as `commerge import --extrinsic` (default "
                  "identity: the clouds are in the odometry's body frame)")
      ->group(group);
  app->add_option("--lcm-url", o->lcm_url,
                  "LCM URL of `commerge robot --input-lcm-url` (ttl=0: scans must never reach the radio)")
      ->capture_default_str()
      ->group(group);
  app->add_option("--scan-channel", o->scan_channel, "channel of the lidar_scan_t messages")
      ->capture_default_str()
      ->group(group);
  app->add_option("--odometry-channel", o->odometry_channel, "channel of the odometry_t messages")
      ->capture_default_str()
      ->group(group);
  app->add_option("--scan-queue", o->scan_queue,
                  "roscpp subscriber queue of --scan-topic; roscpp drops beyond it without telling [messages]")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str()
      ->group(group);
  app->add_option("--odom-queue", o->odom_queue, "roscpp subscriber queue of --odom-topic [messages]")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str()
      ->group(group);
}

void AddResultsOptions(CLI::App* app, BridgeOptions* o) {
  const char* group = "LCM -> ROS: the server's results for rviz";
  app->add_flag("--results", o->results,
                "publish tf world -> robot_<r>/map (latched, on /tf_static) for every robot each new merge_result_t "
                "places");
  app->get_option("--results")->group(group);
  app->add_option("--results-lcm-url", o->results_lcm_url,
                  "LCM URL of the team's bus, where the server publishes merge_result_t (default: LCM_DEFAULT_URL, "
                  "as `commerge robot --lcm-url`)")
      ->group(group);
  app->add_option("--auth-key", o->auth.key_file,
                  "team key file (from `commerge keygen`) when the team signs its messages: merge results are then "
                  "verified, and unsigned or forged ones dropped and counted")
      ->check(CLI::ExistingFile)
      ->group(group);
  app->add_option("--server-out", o->server_out,
                  "the server's --out directory on this host (implies --results): its merged_map.pcd, rewritten "
                  "after every round, is published latched as the map")
      ->group(group);
  app->add_option("--world-frame", o->world_frame, "tf parent frame and the map's frame_id (robot 0's map)")
      ->capture_default_str()
      ->group(group);
  app->add_option("--robot-frame-format", o->robot_frame_format,
                  "tf child frame of robot r's map (its first mapped scan); one %d")
      ->capture_default_str()
      ->group(group);
  app->add_option("--map-topic", o->map_topic, "latched sensor_msgs/PointCloud2 of the merged map")
      ->capture_default_str()
      ->group(group);
  app->add_option("--map-poll-s", o->map_poll_s,
                  "look at merged_map.pcd this often; a changed file is read once it stayed the same for one look [s]")
      ->check(CLI::Range(0.05, 3600.0))
      ->capture_default_str()
      ->group(group);
}

}  // namespace

void AddBridgeOptions(CLI::App* app, BridgeOptions* o) {
  o->lcm_url = platform::kDefaultInputLcmUrl;
  o->scan_channel = platform::kLidarScanChannel;
  o->odometry_channel = platform::kOdometryChannel;
  AddInputOptions(app, o);
  AddResultsOptions(app, o);
  app->add_option("--report-s", o->report_s,
                  "print the message counters (every drop by reason) on stderr this often; always at exit [s] (0 = "
                  "only at exit)")
      ->check(CLI::Range(0.0, 86400.0))
      ->capture_default_str();
  app->add_flag("--quiet", o->quiet, "no start-up and periodic lines on stderr (the exit summary stays)");
}

Status ValidateBridgeOptions(const BridgeOptions& o) {
  if (o.scan_topic.empty() != o.odom_topic.empty()) {
    return InvalidArgument("give both --scan-topic and --odom-topic (or neither, for the results alone)");
  }
  if (!o.input_on() && !o.results_on()) {
    return InvalidArgument("nothing to bridge: give --scan-topic and --odom-topic, and/or --results or --server-out");
  }
  if (auto frame = FormatRobotFrame(o.robot_frame_format, 0); !frame.ok()) return frame.status();
  if (o.world_frame.empty()) return InvalidArgument("--world-frame: empty");
  if (auto T = platform::ParseExtrinsic(o.extrinsic); !T.ok()) return T.status();
  return Status::Ok();
}

Result<std::string> FormatRobotFrame(const std::string& format, int robot_id) {
  std::string out;
  int conversions = 0;
  for (std::size_t i = 0; i < format.size(); ++i) {
    if (format[i] != '%') {
      out += format[i];
      continue;
    }
    const char next = i + 1 < format.size() ? format[i + 1] : '\0';
    if (next == '%') {
      out += '%';
    } else if (next == 'd') {
      out += std::to_string(robot_id);
      ++conversions;
    } else {
      return InvalidArgument("--robot-frame-format '" + format + "': only %d (the robot id) and %% are allowed");
    }
    ++i;
  }
  if (conversions != 1) {
    return InvalidArgument("--robot-frame-format '" + format + "': want exactly one %d (the robot id)");
  }
  return out;
}

const char* ScanTypeName(ScanType type) noexcept {
  switch (type) {
    case ScanType::kAuto: return "auto";
    case ScanType::kPointCloud2: return "pointcloud2";
    case ScanType::kLivox: return "livox";
  }
  return "?";
}

}  // namespace commerge::ros1_bridge
