// SPDX-License-Identifier: BSD-3-Clause
#include "apps/ros1_bridge/results_publisher.hpp"

#include <sensor_msgs/PointCloud2.h>
#include <sensor_msgs/PointField.h>
#include <tf2_msgs/TFMessage.h>

#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

#include "platform/io/pcd.hpp"
#include "platform/lcm/message_auth.hpp"
#include "platform/lcm/status_codec.hpp"

namespace commerge::ros1_bridge {

namespace {

ros::Time RosTimeOfUs(std::int64_t utime_us) {
  if (utime_us <= 0) return ros::Time::now();
  ros::Time t;
  t.fromNSec(static_cast<std::uint64_t>(utime_us) * 1000u);
  return t;
}

geometry_msgs::TransformStamped ToTransformMsg(const RobotTransform& r, const std::string& world_frame,
                                               const ros::Time& stamp) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = world_frame;
  t.child_frame_id = r.child_frame;
  const Eigen::Vector3d p = r.T_world_map.translation();
  const Eigen::Quaterniond q(r.T_world_map.rotation());
  t.transform.translation.x = p.x();
  t.transform.translation.y = p.y();
  t.transform.translation.z = p.z();
  t.transform.rotation.w = q.w();
  t.transform.rotation.x = q.x();
  t.transform.rotation.y = q.y();
  t.transform.rotation.z = q.z();
  return t;
}

sensor_msgs::PointField Field(const char* name, std::uint32_t offset, std::uint8_t datatype) {
  sensor_msgs::PointField f;
  f.name = name;
  f.offset = offset;
  f.datatype = datatype;
  f.count = 1;
  return f;
}

// x y z intensity (float32) and, when the file has it, robot (uint16: rviz colours by it as a channel).
void FillCloud(const platform::PointCloudFile& map, sensor_msgs::PointCloud2* out) {
  const bool with_robot = !map.robot_ids.empty();
  out->fields = {Field("x", 0, sensor_msgs::PointField::FLOAT32), Field("y", 4, sensor_msgs::PointField::FLOAT32),
                 Field("z", 8, sensor_msgs::PointField::FLOAT32),
                 Field("intensity", 12, sensor_msgs::PointField::FLOAT32)};
  if (with_robot) out->fields.push_back(Field("robot", 16, sensor_msgs::PointField::UINT16));
  out->point_step = with_robot ? 20 : 16;  // 18 bytes padded to a float's alignment
  out->height = 1;
  out->width = static_cast<std::uint32_t>(map.points.size());
  out->row_step = out->point_step * out->width;
  out->is_bigendian = false;
  out->is_dense = true;  // ReadPcd dropped the non-finite points
  out->data.assign(static_cast<std::size_t>(out->row_step), 0);
  std::uint8_t* dst = out->data.data();
  for (std::size_t i = 0; i < map.points.size(); ++i, dst += out->point_step) {
    const PointXYZI& p = map.points[i];
    const float xyzi[4] = {p.x, p.y, p.z, p.intensity};
    std::memcpy(dst, xyzi, sizeof(xyzi));
    if (with_robot) std::memcpy(dst + 16, &map.robot_ids[i], sizeof(std::uint16_t));
  }
}

}  // namespace

std::string ResultsCountersText(const ResultsCounters& c) {
  return "merge results " + std::to_string(c.results_received) + " received (" +
         std::to_string(c.results_malformed) + " malformed, " + std::to_string(c.auth_rejected) +
         " refused by authentication), " + std::to_string(c.tf_published) + " tf updates (" +
         std::to_string(c.robots_placed) + " robots placed); maps " + std::to_string(c.maps_published) +
         " published (" + std::to_string(c.map_points) + " points), " + std::to_string(c.map_read_errors) +
         " unreadable";
}

Result<std::vector<RobotTransform>> PlacedRobots(const MergeResultMessage& result, const std::string& frame_format) {
  std::vector<RobotTransform> placed;
  for (std::size_t i = 0; i < result.robot_ids.size(); ++i) {
    if (i >= result.in_world.size() || i >= result.T_world_map.size() || !result.in_world[i]) continue;
    auto frame = FormatRobotFrame(frame_format, result.robot_ids[i]);
    if (!frame.ok()) return frame.status();
    placed.push_back(RobotTransform{result.robot_ids[i], std::move(*frame), result.T_world_map[i]});
  }
  return placed;
}

Result<std::unique_ptr<ResultsPublisher>> ResultsPublisher::Create(const BridgeOptions& o) {
  platform::LcmBusParams params;
  params.url = o.results_lcm_url;
  // The bridge only listens on the team bus: it signs nothing, so any sender id does; the server's id with this
  // process's own session never matches a real server's messages as an echo.
  if (app::SetUpAuth(kTag, o.auth, platform::kAuthServerSender, platform::WallTimeUs(), platform::kAuthMaxRobots,
                     &params) != app::kExitOk) {
    return InvalidArgument("--auth-key " + o.auth.key_file + " is not usable (see above)");
  }
  auto bus = platform::OpenLcmBus(params, {platform::kMergeResultChannel});
  if (!bus.ok()) return bus.status();
  return std::unique_ptr<ResultsPublisher>(new ResultsPublisher(o, std::move(*bus)));
}

