// SPDX-License-Identifier: BSD-3-Clause
// Decoders of the ROS messages commerge imports, from their ROS 1 serialization (bags) or ROS 2 CDR (MCAP,
// rosbag2): sensor_msgs/PointCloud2 of any field layout, livox_ros_driver/CustomMsg and livox_ros_driver2/CustomMsg,
// nav_msgs/Odometry and geometry_msgs/PoseStamped. Every length and offset is checked against the buffer before
// it is used; an error names the field and the byte offset in the message. Pure functions of their input.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/cloud/point.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge::platform {

/// ROS 1: little-endian, packed, header with seq; the message must end exactly at its last field. CDR: the 4-byte
/// encapsulation header (CDR_LE 00 01 or CDR_BE 00 00; any other, PL_CDR and XCDR2 included, is InvalidArgument),
/// every primitive aligned to its size from the end of that header, strings with their NUL, ROS 2 header without
/// seq; at most 3 bytes (padding) may follow the last field.
///
/// Every decoder: header.stamp = sec * 1e9 + nsec (nsec >= 1e9 is an error). Errors: DataLoss for a truncated or
/// corrupt message (the text names the message kind, the field and its byte offset from the start of the message,
/// CDR header included, e.g. "Odometry: truncated at byte 120 reading pose.pose.orientation.w (message has 118
/// bytes)"), InvalidArgument for a layout this code does not support or a scan above the limits. On error *out is
/// left unchanged.
enum class RosEncoding { kRos1, kCdr };

/// Which message a type name is: "sensor_msgs/PointCloud2" and "sensor_msgs/msg/PointCloud2" alike.
enum class RosMessageKind { kUnsupported, kPointCloud2, kLivoxCustom, kOdometry, kPoseStamped };
RosMessageKind RosMessageKindOf(const std::string& type);
/// "PointCloud2", "Livox CustomMsg", "Odometry", "PoseStamped", "unsupported".
const char* RosMessageKindName(RosMessageKind kind) noexcept;
/// True for the scan kinds (PointCloud2, Livox CustomMsg); false for the pose kinds.
bool IsScanKind(RosMessageKind kind) noexcept;

struct RosScanLimits {
  std::size_t max_points = 1u << 21;  ///< points of one scan (more is an error, not a truncation)
};

/// A decoded scan in the message's frame (frame_id).
struct RosScan {
  std::int64_t stamp_ns = 0;           ///< header.stamp
  std::string frame_id;
  std::vector<PointXYZI> points;       ///< finite points only, in message order
  /// Per-point time relative to stamp [s], one per kept point, when the message has one (see DecodePointCloud2
  /// and DecodeLivoxCustomMsg for where it comes from); else empty.
  std::vector<float> point_time_s;
  std::string point_time_field;        ///< the field it came from, or empty
  std::uint64_t non_finite_dropped = 0;  ///< points dropped for a NaN / inf coordinate
};

/// A decoded pose: T_parent_child (Odometry: header.frame_id <- child_frame_id; PoseStamped: header.frame_id <- the
/// pose's body, child_frame_id empty).
struct RosPose {
  std::int64_t stamp_ns = 0;
  std::string frame_id;
  std::string child_frame_id;
  Eigen::Isometry3d T_parent_child = Eigen::Isometry3d::Identity();
};

/// PointCloud2. Fields are looked up by name (the first of that name); each one used must have a datatype 1..8,
/// count >= 1 (only its first element is read) and offset + size * count <= point_step (else an error naming it).
///   * x, y, z: required, FLOAT32 or FLOAT64 (read as float; a point with a non-finite one is dropped and counted).
///   * intensity: the field "intensity", else "reflectivity" (any datatype, converted to float), else 0.
///   * point time: the first present of, in this order, "t" (ns relative to stamp: Ouster), "time" (s relative:
///     Velodyne), "timestamp" (absolute: Hesai, Robosense s; a value above 1e14 in magnitude is taken as ns, as
///     livox_ros_driver2 writes it; stamp subtracted), "offset_time" (ns relative); any datatype. Its name goes
///     to point_time_field.
/// The data is height rows of row_step bytes, each starting with width points of point_step bytes: errors when
/// width * point_step > row_step or the data's length != row_step * height (64-bit products). Also errors:
/// is_bigendian set, width * height > limits.max_points (before anything is allocated), a truncated message.
Status DecodePointCloud2(RosEncoding encoding, Span<const std::uint8_t> message, const RosScanLimits& limits,
                         RosScan* out);

/// livox_ros_driver/CustomMsg and livox_ros_driver2/CustomMsg (same layout): header, timebase (uint64 ns),
/// point_num, lidar_id, rsvd[3], points[] of {offset_time uint32 ns, x, y, z float32, reflectivity, tag, line
/// uint8}; intensity = reflectivity, point_time_s = (timebase + offset_time - header.stamp) in s (= offset_time
/// when the header is stamped with timebase), point_time_field "offset_time"; non-finite points dropped and
/// counted. Errors: point_num != the array's length, a truncated message, more points than limits.max_points.
Status DecodeLivoxCustomMsg(RosEncoding encoding, Span<const std::uint8_t> message, const RosScanLimits& limits,
                            RosScan* out);

/// nav_msgs/Odometry (pose.pose; the covariances and the twist are read past, not used, but must be present: a
/// message that ends inside them is truncated). Errors: a non-finite position or orientation value, a
/// quaternion whose norm is not within 1e-3 of 1 (it is normalised otherwise), a truncated message.
Status DecodeOdometry(RosEncoding encoding, Span<const std::uint8_t> message, RosPose* out);

/// geometry_msgs/PoseStamped; the same rules.
Status DecodePoseStamped(RosEncoding encoding, Span<const std::uint8_t> message, RosPose* out);

}  // namespace commerge::platform
