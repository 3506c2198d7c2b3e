// SPDX-License-Identifier: BSD-3-Clause
// commerge-ros1-bridge: a ROS 1 robot's odometry stack to `commerge robot --live`, and the server's results back
// to ROS for rviz (apps/README.md, "Live on a ROS robot").
//   ROS -> LCM (input_forwarder): --scan-topic (PointCloud2 / Livox CustomMsg) and --odom-topic (Odometry /
//     PoseStamped) become lidar_scan_t and odometry_t (T_odom_sensor = T_odom_body * T_body_sensor) on the
//     board-local LCM URL.
//   LCM -> ROS (results_publisher): merge_result_t from the team's bus becomes tf world -> robot_<r>/map on
//     /tf_static; with --server-out, the server's merged_map.pcd a latched PointCloud2 in the world frame.
// One thread: ROS callbacks and the LCM poll take turns. SIGINT / SIGTERM end it with the counters of every
// message it did not forward, by reason (also every --report-s on stderr).
#include <CLI/CLI.hpp>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <new>
#include <string>
#include <thread>

#include "apps/app_common.hpp"
#include "apps/ros1_bridge/bridge_options.hpp"
#include "apps/ros1_bridge/input_forwarder.hpp"
#include "apps/ros1_bridge/results_publisher.hpp"
#include "platform/ros/extrinsic.hpp"

namespace commerge::ros1_bridge {

namespace {

// Waits for the ROS master (roscore); false when a stop signal came first.
bool WaitForMaster(bool quiet) {
  bool said = false;
  while (app::StopSignalCount() == 0) {
    if (ros::master::check()) return true;
    if (!said && !quiet) {
      std::fprintf(stderr, "%s: waiting for the ROS master at %s\n", kTag, ros::master::getURI().c_str());
      said = true;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(500));
  }
  return false;
}

std::string CountersLine(const InputForwarder* input, const ResultsPublisher* results) {
  std::string line;
  if (input) line += InputCountersText(input->counters());
  if (results) line += (line.empty() ? "" : "; ") + ResultsCountersText(results->counters());
  return line;
}

void PrintBanner(const BridgeOptions& o) {
  if (o.quiet) return;
  if (o.input_on()) {
    std::fprintf(stderr, "%s: %s (%s) + %s -> lidar_scan_t %s + odometry_t %s on %s%s\n", kTag, o.scan_topic.c_str(),
                 ScanTypeName(o.scan_type), o.odom_topic.c_str(), o.scan_channel.c_str(), o.odometry_channel.c_str(),
                 o.lcm_url.c_str(), o.extrinsic.empty() ? "" : (", extrinsic " + o.extrinsic).c_str());
  }
  if (o.results_on()) {
    std::fprintf(stderr, "%s: merge_result_t on %s -> tf %s -> %s on /tf_static%s%s\n", kTag,
                 o.results_lcm_url.empty() ? "LCM_DEFAULT_URL" : o.results_lcm_url.c_str(), o.world_frame.c_str(),
                 o.robot_frame_format.c_str(), o.server_out.empty() ? "" : "; merged_map.pcd -> ",
                 o.server_out.empty() ? "" : o.map_topic.c_str());
  }
  std::fprintf(stderr, "%s: running as ROS node %s (Ctrl-C ends it)\n", kTag, ros::this_node::getName().c_str());
}

void PrintSummary(const InputForwarder* input, const ResultsPublisher* results) {
  std::printf("ros1-bridge: %s\n", CountersLine(input, results).c_str());
  if (input && !input->first_scan_error().empty()) {
    std::printf("ros1-bridge: first dropped scan: %s\n", input->first_scan_error().c_str());
  }
  if (input && !input->first_odometry_error().empty()) {
    std::printf("ros1-bridge: first dropped odometry: %s\n", input->first_odometry_error().c_str());
  }
  if (results && !results->first_error().empty()) {
    std::printf("ros1-bridge: first results error: %s\n", results->first_error().c_str());
  }
}

// ROS callbacks and the LCM poll by turns until a stop signal or ROS shuts down.
int Loop(const BridgeOptions& o, InputForwarder* input, ResultsPublisher* results) {
  ros::CallbackQueue* queue = ros::getGlobalCallbackQueue();
  std::int64_t next_report_us = platform::MonotonicUs() + static_cast<std::int64_t>(o.report_s * 1e6);
  while (app::StopSignalCount() == 0 && ros::ok()) {
    queue->callAvailable(ros::WallDuration(0.01));
    if (results) {
      if (Status st = results->Poll(10); !st.ok()) {
        std::fprintf(stderr, "%s: %s\n", kTag, st.message().c_str());
        return app::kExitFailure;
      }
    }
    if (o.report_s > 0.0 && !o.quiet && platform::MonotonicUs() >= next_report_us) {
      next_report_us += static_cast<std::int64_t>(o.report_s * 1e6);
      std::fprintf(stderr, "%s: %s\n", kTag, CountersLine(input, results).c_str());
    }
  }
  return app::kExitOk;
}

int Run(const BridgeOptions& o) {
  auto T_body_sensor = platform::ParseExtrinsic(o.extrinsic);
  if (!T_body_sensor.ok()) return app::kExitUsage;  // ValidateBridgeOptions said why
  std::unique_ptr<InputForwarder> input;
  std::unique_ptr<ResultsPublisher> results;
  if (o.input_on()) {
    auto created = InputForwarder::Create(o, *T_body_sensor);
    if (!created.ok()) {
      std::fprintf(stderr, "%s: --lcm-url: %s\n", kTag, created.status().message().c_str());
      return app::kExitFailure;
    }
    input = std::move(*created);
  }
  if (o.results_on()) {
    auto created = ResultsPublisher::Create(o);
    if (!created.ok()) {
      std::fprintf(stderr, "%s: %s\n", kTag, created.status().message().c_str());
      return app::kExitFailure;
    }
    results = std::move(*created);
  }
  app::InstallStopSignalHandlers();
  int rc = app::kExitOk;
  if (WaitForMaster(o.quiet)) {
    ros::NodeHandle nh;
    if (input) input->Subscribe(&nh);
    if (results) results->Advertise(&nh);
    PrintBanner(o);
    rc = Loop(o, input.get(), results.get());
  }
  PrintSummary(input.get(), results.get());
  ros::shutdown();
  return rc;
}

}  // namespace

}  // namespace commerge::ros1_bridge