ResultsPublisher::ResultsPublisher(const BridgeOptions& o, std::unique_ptr<platform::LcmBus> bus)
    : o_(o), bus_(std::move(bus)) {}

void ResultsPublisher::Advertise(ros::NodeHandle* nh) {
  tf_pub_ = nh->advertise<tf2_msgs::TFMessage>("/tf_static", 4, /*latch=*/true);
  if (!o_.server_out.empty()) map_pub_ = nh->advertise<sensor_msgs::PointCloud2>(o_.map_topic, 1, /*latch=*/true);
}

void ResultsPublisher::NoteError(const std::string& what) {
  if (first_error_.empty()) first_error_ = what;
  if (!o_.quiet) std::fprintf(stderr, "%s: %s\n", kTag, what.c_str());
}

Status ResultsPublisher::Poll(int timeout_ms) {
  if (Status st = bus_->Poll(timeout_ms); !st.ok()) return st;
  platform::BusMessage message;
  while (bus_->Take(&message)) OnMergeResult(message);
  if (!o_.server_out.empty()) PollMap();
  return Status::Ok();
}

void ResultsPublisher::OnMergeResult(const platform::BusMessage& message) {
  ++c_.results_received;
  auto result = platform::DecodeMergeResult(Span<const std::uint8_t>(message.bytes.data(), message.bytes.size()));
  if (!result.ok()) {
    ++c_.results_malformed;
    NoteError("merge_result_t: " + result.status().message());
    return;
  }
  // The server re-sends a result every second while it waits for the robots: publish each round once.
  if (result->server_session == last_session_ && result->round == last_round_) return;
  auto placed = PlacedRobots(*result, o_.robot_frame_format);
  if (!placed.ok()) {
    NoteError(placed.status().message());
    return;
  }
  last_session_ = result->server_session;
  last_round_ = result->round;
  tf2_msgs::TFMessage tf;
  const ros::Time stamp = RosTimeOfUs(result->utime_us);
  for (const RobotTransform& r : *placed) tf.transforms.push_back(ToTransformMsg(r, o_.world_frame, stamp));
  tf_pub_.publish(tf);
  ++c_.tf_published;
  c_.robots_placed = placed->size();
  if (!o_.quiet) {
    std::fprintf(stderr, "%s: round %d of server session %lld: tf %s -> %zu robot map frame(s) on /tf_static\n", kTag,
                 result->round, static_cast<long long>(result->server_session), o_.world_frame.c_str(),
                 placed->size());
  }
}

// merged_map.pcd is rewritten in place (not renamed) after each round: a changed file is read only once it looked
// the same at two looks --map-poll-s apart, and a read that still fails (caught mid-rewrite) is retried when the
// file changes again.
void ResultsPublisher::PollMap() {
  const std::int64_t now_us = platform::MonotonicUs();
  if (now_us < next_map_look_us_) return;
  next_map_look_us_ = now_us + static_cast<std::int64_t>(o_.map_poll_s * 1e6);
  const std::string path = (std::filesystem::path(o_.server_out) / "merged_map.pcd").string();
  std::error_code ec;
  FileStamp stamp;
  const auto mtime = std::filesystem::last_write_time(path, ec);
  if (ec) return;  // not written yet
  stamp.size = std::filesystem::file_size(path, ec);
  if (ec) return;
  stamp.mtime_ns = std::chrono::duration_cast<std::chrono::nanoseconds>(mtime.time_since_epoch()).count();
  const bool settled = stamp == seen_;
  seen_ = stamp;
  if (!settled || stamp == handled_) return;
  handled_ = stamp;
  PublishMap(path);
}

void ResultsPublisher::PublishMap(const std::string& path) {
  auto map = platform::ReadPcd(path);
  if (!map.ok()) {
    ++c_.map_read_errors;
    NoteError(map.status().message());
    return;
  }
  sensor_msgs::PointCloud2 cloud;
  cloud.header.stamp = ros::Time::now();
  cloud.header.frame_id = o_.world_frame;
  FillCloud(*map, &cloud);
  map_pub_.publish(cloud);
  ++c_.maps_published;
  c_.map_points = map->points.size();
  if (!o_.quiet) {
    std::fprintf(stderr, "%s: %s: %zu points published on %s (latched, frame %s)\n", kTag, path.c_str(),
                 map->points.size(), o_.map_topic.c_str(), o_.world_frame.c_str());
  }
}

ResultsCounters ResultsPublisher::counters() const {
  ResultsCounters c = c_;
  c.auth_rejected = app::AuthRejected(*bus_);
  return c;
}

}  // namespace commerge::ros1_bridge
