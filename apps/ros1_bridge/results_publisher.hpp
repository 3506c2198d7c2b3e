// SPDX-License-Identifier: BSD-3-Clause
// LCM -> ROS: the server's results for rviz. Each new merge_result_t (platform::kMergeResultChannel, on the team's
// bus) becomes one tf2_msgs/TFMessage on /tf_static (latched, every placed robot in it, so a late rviz gets them
// all): world -> robot_<r>/map = T_world_map. The server publishes no map over LCM (a merged map is megabytes;
// the radio carries descriptors and requested scans only); it rewrites merged_map.pcd in its --out directory after
// every round, and with --server-out this bridge publishes that file, when it changed, as a latched
// sensor_msgs/PointCloud2 in the world frame: exactly the server's map, no second map builder.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <ros/ros.h>

#include "apps/ros1_bridge/bridge_options.hpp"
#include "core/agent/messages.hpp"
#include "core/common/status.hpp"
#include "platform/lcm/lcm_bus.hpp"

namespace commerge::ros1_bridge {

struct ResultsCounters {
  std::uint64_t results_received = 0;   ///< merge_result_t messages (the server re-sends each while it lingers)
  std::uint64_t results_malformed = 0;  ///< refused by the decoder
  std::uint64_t tf_published = 0;       ///< TFMessages: one per new (server session, round)
  std::uint64_t robots_placed = 0;      ///< in the latest one
  std::uint64_t maps_published = 0;
  std::uint64_t map_points = 0;         ///< of the latest map
  std::uint64_t map_read_errors = 0;    ///< merged_map.pcd unreadable (e.g. read while the server rewrote it)
  std::uint64_t auth_rejected = 0;      ///< with --auth-key: unsigned, forged or replayed messages
};

/// "merge results 12 received (0 malformed, 0 refused by authentication), 3 tf updates (2 robots placed);
/// maps 3 published (123456 points), 0 unreadable"
std::string ResultsCountersText(const ResultsCounters& c);

/// The TFMessage contents for a result: for every robot in the world frame, world_frame -> robot frame.
struct RobotTransform {
  int robot_id = 0;
  std::string child_frame;
  Eigen::Isometry3d T_world_map = Eigen::Isometry3d::Identity();
};
Result<std::vector<RobotTransform>> PlacedRobots(const MergeResultMessage& result, const std::string& frame_format);

class ResultsPublisher {
 public:
  /// Opens the team bus (subscribed to merge results only; verifying them with --auth-key).
  static Result<std::unique_ptr<ResultsPublisher>> Create(const BridgeOptions& o);
  /// Advertises /tf_static and, with --server-out, the map topic (both latched).
  void Advertise(ros::NodeHandle* nh);
  /// Waits up to timeout_ms for merge results, publishes what is new, and looks at merged_map.pcd when due.
  Status Poll(int timeout_ms);
  ResultsCounters counters() const;
  const std::string& first_error() const noexcept { return first_error_; }

 private:
  struct FileStamp {
    std::int64_t mtime_ns = -1;
    std::uint64_t size = 0;
    bool operator==(const FileStamp& o) const { return mtime_ns == o.mtime_ns && size == o.size; }
  };
  explicit ResultsPublisher(const BridgeOptions& o, std::unique_ptr<platform::LcmBus> bus);
  void OnMergeResult(const platform::BusMessage& message);
  void PollMap();
  void PublishMap(const std::string& path);
  void NoteError(const std::string& what);

  BridgeOptions o_;
  std::unique_ptr<platform::LcmBus> bus_;
  ros::Publisher tf_pub_, map_pub_;
  ResultsCounters c_;
  std::string first_error_;
  std::int64_t last_session_ = -1;
  std::int32_t last_round_ = -1;
  std::int64_t next_map_look_us_ = 0;
  FileStamp seen_, handled_;  ///< merged_map.pcd at the previous look; the last one published or found unreadable
};

}  // namespace commerge::ros1_bridge