int main(int argc, char** argv) {
  using namespace commerge;
  // ros::init first: it takes ROS's own arguments (remappings such as /points:=/ouster/points, __ns:=, __name:=)
  // out of argv, so CLI11 sees ours only. The stop signals are ours (summary at exit); anonymous node names let
  // one bridge per robot share a ROS graph.
  ros::init(argc, argv, "commerge_ros1_bridge", ros::init_options::NoSigintHandler | ros::init_options::AnonymousName);
  CLI::App cli{"commerge-ros1-bridge: a ROS 1 odometry stack (point clouds + odometry) to `commerge robot --live` "
               "over the board-local LCM URL, and the server's merge results back to ROS (tf, merged map) for rviz. "
               "ROS remapping arguments (from:=to, __ns:=...) are accepted too."};
  cli.set_version_flag("--version", "commerge-ros1-bridge " CM_VERSION);
  ros1_bridge::BridgeOptions o;
  ros1_bridge::AddBridgeOptions(&cli, &o);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? app::kExitOk : app::kExitUsage;
  }
  if (Status st = ros1_bridge::ValidateBridgeOptions(o); !st.ok()) {
    std::fprintf(stderr, "commerge-ros1-bridge: %s\n", st.message().c_str());
    return app::kExitUsage;
  }
  try {
    return ros1_bridge::Run(o);
  } catch (const std::bad_alloc&) {
    std::fprintf(stderr, "commerge-ros1-bridge: out of memory (std::bad_alloc)\n");
    return app::kExitOutOfMemory;
  }
}
