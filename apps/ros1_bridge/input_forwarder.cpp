// SPDX-License-Identifier: BSD-3-Clause
#include "apps/ros1_bridge/input_forwarder.hpp"

#include <ros/serialization.h>

#include <cstdio>
#include <utility>

#include "platform/lcm/input_codec.hpp"

namespace commerge::ros1_bridge {

namespace {

using platform::RosMessageKind;

// The message's ROS 1 serialization, exactly as it travelled (ShapeShifter keeps the bytes).
void SerializedBytes(const topic_tools::ShapeShifter& msg, std::vector<std::uint8_t>* out) {
  out->resize(msg.size());
  ros::serialization::OStream stream(out->data(), static_cast<std::uint32_t>(out->size()));
  msg.write(stream);
}

std::string Count(std::uint64_t n, const char* what) {
  return n == 0 ? std::string() : ", " + std::to_string(n) + " " + what;
}

}  // namespace

std::string InputCountersText(const InputCounters& c) {
  std::string scan_drops = Count(c.scans_wrong_type, "not a scan type") + Count(c.scans_malformed, "malformed") +
                           Count(c.scans_unsupported, "unsupported layout") +
                           Count(c.scans_too_many_points, "too many points") +
                           Count(c.scans_not_encodable, "not encodable");
  std::string odometry_drops = Count(c.odometry_wrong_type, "not an odometry type") +
                               Count(c.odometry_malformed, "malformed") +
                               Count(c.odometry_not_encodable, "not encodable");
  auto dropped = [](const std::string& list) { return list.empty() ? std::string("none") : list.substr(2); };
  return "scans " + std::to_string(c.scans_received) + " received, " + std::to_string(c.scans_published) +
         " published (" + std::to_string(c.points_published) + " points; " + std::to_string(c.non_finite_points) +
         " non-finite points dropped); dropped scans: " + dropped(scan_drops) + "; odometry " +
         std::to_string(c.odometry_received) + " received, " + std::to_string(c.odometry_published) +
         " published; dropped odometry: " + dropped(odometry_drops) + "; LCM publish errors " +
         std::to_string(c.publish_errors) + ", " + std::to_string(c.bytes_published) + " bytes published";
}

Result<std::unique_ptr<InputForwarder>> InputForwarder::Create(const BridgeOptions& o,
                                                               const Eigen::Isometry3d& T_body_sensor) {
  platform::LcmBusParams params;
  params.url = o.lcm_url;
  auto bus = platform::OpenLcmBus(params, {});
  if (!bus.ok()) return bus.status();
  return std::unique_ptr<InputForwarder>(new InputForwarder(o, T_body_sensor, std::move(*bus)));
}

InputForwarder::InputForwarder(const BridgeOptions& o, const Eigen::Isometry3d& T_body_sensor,
                               std::unique_ptr<platform::LcmBus> bus)
    : o_(o), T_body_sensor_(T_body_sensor), bus_(std::move(bus)) {}

void InputForwarder::Subscribe(ros::NodeHandle* nh) {
  const ros::TransportHints hints = ros::TransportHints().tcpNoDelay();
  scan_sub_ = nh->subscribe<topic_tools::ShapeShifter>(o_.scan_topic, static_cast<std::uint32_t>(o_.scan_queue),
                                                       &InputForwarder::OnScan, this, hints);
  odom_sub_ = nh->subscribe<topic_tools::ShapeShifter>(o_.odom_topic, static_cast<std::uint32_t>(o_.odom_queue),
                                                       &InputForwarder::OnOdometry, this, hints);
}

void InputForwarder::NoteScanError(std::uint64_t* counter, const std::string& what) {
  ++*counter;
  if (first_scan_error_.empty()) first_scan_error_ = what;
}

void InputForwarder::NoteOdometryError(std::uint64_t* counter, const std::string& what) {
  ++*counter;
  if (first_odometry_error_.empty()) first_odometry_error_ = what;
}

// Decodes ros_bytes_ as the scan kind --scan-type names (auto: the publisher's datatype).
Status InputForwarder::DecodeScan(const std::string& datatype, platform::RosScan* out) {
  RosMessageKind kind = platform::RosMessageKindOf(datatype);
  if (o_.scan_type == ScanType::kPointCloud2) kind = RosMessageKind::kPointCloud2;
  if (o_.scan_type == ScanType::kLivox) kind = RosMessageKind::kLivoxCustom;
  const Span<const std::uint8_t> bytes(ros_bytes_.data(), ros_bytes_.size());
  const platform::RosScanLimits limits;  // 2 097 152 points: beyond lidar_scan_t's limit, counted below
  if (kind == RosMessageKind::kPointCloud2) {
    return platform::DecodePointCloud2(platform::RosEncoding::kRos1, bytes, limits, out);
  }
  if (kind == RosMessageKind::kLivoxCustom) {
    return platform::DecodeLivoxCustomMsg(platform::RosEncoding::kRos1, bytes, limits, out);
  }
  // Unimplemented marks the wrong datatype (the decoders return DataLoss and InvalidArgument only).
  return Unimplemented(datatype + " is not a scan type (sensor_msgs/PointCloud2, livox_ros_driver[2]/CustomMsg)");
}

void InputForwarder::OnScan(const topic_tools::ShapeShifter::ConstPtr& msg) {
  ++c_.scans_received;
  const std::string& datatype = msg->getDataType();
  SerializedBytes(*msg, &ros_bytes_);
  if (Status st = DecodeScan(datatype, &ros_scan_); !st.ok()) {
    std::uint64_t* counter = st.code() == StatusCode::kUnimplemented ? &c_.scans_wrong_type
                             : st.code() == StatusCode::kDataLoss    ? &c_.scans_malformed
                                                                     : &c_.scans_unsupported;
    NoteScanError(counter, o_.scan_topic + ": " + st.message());
    return;
  }
  if (ros_scan_.points.size() > kMaxLidarScanPoints) {
    NoteScanError(&c_.scans_too_many_points, o_.scan_topic + ": " + std::to_string(ros_scan_.points.size()) +
                                                 " points, more than lidar_scan_t's " +
                                                 std::to_string(kMaxLidarScanPoints));
    return;
  }
  scan_.utime_us = ros_scan_.stamp_ns / 1000;
  scan_.frame = ros_scan_.frame_id;
  std::swap(scan_.points, ros_scan_.points);  // both keep their capacity for the next message
  if (Status st = platform::EncodeLidarScan(scan_, &lcm_bytes_); !st.ok()) {
    NoteScanError(&c_.scans_not_encodable, o_.scan_topic + ": " + st.message());
    return;
  }
  if (!Publish(o_.scan_channel)) return;
  ++c_.scans_published;
  c_.points_published += scan_.points.size();
  c_.non_finite_points += ros_scan_.non_finite_dropped;
  sensor_frame_ = scan_.frame;
}

Status InputForwarder::DecodePose(const std::string& datatype, platform::RosPose* out) {
  const Span<const std::uint8_t> bytes(ros_bytes_.data(), ros_bytes_.size());
  switch (platform::RosMessageKindOf(datatype)) {
    case RosMessageKind::kOdometry: return platform::DecodeOdometry(platform::RosEncoding::kRos1, bytes, out);
    case RosMessageKind::kPoseStamped: return platform::DecodePoseStamped(platform::RosEncoding::kRos1, bytes, out);
    default: break;
  }
  return Unimplemented(datatype + " is not an odometry type (nav_msgs/Odometry, geometry_msgs/PoseStamped)");
}

void InputForwarder::OnOdometry(const topic_tools::ShapeShifter::ConstPtr& msg) {
  ++c_.odometry_received;
  SerializedBytes(*msg, &ros_bytes_);
  platform::RosPose pose;
  if (Status st = DecodePose(msg->getDataType(), &pose); !st.ok()) {
    NoteOdometryError(st.code() == StatusCode::kUnimplemented ? &c_.odometry_wrong_type : &c_.odometry_malformed,
                      o_.odom_topic + ": " + st.message());
    return;
  }
  OdometrySample sample;
  sample.utime_us = pose.stamp_ns / 1000;
  sample.odom_frame = pose.frame_id;
  sample.sensor_frame = !sensor_frame_.empty() ? sensor_frame_ : pose.child_frame_id;
  sample.T_odom_sensor = pose.T_parent_child * T_body_sensor_;  // T_odom_body * T_body_sensor
  if (Status st = platform::EncodeOdometry(sample, &lcm_bytes_); !st.ok()) {
    NoteOdometryError(&c_.odometry_not_encodable, o_.odom_topic + ": " + st.message());
    return;
  }
  if (Publish(o_.odometry_channel)) ++c_.odometry_published;
}

bool InputForwarder::Publish(const std::string& channel) {
  if (Status st = bus_->Publish(channel, lcm_bytes_); !st.ok()) {
    ++c_.publish_errors;
    if (c_.publish_errors == 1) std::fprintf(stderr, "%s: %s: %s\n", kTag, channel.c_str(), st.message().c_str());
    return false;
  }
  c_.bytes_published += lcm_bytes_.size();
  return true;
}

}  // namespace commerge::ros1_bridge
