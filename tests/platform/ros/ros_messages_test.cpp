// SPDX-License-Identifier: BSD-3-Clause
// ROS message decoders (platform/ros/ros_messages.hpp). Two independent references:
//   * bytes written by the official writers, generated once and embedded below: ROS 1 by genpy (Debian's
//     python3-genpy with sensor_msgs, nav_msgs, geometry_msgs; the Livox message through genpy.dynamic from its
//     .msg text), CDR_LE by Foxglove's @foxglove/rosmsg2-serialization MessageWriter (the ROS 2 Humble definitions
//     of @foxglove/rosmsg-msgs-common), CDR_BE by @foxglove/cdr's CdrWriter field by field;
//   * a small encoder written here from the wire rules (Wire), checked to reproduce those bytes exactly, which then
//     builds the layouts and the corrupt messages the references do not cover.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "platform/ros/ros_messages.hpp"

namespace commerge::platform {
// A named namespace: the test sources of an area are compiled in unity batches, where the anonymous namespaces of
// several files merge.
namespace ros_messages_test {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// Reference bytes.
//
// ROS 1 (genpy), made with /usr/bin/python3:
//   pc = sensor_msgs.msg.PointCloud2(); pc.header.seq = 7; pc.header.stamp = genpy.Time(1700000000, 123456789)
//   pc.header.frame_id = "os_sensor"; pc.height = 1; pc.width = 3
//   pc.fields = [PointField("x", 0, 7, 1), PointField("y", 4, 7, 1), PointField("z", 8, 7, 1),
//                PointField("intensity", 12, 7, 1), PointField("t", 16, 6, 1)]
//   pc.is_bigendian = False; pc.point_step = 20; pc.row_step = 60; pc.is_dense = False
//   pc.data = struct.pack("<ffffI", 1.5, -2.0, 0.25, 100.0, 0) + struct.pack("<ffffI", nan, 1.0, 2.0, 5.0, 50000)
//             + struct.pack("<ffffI", -3.0, 4.0, -5.5, 7.5, 99000000)
//   od = nav_msgs.msg.Odometry(); od.header.seq = 1; od.header.stamp = genpy.Time(1700000001, 500000000)
//   od.header.frame_id = "odom"; od.child_frame_id = "base_link"
//   od.pose.pose.position = (1.5, -2.25, 3.0); od.pose.pose.orientation = (0, 0, sin(15 deg), cos(15 deg))
//   od.pose.covariance = [0.01 * i for i in range(36)]; od.twist.twist.linear.x = 0.5
//   od.twist.twist.angular.z = 0.1; od.twist.covariance = [0.02 * i for i in range(36)]
//   ps = geometry_msgs.msg.PoseStamped(); ps.header.seq = 2; ps.header.stamp = genpy.Time(1700000002, 0)
//   ps.header.frame_id = "map"; ps.pose.position = (-10.0, 20.5, 0.125); ps.pose.orientation = (.5, .5, .5, .5)
//   lv = livox_ros_driver/CustomMsg (genpy.dynamic.generate_dynamic from the .msg text): header.seq = 3,
//   stamp = genpy.Time(1700000003, 250000000), frame_id = "livox_frame", timebase = 1700000003250000000,
//   point_num = 2, lidar_id = 1, rsvd = [0, 0, 0], points = [
//     CustomPoint(offset_time=0, x=1.0, y=2.0, z=3.0, reflectivity=10, tag=0x10, line=0),
//     CustomPoint(offset_time=100000, x=-1.0, y=-2.0, z=-3.5, reflectivity=200, tag=0, line=3)]
//   each: buf = io.BytesIO(); msg.serialize(buf); buf.getvalue()
// CDR (node, Foxglove): the same messages without seq (the data bytes of the cloud identical), except
// PoseStamped CDR_LE, stamped sec = -5, nanosec = 999999999; MessageWriter(defs).writeMessage(msg) for CDR_LE;
// new CdrWriter({kind: EncapsulationKind.CDR_BE}) with int32/uint32/string/float64/uint8/sequenceLength/
// uint8Array calls in field order for CDR_BE.
constexpr std::uint8_t kRos1Cloud[] = {  // 189 bytes
  0x07, 0x00, 0x00, 0x00, 0x00, 0xf1, 0x53, 0x65, 0x15, 0xcd, 0x5b, 0x07, 0x09, 0x00, 0x00, 0x00,
  0x6f, 0x73, 0x5f, 0x73, 0x65, 0x6e, 0x73, 0x6f, 0x72, 0x01, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00,
  0x00, 0x05, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x78, 0x00, 0x00, 0x00, 0x00, 0x07, 0x01,
  0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x79, 0x04, 0x00, 0x00, 0x00, 0x07, 0x01, 0x00, 0x00,
  0x00, 0x01, 0x00, 0x00, 0x00, 0x7a, 0x08, 0x00, 0x00, 0x00, 0x07, 0x01, 0x00, 0x00, 0x00, 0x09,
  0x00, 0x00, 0x00, 0x69, 0x6e, 0x74, 0x65, 0x6e, 0x73, 0x69, 0x74, 0x79, 0x0c, 0x00, 0x00, 0x00,
  0x07, 0x01, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x74, 0x10, 0x00, 0x00, 0x00, 0x06, 0x01,
  0x00, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00, 0x00, 0x3c, 0x00, 0x00, 0x00, 0x3c, 0x00, 0x00, 0x00,
  0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00, 0x00, 0xc0, 0x00, 0x00, 0x80, 0x3e, 0x00, 0x00, 0xc8, 0x42,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x7f, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x40,
  0x00, 0x00, 0xa0, 0x40, 0x50, 0xc3, 0x00, 0x00, 0x00, 0x00, 0x40, 0xc0, 0x00, 0x00, 0x80, 0x40,
  0x00, 0x00, 0xb0, 0xc0, 0x00, 0x00, 0xf0, 0x40, 0xc0, 0x9e, 0xe6, 0x05, 0x00,
};
constexpr std::uint8_t kRos1Odometry[] = {  // 713 bytes
  0x01, 0x00, 0x00, 0x00, 0x01, 0xf1, 0x53, 0x65, 0x00, 0x65, 0xcd, 0x1d, 0x04, 0x00, 0x00, 0x00,
  0x6f, 0x64, 0x6f, 0x6d, 0x09, 0x00, 0x00, 0x00, 0x62, 0x61, 0x73, 0x65, 0x5f, 0x6c, 0x69, 0x6e,
  0x6b, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xf8, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02,
  0xc0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x90, 0x06, 0x93, 0xc1, 0x7d, 0x90, 0xd0,
  0x3f, 0x15, 0xbf, 0x48, 0x47, 0xdd, 0xe8, 0xee, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0x84, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0x94,
  0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0x9e, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xa4,
  0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xa9, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xae,
  0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xb1, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xb4,
  0x3f, 0x0a, 0xd7, 0xa3, 0x70, 0x3d, 0x0a, 0xb7, 0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xb9,
  0x3f, 0x29, 0x5c, 0x8f, 0xc2, 0xf5, 0x28, 0xbc, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xbe,
  0x3f, 0xa4, 0x70, 0x3d, 0x0a, 0xd7, 0xa3, 0xc0, 0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xc1,
  0x3f, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0xc3, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xc4,
  0x3f, 0xc3, 0xf5, 0x28, 0x5c, 0x8f, 0xc2, 0xc5, 0x3f, 0x0a, 0xd7, 0xa3, 0x70, 0x3d, 0x0a, 0xc7,
  0x3f, 0x52, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xc8, 0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xc9,
  0x3f, 0xe1, 0x7a, 0x14, 0xae, 0x47, 0xe1, 0xca, 0x3f, 0x29, 0x5c, 0x8f, 0xc2, 0xf5, 0x28, 0xcc,
  0x3f, 0x71, 0x3d, 0x0a, 0xd7, 0xa3, 0x70, 0xcd, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xce,
  0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xd0, 0x3f, 0xa4, 0x70, 0x3d, 0x0a, 0xd7, 0xa3, 0xd0,
  0x3f, 0x48, 0xe1, 0x7a, 0x14, 0xae, 0x47, 0xd1, 0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xd1,
  0x3f, 0x8f, 0xc2, 0xf5, 0x28, 0x5c, 0x8f, 0xd2, 0x3f, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0xd3,
  0x3f, 0xd7, 0xa3, 0x70, 0x3d, 0x0a, 0xd7, 0xd3, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xd4,
  0x3f, 0x1f, 0x85, 0xeb, 0x51, 0xb8, 0x1e, 0xd5, 0x3f, 0xc3, 0xf5, 0x28, 0x5c, 0x8f, 0xc2, 0xd5,
  0x3f, 0x67, 0x66, 0x66, 0x66, 0x66, 0x66, 0xd6, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0,
  0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xb9, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0x94, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xa4,
  0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xae, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xb4,
  0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xb9, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xbe,
  0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xc1, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xc4,
  0x3f, 0x0a, 0xd7, 0xa3, 0x70, 0x3d, 0x0a, 0xc7, 0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xc9,
  0x3f, 0x29, 0x5c, 0x8f, 0xc2, 0xf5, 0x28, 0xcc, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xce,
  0x3f, 0xa4, 0x70, 0x3d, 0x0a, 0xd7, 0xa3, 0xd0, 0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xd1,
  0x3f, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0xd3, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xd4,
  0x3f, 0xc3, 0xf5, 0x28, 0x5c, 0x8f, 0xc2, 0xd5, 0x3f, 0x0a, 0xd7, 0xa3, 0x70, 0x3d, 0x0a, 0xd7,
  0x3f, 0x52, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xd8, 0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xd9,
  0x3f, 0xe1, 0x7a, 0x14, 0xae, 0x47, 0xe1, 0xda, 0x3f, 0x29, 0x5c, 0x8f, 0xc2, 0xf5, 0x28, 0xdc,
  0x3f, 0x71, 0x3d, 0x0a, 0xd7, 0xa3, 0x70, 0xdd, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xde,
  0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0xa4, 0x70, 0x3d, 0x0a, 0xd7, 0xa3, 0xe0,
  0x3f, 0x48, 0xe1, 0x7a, 0x14, 0xae, 0x47, 0xe1, 0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xe1,
  0x3f, 0x8f, 0xc2, 0xf5, 0x28, 0x5c, 0x8f, 0xe2, 0x3f, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0xe3,
  0x3f, 0xd7, 0xa3, 0x70, 0x3d, 0x0a, 0xd7, 0xe3, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xe4,
  0x3f, 0x1f, 0x85, 0xeb, 0x51, 0xb8, 0x1e, 0xe5, 0x3f, 0xc3, 0xf5, 0x28, 0x5c, 0x8f, 0xc2, 0xe5,
  0x3f, 0x67, 0x66, 0x66, 0x66, 0x66, 0x66, 0xe6, 0x3f,
};
constexpr std::uint8_t kRos1PoseStamped[] = {  // 75 bytes
  0x02, 0x00, 0x00, 0x00, 0x02, 0xf1, 0x53, 0x65, 0x00, 0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00,
  0x6d, 0x61, 0x70, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x24, 0xc0, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x80, 0x34, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f,
};
constexpr std::uint8_t kRos1Livox[] = {  // 85 bytes
  0x03, 0x00, 0x00, 0x00, 0x03, 0xf1, 0x53, 0x65, 0x80, 0xb2, 0xe6, 0x0e, 0x0b, 0x00, 0x00, 0x00,
  0x6c, 0x69, 0x76, 0x6f, 0x78, 0x5f, 0x66, 0x72, 0x61, 0x6d, 0x65, 0x80, 0x10, 0xe1, 0xf7, 0xfe,
  0x9c, 0x97, 0x17, 0x02, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0x40, 0x40, 0x0a,
  0x10, 0x00, 0xa0, 0x86, 0x01, 0x00, 0x00, 0x00, 0x80, 0xbf, 0x00, 0x00, 0x00, 0xc0, 0x00, 0x00,
  0x60, 0xc0, 0xc8, 0x00, 0x03,
};
constexpr std::uint8_t kCdrLeCloud[] = {  // 225 bytes
  0x00, 0x01, 0x00, 0x00, 0x00, 0xf1, 0x53, 0x65, 0x15, 0xcd, 0x5b, 0x07, 0x0a, 0x00, 0x00, 0x00,
  0x6f, 0x73, 0x5f, 0x73, 0x65, 0x6e, 0x73, 0x6f, 0x72, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
  0x03, 0x00, 0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00, 0x78, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x07, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00,
  0x79, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x07, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
  0x02, 0x00, 0x00, 0x00, 0x7a, 0x00, 0x00, 0x00, 0x08, 0x00, 0x00, 0x00, 0x07, 0x00, 0x00, 0x00,
  0x01, 0x00, 0x00, 0x00, 0x0a, 0x00, 0x00, 0x00, 0x69, 0x6e, 0x74, 0x65, 0x6e, 0x73, 0x69, 0x74,
  0x79, 0x00, 0x00, 0x00, 0x0c, 0x00, 0x00, 0x00, 0x07, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00,
  0x02, 0x00, 0x00, 0x00, 0x74, 0x00, 0x00, 0x00, 0x10, 0x00, 0x00, 0x00, 0x06, 0x00, 0x00, 0x00,
  0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00, 0x00, 0x3c, 0x00, 0x00, 0x00,
  0x3c, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00, 0x00, 0xc0, 0x00, 0x00, 0x80, 0x3e,
  0x00, 0x00, 0xc8, 0x42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x7f, 0x00, 0x00, 0x80, 0x3f,
  0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0xa0, 0x40, 0x50, 0xc3, 0x00, 0x00, 0x00, 0x00, 0x40, 0xc0,
  0x00, 0x00, 0x80, 0x40, 0x00, 0x00, 0xb0, 0xc0, 0x00, 0x00, 0xf0, 0x40, 0xc0, 0x9e, 0xe6, 0x05,
  0x00,
};
constexpr std::uint8_t kCdrLeOdometry[] = {  // 724 bytes
  0x00, 0x01, 0x00, 0x00, 0x01, 0xf1, 0x53, 0x65, 0x00, 0x65, 0xcd, 0x1d, 0x05, 0x00, 0x00, 0x00,
  0x6f, 0x64, 0x6f, 0x6d, 0x00, 0x00, 0x00, 0x00, 0x0a, 0x00, 0x00, 0x00, 0x62, 0x61, 0x73, 0x65,
  0x5f, 0x6c, 0x69, 0x6e, 0x6b, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0xf8, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02, 0xc0, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x08, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x90, 0x06, 0x93, 0xc1, 0x7d, 0x90, 0xd0, 0x3f, 0x15, 0xbf, 0x48, 0x47,
  0xdd, 0xe8, 0xee, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x7b, 0x14, 0xae, 0x47,
  0xe1, 0x7a, 0x84, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0x94, 0x3f, 0xb8, 0x1e, 0x85, 0xeb,
  0x51, 0xb8, 0x9e, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xa4, 0x3f, 0x9a, 0x99, 0x99, 0x99,
  0x99, 0x99, 0xa9, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xae, 0x3f, 0xec, 0x51, 0xb8, 0x1e,
  0x85, 0xeb, 0xb1, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xb4, 0x3f, 0x0a, 0xd7, 0xa3, 0x70,
  0x3d, 0x0a, 0xb7, 0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xb9, 0x3f, 0x29, 0x5c, 0x8f, 0xc2,
  0xf5, 0x28, 0xbc, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xbe, 0x3f, 0xa4, 0x70, 0x3d, 0x0a,
  0xd7, 0xa3, 0xc0, 0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xc1, 0x3f, 0x33, 0x33, 0x33, 0x33,
  0x33, 0x33, 0xc3, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xc4, 0x3f, 0xc3, 0xf5, 0x28, 0x5c,
  0x8f, 0xc2, 0xc5, 0x3f, 0x0a, 0xd7, 0xa3, 0x70, 0x3d, 0x0a, 0xc7, 0x3f, 0x52, 0xb8, 0x1e, 0x85,
  0xeb, 0x51, 0xc8, 0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xc9, 0x3f, 0xe1, 0x7a, 0x14, 0xae,
  0x47, 0xe1, 0xca, 0x3f, 0x29, 0x5c, 0x8f, 0xc2, 0xf5, 0x28, 0xcc, 0x3f, 0x71, 0x3d, 0x0a, 0xd7,
  0xa3, 0x70, 0xcd, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xce, 0x3f, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0xd0, 0x3f, 0xa4, 0x70, 0x3d, 0x0a, 0xd7, 0xa3, 0xd0, 0x3f, 0x48, 0xe1, 0x7a, 0x14,
  0xae, 0x47, 0xd1, 0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xd1, 0x3f, 0x8f, 0xc2, 0xf5, 0x28,
  0x5c, 0x8f, 0xd2, 0x3f, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0xd3, 0x3f, 0xd7, 0xa3, 0x70, 0x3d,
  0x0a, 0xd7, 0xd3, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xd4, 0x3f, 0x1f, 0x85, 0xeb, 0x51,
  0xb8, 0x1e, 0xd5, 0x3f, 0xc3, 0xf5, 0x28, 0x5c, 0x8f, 0xc2, 0xd5, 0x3f, 0x67, 0x66, 0x66, 0x66,
  0x66, 0x66, 0xd6, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x9a, 0x99, 0x99, 0x99,
  0x99, 0x99, 0xb9, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x7b, 0x14, 0xae, 0x47,
  0xe1, 0x7a, 0x94, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xa4, 0x3f, 0xb8, 0x1e, 0x85, 0xeb,
  0x51, 0xb8, 0xae, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xb4, 0x3f, 0x9a, 0x99, 0x99, 0x99,
  0x99, 0x99, 0xb9, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xbe, 0x3f, 0xec, 0x51, 0xb8, 0x1e,
  0x85, 0xeb, 0xc1, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xc4, 0x3f, 0x0a, 0xd7, 0xa3, 0x70,
  0x3d, 0x0a, 0xc7, 0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xc9, 0x3f, 0x29, 0x5c, 0x8f, 0xc2,
  0xf5, 0x28, 0xcc, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xce, 0x3f, 0xa4, 0x70, 0x3d, 0x0a,
  0xd7, 0xa3, 0xd0, 0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xd1, 0x3f, 0x33, 0x33, 0x33, 0x33,
  0x33, 0x33, 0xd3, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xd4, 0x3f, 0xc3, 0xf5, 0x28, 0x5c,
  0x8f, 0xc2, 0xd5, 0x3f, 0x0a, 0xd7, 0xa3, 0x70, 0x3d, 0x0a, 0xd7, 0x3f, 0x52, 0xb8, 0x1e, 0x85,
  0xeb, 0x51, 0xd8, 0x3f, 0x9a, 0x99, 0x99, 0x99, 0x99, 0x99, 0xd9, 0x3f, 0xe1, 0x7a, 0x14, 0xae,
  0x47, 0xe1, 0xda, 0x3f, 0x29, 0x5c, 0x8f, 0xc2, 0xf5, 0x28, 0xdc, 0x3f, 0x71, 0x3d, 0x0a, 0xd7,
  0xa3, 0x70, 0xdd, 0x3f, 0xb8, 0x1e, 0x85, 0xeb, 0x51, 0xb8, 0xde, 0x3f, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0xe0, 0x3f, 0xa4, 0x70, 0x3d, 0x0a, 0xd7, 0xa3, 0xe0, 0x3f, 0x48, 0xe1, 0x7a, 0x14,
  0xae, 0x47, 0xe1, 0x3f, 0xec, 0x51, 0xb8, 0x1e, 0x85, 0xeb, 0xe1, 0x3f, 0x8f, 0xc2, 0xf5, 0x28,
  0x5c, 0x8f, 0xe2, 0x3f, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0xe3, 0x3f, 0xd7, 0xa3, 0x70, 0x3d,
  0x0a, 0xd7, 0xe3, 0x3f, 0x7b, 0x14, 0xae, 0x47, 0xe1, 0x7a, 0xe4, 0x3f, 0x1f, 0x85, 0xeb, 0x51,
  0xb8, 0x1e, 0xe5, 0x3f, 0xc3, 0xf5, 0x28, 0x5c, 0x8f, 0xc2, 0xe5, 0x3f, 0x67, 0x66, 0x66, 0x66,
  0x66, 0x66, 0xe6, 0x3f,
};
constexpr std::uint8_t kCdrLePoseStamped[] = {  // 76 bytes
  0x00, 0x01, 0x00, 0x00, 0xfb, 0xff, 0xff, 0xff, 0xff, 0xc9, 0x9a, 0x3b, 0x04, 0x00, 0x00, 0x00,
  0x6d, 0x61, 0x70, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x24, 0xc0, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x80, 0x34, 0x40, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0xe0, 0x3f, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xe0, 0x3f,
};
constexpr std::uint8_t kCdrLeLivox[] = {  // 87 bytes
  0x00, 0x01, 0x00, 0x00, 0x03, 0xf1, 0x53, 0x65, 0x80, 0xb2, 0xe6, 0x0e, 0x0c, 0x00, 0x00, 0x00,
  0x6c, 0x69, 0x76, 0x6f, 0x78, 0x5f, 0x66, 0x72, 0x61, 0x6d, 0x65, 0x00, 0x80, 0x10, 0xe1, 0xf7,
  0xfe, 0x9c, 0x97, 0x17, 0x02, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x02, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x80, 0x3f, 0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0x40, 0x40,
  0x0a, 0x10, 0x00, 0x00, 0xa0, 0x86, 0x01, 0x00, 0x00, 0x00, 0x80, 0xbf, 0x00, 0x00, 0x00, 0xc0,
  0x00, 0x00, 0x60, 0xc0, 0xc8, 0x00, 0x03,
};
constexpr std::uint8_t kCdrBeOdometry[] = {  // 724 bytes
  0x00, 0x00, 0x00, 0x00, 0x65, 0x53, 0xf1, 0x01, 0x1d, 0xcd, 0x65, 0x00, 0x00, 0x00, 0x00, 0x05,
  0x6f, 0x64, 0x6f, 0x6d, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0a, 0x62, 0x61, 0x73, 0x65,
  0x5f, 0x6c, 0x69, 0x6e, 0x6b, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x3f, 0xf8, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0xc0, 0x02, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x40, 0x08, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x3f, 0xd0, 0x90, 0x7d, 0xc1, 0x93, 0x06, 0x90, 0x3f, 0xee, 0xe8, 0xdd,
  0x47, 0x48, 0xbf, 0x15, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x3f, 0x84, 0x7a, 0xe1,
  0x47, 0xae, 0x14, 0x7b, 0x3f, 0x94, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0x9e, 0xb8, 0x51,
  0xeb, 0x85, 0x1e, 0xb8, 0x3f, 0xa4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xa9, 0x99, 0x99,
  0x99, 0x99, 0x99, 0x9a, 0x3f, 0xae, 0xb8, 0x51, 0xeb, 0x85, 0x1e, 0xb8, 0x3f, 0xb1, 0xeb, 0x85,
  0x1e, 0xb8, 0x51, 0xec, 0x3f, 0xb4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xb7, 0x0a, 0x3d,
  0x70, 0xa3, 0xd7, 0x0a, 0x3f, 0xb9, 0x99, 0x99, 0x99, 0x99, 0x99, 0x9a, 0x3f, 0xbc, 0x28, 0xf5,
  0xc2, 0x8f, 0x5c, 0x29, 0x3f, 0xbe, 0xb8, 0x51, 0xeb, 0x85, 0x1e, 0xb8, 0x3f, 0xc0, 0xa3, 0xd7,
  0x0a, 0x3d, 0x70, 0xa4, 0x3f, 0xc1, 0xeb, 0x85, 0x1e, 0xb8, 0x51, 0xec, 0x3f, 0xc3, 0x33, 0x33,
  0x33, 0x33, 0x33, 0x33, 0x3f, 0xc4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xc5, 0xc2, 0x8f,
  0x5c, 0x28, 0xf5, 0xc3, 0x3f, 0xc7, 0x0a, 0x3d, 0x70, 0xa3, 0xd7, 0x0a, 0x3f, 0xc8, 0x51, 0xeb,
  0x85, 0x1e, 0xb8, 0x52, 0x3f, 0xc9, 0x99, 0x99, 0x99, 0x99, 0x99, 0x9a, 0x3f, 0xca, 0xe1, 0x47,
  0xae, 0x14, 0x7a, 0xe1, 0x3f, 0xcc, 0x28, 0xf5, 0xc2, 0x8f, 0x5c, 0x29, 0x3f, 0xcd, 0x70, 0xa3,
  0xd7, 0x0a, 0x3d, 0x71, 0x3f, 0xce, 0xb8, 0x51, 0xeb, 0x85, 0x1e, 0xb8, 0x3f, 0xd0, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x3f, 0xd0, 0xa3, 0xd7, 0x0a, 0x3d, 0x70, 0xa4, 0x3f, 0xd1, 0x47, 0xae,
  0x14, 0x7a, 0xe1, 0x48, 0x3f, 0xd1, 0xeb, 0x85, 0x1e, 0xb8, 0x51, 0xec, 0x3f, 0xd2, 0x8f, 0x5c,
  0x28, 0xf5, 0xc2, 0x8f, 0x3f, 0xd3, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0x3f, 0xd3, 0xd7, 0x0a,
  0x3d, 0x70, 0xa3, 0xd7, 0x3f, 0xd4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xd5, 0x1e, 0xb8,
  0x51, 0xeb, 0x85, 0x1f, 0x3f, 0xd5, 0xc2, 0x8f, 0x5c, 0x28, 0xf5, 0xc3, 0x3f, 0xd6, 0x66, 0x66,
  0x66, 0x66, 0x66, 0x67, 0x3f, 0xe0, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x3f, 0xb9, 0x99, 0x99,
  0x99, 0x99, 0x99, 0x9a, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x3f, 0x94, 0x7a, 0xe1,
  0x47, 0xae, 0x14, 0x7b, 0x3f, 0xa4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xae, 0xb8, 0x51,
  0xeb, 0x85, 0x1e, 0xb8, 0x3f, 0xb4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xb9, 0x99, 0x99,
  0x99, 0x99, 0x99, 0x9a, 0x3f, 0xbe, 0xb8, 0x51, 0xeb, 0x85, 0x1e, 0xb8, 0x3f, 0xc1, 0xeb, 0x85,
  0x1e, 0xb8, 0x51, 0xec, 0x3f, 0xc4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xc7, 0x0a, 0x3d,
  0x70, 0xa3, 0xd7, 0x0a, 0x3f, 0xc9, 0x99, 0x99, 0x99, 0x99, 0x99, 0x9a, 0x3f, 0xcc, 0x28, 0xf5,
  0xc2, 0x8f, 0x5c, 0x29, 0x3f, 0xce, 0xb8, 0x51, 0xeb, 0x85, 0x1e, 0xb8, 0x3f, 0xd0, 0xa3, 0xd7,
  0x0a, 0x3d, 0x70, 0xa4, 0x3f, 0xd1, 0xeb, 0x85, 0x1e, 0xb8, 0x51, 0xec, 0x3f, 0xd3, 0x33, 0x33,
  0x33, 0x33, 0x33, 0x33, 0x3f, 0xd4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xd5, 0xc2, 0x8f,
  0x5c, 0x28, 0xf5, 0xc3, 0x3f, 0xd7, 0x0a, 0x3d, 0x70, 0xa3, 0xd7, 0x0a, 0x3f, 0xd8, 0x51, 0xeb,
  0x85, 0x1e, 0xb8, 0x52, 0x3f, 0xd9, 0x99, 0x99, 0x99, 0x99, 0x99, 0x9a, 0x3f, 0xda, 0xe1, 0x47,
  0xae, 0x14, 0x7a, 0xe1, 0x3f, 0xdc, 0x28, 0xf5, 0xc2, 0x8f, 0x5c, 0x29, 0x3f, 0xdd, 0x70, 0xa3,
  0xd7, 0x0a, 0x3d, 0x71, 0x3f, 0xde, 0xb8, 0x51, 0xeb, 0x85, 0x1e, 0xb8, 0x3f, 0xe0, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x3f, 0xe0, 0xa3, 0xd7, 0x0a, 0x3d, 0x70, 0xa4, 0x3f, 0xe1, 0x47, 0xae,
  0x14, 0x7a, 0xe1, 0x48, 0x3f, 0xe1, 0xeb, 0x85, 0x1e, 0xb8, 0x51, 0xec, 0x3f, 0xe2, 0x8f, 0x5c,
  0x28, 0xf5, 0xc2, 0x8f, 0x3f, 0xe3, 0x33, 0x33, 0x33, 0x33, 0x33, 0x33, 0x3f, 0xe3, 0xd7, 0x0a,
  0x3d, 0x70, 0xa3, 0xd7, 0x3f, 0xe4, 0x7a, 0xe1, 0x47, 0xae, 0x14, 0x7b, 0x3f, 0xe5, 0x1e, 0xb8,
  0x51, 0xeb, 0x85, 0x1f, 0x3f, 0xe5, 0xc2, 0x8f, 0x5c, 0x28, 0xf5, 0xc3, 0x3f, 0xe6, 0x66, 0x66,
  0x66, 0x66, 0x66, 0x67,
};
constexpr std::uint8_t kCdrBeCloud[] = {  // 225 bytes
  0x00, 0x00, 0x00, 0x00, 0x65, 0x53, 0xf1, 0x00, 0x07, 0x5b, 0xcd, 0x15, 0x00, 0x00, 0x00, 0x0a,
  0x6f, 0x73, 0x5f, 0x73, 0x65, 0x6e, 0x73, 0x6f, 0x72, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01,
  0x00, 0x00, 0x00, 0x03, 0x00, 0x00, 0x00, 0x05, 0x00, 0x00, 0x00, 0x02, 0x78, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x00, 0x07, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x02,
  0x79, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x04, 0x07, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01,
  0x00, 0x00, 0x00, 0x02, 0x7a, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x08, 0x07, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x0a, 0x69, 0x6e, 0x74, 0x65, 0x6e, 0x73, 0x69, 0x74,
  0x79, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x0c, 0x07, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01,
  0x00, 0x00, 0x00, 0x02, 0x74, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x10, 0x06, 0x00, 0x00, 0x00,
  0x00, 0x00, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x14, 0x00, 0x00, 0x00, 0x3c,
  0x00, 0x00, 0x00, 0x3c, 0x00, 0x00, 0xc0, 0x3f, 0x00, 0x00, 0x00, 0xc0, 0x00, 0x00, 0x80, 0x3e,
  0x00, 0x00, 0xc8, 0x42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0xc0, 0x7f, 0x00, 0x00, 0x80, 0x3f,
  0x00, 0x00, 0x00, 0x40, 0x00, 0x00, 0xa0, 0x40, 0x50, 0xc3, 0x00, 0x00, 0x00, 0x00, 0x40, 0xc0,
  0x00, 0x00, 0x80, 0x40, 0x00, 0x00, 0xb0, 0xc0, 0x00, 0x00, 0xf0, 0x40, 0xc0, 0x9e, 0xe6, 0x05,
  0x00,
};
constexpr std::uint8_t kCdrBeLivox[] = {  // 87 bytes
  0x00, 0x00, 0x00, 0x00, 0x65, 0x53, 0xf1, 0x03, 0x0e, 0xe6, 0xb2, 0x80, 0x00, 0x00, 0x00, 0x0c,
  0x6c, 0x69, 0x76, 0x6f, 0x78, 0x5f, 0x66, 0x72, 0x61, 0x6d, 0x65, 0x00, 0x17, 0x97, 0x9c, 0xfe,
  0xf7, 0xe1, 0x10, 0x80, 0x00, 0x00, 0x00, 0x02, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x02,
  0x00, 0x00, 0x00, 0x00, 0x3f, 0x80, 0x00, 0x00, 0x40, 0x00, 0x00, 0x00, 0x40, 0x40, 0x00, 0x00,
  0x0a, 0x10, 0x00, 0x00, 0x00, 0x01, 0x86, 0xa0, 0xbf, 0x80, 0x00, 0x00, 0xc0, 0x00, 0x00, 0x00,
  0xc0, 0x60, 0x00, 0x00, 0xc8, 0x00, 0x03,
};

Span<const std::uint8_t> Bytes(const std::uint8_t* data, std::size_t size) { return {data, size}; }
template <std::size_t N>
std::vector<std::uint8_t> Vec(const std::uint8_t (&a)[N]) {
  return std::vector<std::uint8_t>(a, a + N);
}

// ---------------------------------------------------------------------------------------------------------------
// An encoder written from the wire rules, independent of the decoder.

enum class Enc { kRos1, kCdrLe, kCdrBe };

const char* EncName(Enc e) { return e == Enc::kRos1 ? "ROS 1" : (e == Enc::kCdrLe ? "CDR_LE" : "CDR_BE"); }
RosEncoding EncodingOf(Enc e) { return e == Enc::kRos1 ? RosEncoding::kRos1 : RosEncoding::kCdr; }

class Wire {
 public:
  explicit Wire(Enc enc) : enc_(enc) {
    if (enc != Enc::kRos1) bytes = {0x00, static_cast<std::uint8_t>(enc == Enc::kCdrLe ? 1 : 0), 0x00, 0x00};
  }
  Wire& U8(std::uint8_t v) { return Put(v); }
  Wire& U32(std::uint32_t v) { return Put(v); }
  Wire& I32(std::int32_t v) { return Put(v); }
  Wire& U64(std::uint64_t v) { return Put(v); }
  Wire& F32(float v) { return Put(v); }
  Wire& F64(double v) { return Put(v); }
  /// ROS 1: length + chars. CDR: length + 1, chars, NUL.
  Wire& Str(const std::string& s) {
    const bool cdr = enc_ != Enc::kRos1;
    U32(static_cast<std::uint32_t>(s.size() + (cdr ? 1 : 0)));
    bytes.insert(bytes.end(), s.begin(), s.end());
    if (cdr) bytes.push_back(0);
    return *this;
  }
  Wire& Raw(const std::vector<std::uint8_t>& raw) {
    bytes.insert(bytes.end(), raw.begin(), raw.end());
    return *this;
  }
  /// std_msgs/Header.
  Wire& Header(std::uint32_t seq, std::int64_t sec, std::uint32_t nsec, const std::string& frame) {
    if (enc_ == Enc::kRos1) {
      U32(seq).U32(static_cast<std::uint32_t>(sec));
    } else {
      I32(static_cast<std::int32_t>(sec));
    }
    return U32(nsec).Str(frame);
  }

  std::vector<std::uint8_t> bytes;

 private:
  template <class T>
  Wire& Put(T v) {
    if (enc_ != Enc::kRos1) {
      while ((bytes.size() - 4) % sizeof(T) != 0) bytes.push_back(0);
    }
    std::uint8_t b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T); ++i) {
      bytes.push_back(enc_ == Enc::kCdrBe ? b[sizeof(T) - 1 - i] : b[i]);
    }
    return *this;
  }

  Enc enc_;
};

constexpr double kPi = 3.14159265358979323846;

// PointField datatypes.
constexpr std::uint8_t kI8 = 1, kU8 = 2, kI16 = 3, kU16 = 4, kI32 = 5, kU32 = 6, kF32 = 7, kF64 = 8;

struct Field {
  std::string name;
  std::uint32_t offset = 0;
  std::uint8_t datatype = kF32;
  std::uint32_t count = 1;
};

struct CloudSpec {
  std::int64_t sec = 100;
  std::uint32_t nsec = 0;
  std::string frame = "lidar";
  std::uint32_t height = 1, width = 0;
  std::vector<Field> fields;
  std::uint8_t is_bigendian = 0;
  std::uint32_t point_step = 0, row_step = 0;
  std::vector<std::uint8_t> data;

  /// Writes a value into point i (row-major, rows of row_step bytes) at the field's offset.
  template <class T>
  void Set(std::size_t i, std::uint32_t offset, T v) {
    const std::size_t at = (i / width) * row_step + (i % width) * point_step + offset;
    REQUIRE(at + sizeof(T) <= data.size());
    std::memcpy(data.data() + at, &v, sizeof(T));
  }
};

/// n points in one row of point_step bytes each, zero-filled.
CloudSpec MakeCloud(std::vector<Field> fields, std::uint32_t point_step, std::uint32_t n) {
  CloudSpec c;
  c.fields = std::move(fields);
  c.point_step = point_step;
  c.width = n;
  c.row_step = point_step * n;
  c.data.assign(std::size_t{c.row_step}, 0);
  return c;
}

std::vector<Field> XyzFloat32() { return {{"x", 0, kF32}, {"y", 4, kF32}, {"z", 8, kF32}}; }

std::vector<std::uint8_t> EncodeCloud(Enc enc, const CloudSpec& c, std::uint32_t seq = 0) {
  Wire w(enc);
  w.Header(seq, c.sec, c.nsec, c.frame).U32(c.height).U32(c.width);
  w.U32(static_cast<std::uint32_t>(c.fields.size()));
  for (const Field& f : c.fields) w.Str(f.name).U32(f.offset).U8(f.datatype).U32(f.count);
  w.U8(c.is_bigendian).U32(c.point_step).U32(c.row_step);
  w.U32(static_cast<std::uint32_t>(c.data.size())).Raw(c.data);
  return w.U8(0).bytes;
}

struct LivoxPoint {
  std::uint32_t offset_time = 0;
  float x = 0, y = 0, z = 0;
  std::uint8_t reflectivity = 0, tag = 0, line = 0;
};

struct LivoxSpec {
  std::int64_t sec = 100;
  std::uint32_t nsec = 0;
  std::string frame = "livox_frame";
  std::uint64_t timebase = 100000000000ull;
  std::uint32_t point_num = 0;  ///< written as is (tests make it lie)
  std::vector<LivoxPoint> points;
};

std::vector<std::uint8_t> EncodeLivox(Enc enc, const LivoxSpec& l, std::uint32_t seq = 0) {
  Wire w(enc);
  w.Header(seq, l.sec, l.nsec, l.frame).U64(l.timebase).U32(l.point_num).U8(1).U8(0).U8(0).U8(0);
  w.U32(static_cast<std::uint32_t>(l.points.size()));
  for (const LivoxPoint& p : l.points) {
    w.U32(p.offset_time).F32(p.x).F32(p.y).F32(p.z).U8(p.reflectivity).U8(p.tag).U8(p.line);
  }
  return w.bytes;
}

struct PoseSpec {
  std::int64_t sec = 100;
  std::uint32_t nsec = 0;
  std::string frame = "map", child = "base_link";
  double position[3] = {0, 0, 0};
  double orientation[4] = {0, 0, 0, 1};  ///< x, y, z, w
  double cov_scale = 0.0, twist_cov_scale = 0.0;
  double twist[6] = {0, 0, 0, 0, 0, 0};
};

void PutPose(Wire* w, const PoseSpec& p) {
  for (const double v : p.position) w->F64(v);
  for (const double v : p.orientation) w->F64(v);
}

std::vector<std::uint8_t> EncodeOdometry(Enc enc, const PoseSpec& p, std::uint32_t seq = 0) {
  Wire w(enc);
  w.Header(seq, p.sec, p.nsec, p.frame).Str(p.child);
  PutPose(&w, p);
  for (int i = 0; i < 36; ++i) w.F64(p.cov_scale * i);
  for (const double v : p.twist) w.F64(v);
  for (int i = 0; i < 36; ++i) w.F64(p.twist_cov_scale * i);
  return w.bytes;
}

std::vector<std::uint8_t> EncodePoseStamped(Enc enc, const PoseSpec& p, std::uint32_t seq = 0) {
  Wire w(enc);
  w.Header(seq, p.sec, p.nsec, p.frame);
  PutPose(&w, p);
  return w.bytes;
}

// The specs of the reference messages.
CloudSpec ReferenceCloud() {
  CloudSpec c = MakeCloud({{"x", 0, kF32}, {"y", 4, kF32}, {"z", 8, kF32}, {"intensity", 12, kF32}, {"t", 16, kU32}},
                          20, 3);
  c.sec = 1700000000;
  c.nsec = 123456789;
  c.frame = "os_sensor";
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float xyzi[3][4] = {{1.5f, -2.0f, 0.25f, 100.0f}, {nan, 1.0f, 2.0f, 5.0f}, {-3.0f, 4.0f, -5.5f, 7.5f}};
  const std::uint32_t t[3] = {0, 50000, 99000000};
  for (std::size_t i = 0; i < 3; ++i) {
    for (std::uint32_t k = 0; k < 4; ++k) c.Set(i, 4 * k, xyzi[i][k]);
    c.Set(i, 16, t[i]);
  }
  return c;
}

PoseSpec ReferenceOdometry() {
  PoseSpec p;
  p.sec = 1700000001;
  p.nsec = 500000000;
  p.frame = "odom";
  p.child = "base_link";
  const double half = 15.0 * kPi / 180.0;
  p.position[0] = 1.5;
  p.position[1] = -2.25;
  p.position[2] = 3.0;
  p.orientation[2] = std::sin(half);
  p.orientation[3] = std::cos(half);
  p.cov_scale = 0.01;
  p.twist_cov_scale = 0.02;
  p.twist[0] = 0.5;
  p.twist[5] = 0.1;
  return p;
}

PoseSpec ReferencePoseStamped(Enc enc) {
  PoseSpec p;
  p.sec = enc == Enc::kRos1 ? 1700000002 : -5;
  p.nsec = enc == Enc::kRos1 ? 0 : 999999999;
  p.frame = "map";
  p.position[0] = -10.0;
  p.position[1] = 20.5;
  p.position[2] = 0.125;
  for (double& q : p.orientation) q = 0.5;
  return p;
}

LivoxSpec ReferenceLivox() {
  LivoxSpec l;
  l.sec = 1700000003;
  l.nsec = 250000000;
  l.timebase = 1700000003250000000ull;
  l.point_num = 2;
  l.points = {{0, 1.0f, 2.0f, 3.0f, 10, 0x10, 0}, {100000, -1.0f, -2.0f, -3.5f, 200, 0, 3}};
  return l;
}

// ---------------------------------------------------------------------------------------------------------------
// Decoding helpers.

struct ScanResult {
  Status status;
  RosScan scan;
};

ScanResult DecodeCloud(Enc enc, const std::vector<std::uint8_t>& bytes, RosScanLimits limits = {}) {
  ScanResult r;
  r.status = DecodePointCloud2(EncodingOf(enc), bytes, limits, &r.scan);
  return r;
}

ScanResult DecodeLivox(Enc enc, const std::vector<std::uint8_t>& bytes, RosScanLimits limits = {}) {
  ScanResult r;
  r.status = DecodeLivoxCustomMsg(EncodingOf(enc), bytes, limits, &r.scan);
  return r;
}

struct PoseResult {
  Status status;
  RosPose pose;
};

PoseResult DecodeOdom(Enc enc, const std::vector<std::uint8_t>& bytes) {
  PoseResult r;
  r.status = DecodeOdometry(EncodingOf(enc), bytes, &r.pose);
  return r;
}

PoseResult DecodePose(Enc enc, const std::vector<std::uint8_t>& bytes) {
  PoseResult r;
  r.status = DecodePoseStamped(EncodingOf(enc), bytes, &r.pose);
  return r;
}

bool Contains(const Status& s, const std::string& text) { return s.message().find(text) != std::string::npos; }

constexpr Enc kAllEncodings[] = {Enc::kRos1, Enc::kCdrLe, Enc::kCdrBe};

/// Runs every decoder on the bytes in both encodings: none may crash, an error must say something.
void DecodeWithEverything(const std::vector<std::uint8_t>& bytes) {
  RosScanLimits limits;
  limits.max_points = 1u << 16;
  for (const RosEncoding e : {RosEncoding::kRos1, RosEncoding::kCdr}) {
    RosScan scan;
    RosPose pose;
    const Status s[] = {DecodePointCloud2(e, bytes, limits, &scan), DecodeLivoxCustomMsg(e, bytes, limits, &scan),
                        DecodeOdometry(e, bytes, &pose), DecodePoseStamped(e, bytes, &pose)};
    for (const Status& one : s) {
      if (!one.ok()) REQUIRE_FALSE(one.message().empty());
    }
    REQUIRE((scan.point_time_s.empty() || scan.point_time_s.size() == scan.points.size()));
  }
}

// ---------------------------------------------------------------------------------------------------------------

TEST_CASE("RosMessageKindOf accepts pkg/Type and pkg/msg/Type of the five supported types") {
  CHECK(RosMessageKindOf("sensor_msgs/PointCloud2") == RosMessageKind::kPointCloud2);
  CHECK(RosMessageKindOf("sensor_msgs/msg/PointCloud2") == RosMessageKind::kPointCloud2);
  CHECK(RosMessageKindOf("nav_msgs/Odometry") == RosMessageKind::kOdometry);
  CHECK(RosMessageKindOf("nav_msgs/msg/Odometry") == RosMessageKind::kOdometry);
  CHECK(RosMessageKindOf("geometry_msgs/PoseStamped") == RosMessageKind::kPoseStamped);
  CHECK(RosMessageKindOf("geometry_msgs/msg/PoseStamped") == RosMessageKind::kPoseStamped);
  CHECK(RosMessageKindOf("livox_ros_driver/CustomMsg") == RosMessageKind::kLivoxCustom);
  CHECK(RosMessageKindOf("livox_ros_driver/msg/CustomMsg") == RosMessageKind::kLivoxCustom);
  CHECK(RosMessageKindOf("livox_ros_driver2/CustomMsg") == RosMessageKind::kLivoxCustom);
  CHECK(RosMessageKindOf("livox_ros_driver2/msg/CustomMsg") == RosMessageKind::kLivoxCustom);
  for (const char* other : {"", "PointCloud2", "sensor_msgs/PointCloud", "sensor_msgs/msg/PointCloud2x",
                            "sensor_msgs/srv/PointCloud2", "/sensor_msgs/PointCloud2", "sensor_msgs//PointCloud2",
                            "geometry_msgs/Pose", "livox_ros_driver3/CustomMsg", "nav_msgs/Path"}) {
    CAPTURE(other);
    CHECK(RosMessageKindOf(other) == RosMessageKind::kUnsupported);
  }
  CHECK(std::string(RosMessageKindName(RosMessageKind::kPointCloud2)) == "PointCloud2");
  CHECK(std::string(RosMessageKindName(RosMessageKind::kLivoxCustom)) == "Livox CustomMsg");
  CHECK(std::string(RosMessageKindName(RosMessageKind::kOdometry)) == "Odometry");
  CHECK(std::string(RosMessageKindName(RosMessageKind::kPoseStamped)) == "PoseStamped");
  CHECK(std::string(RosMessageKindName(RosMessageKind::kUnsupported)) == "unsupported");
  CHECK(IsScanKind(RosMessageKind::kPointCloud2));
  CHECK(IsScanKind(RosMessageKind::kLivoxCustom));
  CHECK_FALSE(IsScanKind(RosMessageKind::kOdometry));
  CHECK_FALSE(IsScanKind(RosMessageKind::kPoseStamped));
  CHECK_FALSE(IsScanKind(RosMessageKind::kUnsupported));
}

TEST_CASE("the test encoder reproduces the bytes of genpy and of the Foxglove CDR writers") {
  CHECK(EncodeCloud(Enc::kRos1, ReferenceCloud(), 7) == Vec(kRos1Cloud));
  CHECK(EncodeCloud(Enc::kCdrLe, ReferenceCloud()) == Vec(kCdrLeCloud));
  CHECK(EncodeCloud(Enc::kCdrBe, ReferenceCloud()) == Vec(kCdrBeCloud));
  CHECK(EncodeOdometry(Enc::kRos1, ReferenceOdometry(), 1) == Vec(kRos1Odometry));
  CHECK(EncodeOdometry(Enc::kCdrLe, ReferenceOdometry()) == Vec(kCdrLeOdometry));
  CHECK(EncodeOdometry(Enc::kCdrBe, ReferenceOdometry()) == Vec(kCdrBeOdometry));
  CHECK(EncodePoseStamped(Enc::kRos1, ReferencePoseStamped(Enc::kRos1), 2) == Vec(kRos1PoseStamped));
  CHECK(EncodePoseStamped(Enc::kCdrLe, ReferencePoseStamped(Enc::kCdrLe)) == Vec(kCdrLePoseStamped));
  CHECK(EncodeLivox(Enc::kRos1, ReferenceLivox(), 3) == Vec(kRos1Livox));
  CHECK(EncodeLivox(Enc::kCdrLe, ReferenceLivox()) == Vec(kCdrLeLivox));
  CHECK(EncodeLivox(Enc::kCdrBe, ReferenceLivox()) == Vec(kCdrBeLivox));
}

void CheckReferenceCloud(const ScanResult& r) {
  REQUIRE_MESSAGE(r.status.ok(), r.status.ToString());
  CHECK(r.scan.stamp_ns == 1700000000123456789LL);
  CHECK(r.scan.frame_id == "os_sensor");
  CHECK(r.scan.non_finite_dropped == 1);
  REQUIRE(r.scan.points.size() == 2);
  CHECK(r.scan.points[0].x == 1.5f);
  CHECK(r.scan.points[0].y == -2.0f);
  CHECK(r.scan.points[0].z == 0.25f);
  CHECK(r.scan.points[0].intensity == 100.0f);
  CHECK(r.scan.points[1].x == -3.0f);
  CHECK(r.scan.points[1].y == 4.0f);
  CHECK(r.scan.points[1].z == -5.5f);
  CHECK(r.scan.points[1].intensity == 7.5f);
  CHECK(r.scan.point_time_field == "t");
  REQUIRE(r.scan.point_time_s.size() == 2);
  CHECK(r.scan.point_time_s[0] == 0.0f);
  CHECK(r.scan.point_time_s[1] == doctest::Approx(0.099).epsilon(1e-6));
}

TEST_CASE("PointCloud2 written by genpy and by the Foxglove CDR writers decodes to the same scan") {
  SUBCASE("ROS 1") { CheckReferenceCloud(DecodeCloud(Enc::kRos1, Vec(kRos1Cloud))); }
  SUBCASE("CDR_LE") { CheckReferenceCloud(DecodeCloud(Enc::kCdrLe, Vec(kCdrLeCloud))); }
  SUBCASE("CDR_BE") { CheckReferenceCloud(DecodeCloud(Enc::kCdrBe, Vec(kCdrBeCloud))); }
}

TEST_CASE("PointCloud2 with float64 coordinates, padded points and rows, two rows") {
  for (const Enc enc : kAllEncodings) {
    CAPTURE(EncName(enc));
    CloudSpec c = MakeCloud({{"pad", 0, kU32}, {"x", 8, kF64}, {"y", 16, kF64}, {"z", 24, kF64}}, 40, 2);
    c.height = 2;
    c.row_step = 96;  // 2 x 40 bytes of points + 16 bytes of row padding
    c.data.assign(192, 0xEE);
    for (std::size_t i = 0; i < 4; ++i) {
      c.Set(i, 8, 1.0 + static_cast<double>(i));
      c.Set(i, 16, -0.5 * static_cast<double>(i));
      c.Set(i, 24, 1e-3);
    }
    const ScanResult r = DecodeCloud(enc, EncodeCloud(enc, c));
    REQUIRE_MESSAGE(r.status.ok(), r.status.ToString());
    REQUIRE(r.scan.points.size() == 4);
    for (std::size_t i = 0; i < 4; ++i) {
      CHECK(r.scan.points[i].x == static_cast<float>(1.0 + static_cast<double>(i)));
      CHECK(r.scan.points[i].y == static_cast<float>(-0.5 * static_cast<double>(i)));
      CHECK(r.scan.points[i].z == static_cast<float>(1e-3));
      CHECK(r.scan.points[i].intensity == 0.0f);
    }
    CHECK(r.scan.point_time_s.empty());
    CHECK(r.scan.point_time_field.empty());
  }
}

/// A cloud of two points x y z float32 + one extra field at offset 12 in a 24-byte point.
template <class T>
CloudSpec CloudWithField(const std::string& name, std::uint8_t datatype, T a, T b) {
  std::vector<Field> fields = XyzFloat32();
  fields.push_back({name, 12, datatype});
  CloudSpec c = MakeCloud(fields, 24, 2);
  c.Set(0, 0, 1.0f);
  c.Set(1, 0, 2.0f);
  c.Set(0, 12, a);
  c.Set(1, 12, b);
  return c;
}

template <class T>
void CheckIntensity(const std::string& name, std::uint8_t datatype, T a, T b, float fa, float fb) {
  for (const Enc enc : kAllEncodings) {
    CAPTURE(name);
    CAPTURE(EncName(enc));
    const ScanResult r = DecodeCloud(enc, EncodeCloud(enc, CloudWithField(name, datatype, a, b)));
    REQUIRE_MESSAGE(r.status.ok(), r.status.ToString());
    REQUIRE(r.scan.points.size() == 2);
    CHECK(r.scan.points[0].intensity == fa);
    CHECK(r.scan.points[1].intensity == fb);
  }
}

TEST_CASE("PointCloud2 intensity of every numeric type, from intensity else reflectivity else 0") {
  CheckIntensity<std::uint8_t>("intensity", kU8, 0, 255, 0.0f, 255.0f);
  CheckIntensity<std::int8_t>("intensity", kI8, -128, 127, -128.0f, 127.0f);
  CheckIntensity<std::uint16_t>("intensity", kU16, 1000, 65535, 1000.0f, 65535.0f);
  CheckIntensity<std::int16_t>("intensity", kI16, -300, 300, -300.0f, 300.0f);
  CheckIntensity<std::uint32_t>("intensity", kU32, 70000, 7, 70000.0f, 7.0f);
  CheckIntensity<std::int32_t>("intensity", kI32, -70000, 7, -70000.0f, 7.0f);
  CheckIntensity<float>("intensity", kF32, 0.25f, 3.5f, 0.25f, 3.5f);
  CheckIntensity<double>("intensity", kF64, 0.125, 1e3, 0.125f, 1000.0f);
  CheckIntensity<std::uint16_t>("reflectivity", kU16, 12, 4000, 12.0f, 4000.0f);
  CheckIntensity<std::uint8_t>("ambient", kU8, 12, 40, 0.0f, 0.0f);  // not an intensity: 0

  SUBCASE("intensity wins over reflectivity") {
    std::vector<Field> fields = XyzFloat32();
    fields.push_back({"reflectivity", 12, kU8});
    fields.push_back({"intensity", 16, kF32});
    CloudSpec c = MakeCloud(fields, 20, 1);
    c.Set<std::uint8_t>(0, 12, 9);
    c.Set(0, 16, 42.0f);
    const ScanResult r = DecodeCloud(Enc::kRos1, EncodeCloud(Enc::kRos1, c));
    REQUIRE(r.status.ok());
    CHECK(r.scan.points[0].intensity == 42.0f);
  }
}

TEST_CASE("PointCloud2 point times from t, time, timestamp and offset_time") {
  for (const Enc enc : kAllEncodings) {
    CAPTURE(EncName(enc));
    SUBCASE("t: uint32 ns (Ouster)") {
      const ScanResult r = DecodeCloud(enc, EncodeCloud(enc, CloudWithField<std::uint32_t>("t", kU32, 0, 50000000)));
      REQUIRE(r.status.ok());
      CHECK(r.scan.point_time_field == "t");
      REQUIRE(r.scan.point_time_s.size() == 2);
      CHECK(r.scan.point_time_s[0] == 0.0f);
      CHECK(r.scan.point_time_s[1] == doctest::Approx(0.05).epsilon(1e-6));
    }
    SUBCASE("time: float32 s (Velodyne)") {
      const ScanResult r = DecodeCloud(enc, EncodeCloud(enc, CloudWithField("time", kF32, -0.05f, 0.0625f)));
      REQUIRE(r.status.ok());
      CHECK(r.scan.point_time_field == "time");
      REQUIRE(r.scan.point_time_s.size() == 2);
      CHECK(r.scan.point_time_s[0] == -0.05f);
      CHECK(r.scan.point_time_s[1] == 0.0625f);
    }
    SUBCASE("timestamp: float64 absolute s (Hesai), relative to the stamp") {
      CloudSpec c = CloudWithField("timestamp", kF64, 1700000000.5, 1700000000.6);
      c.sec = 1700000000;
      c.nsec = 500000000;
      const ScanResult r = DecodeCloud(enc, EncodeCloud(enc, c));
      REQUIRE(r.status.ok());
      CHECK(r.scan.point_time_field == "timestamp");
      REQUIRE(r.scan.point_time_s.size() == 2);
      CHECK(std::fabs(r.scan.point_time_s[0]) < 1e-6);
      CHECK(std::fabs(r.scan.point_time_s[1] - 0.1f) < 1e-6);
    }
    SUBCASE("timestamp above 1e14: absolute ns (livox_ros_driver2)") {
      CloudSpec c = CloudWithField("timestamp", kF64, 1700000000400000000.0, 1700000000510000000.0);
      c.sec = 1700000000;
      c.nsec = 500000000;
      const ScanResult r = DecodeCloud(enc, EncodeCloud(enc, c));
      REQUIRE(r.status.ok());
      REQUIRE(r.scan.point_time_s.size() == 2);
      CHECK(std::fabs(r.scan.point_time_s[0] - -0.1f) < 1e-6);
      CHECK(std::fabs(r.scan.point_time_s[1] - 0.01f) < 1e-6);
    }
    SUBCASE("offset_time: uint32 ns (Livox as PointCloud2)") {
      const ScanResult r =
          DecodeCloud(enc, EncodeCloud(enc, CloudWithField<std::uint32_t>("offset_time", kU32, 10, 2000000)));
      REQUIRE(r.status.ok());
      CHECK(r.scan.point_time_field == "offset_time");
      REQUIRE(r.scan.point_time_s.size() == 2);
      CHECK(r.scan.point_time_s[0] == doctest::Approx(1e-8).epsilon(1e-6));
      CHECK(r.scan.point_time_s[1] == doctest::Approx(0.002).epsilon(1e-6));
    }
  }
  SUBCASE("the order of preference is t, time, timestamp, offset_time, whatever the fields' order") {
    std::vector<Field> fields = XyzFloat32();
    fields.push_back({"offset_time", 12, kU32});
    fields.push_back({"timestamp", 16, kF64});
    fields.push_back({"time", 24, kF32});
    CloudSpec c = MakeCloud(fields, 28, 1);
    c.Set<std::uint32_t>(0, 12, 1000);
    c.Set(0, 16, 5.0);
    c.Set(0, 24, 0.25f);
    ScanResult r = DecodeCloud(Enc::kRos1, EncodeCloud(Enc::kRos1, c));
    REQUIRE(r.status.ok());
    CHECK(r.scan.point_time_field == "time");
    CHECK(r.scan.point_time_s == std::vector<float>{0.25f});
    c.fields[5].name = "other";  // was "time"
    r = DecodeCloud(Enc::kRos1, EncodeCloud(Enc::kRos1, c));
    REQUIRE(r.status.ok());
    CHECK(r.scan.point_time_field == "timestamp");
    c.fields[4].name = "other2";  // was "timestamp"
    r = DecodeCloud(Enc::kRos1, EncodeCloud(Enc::kRos1, c));
    REQUIRE(r.status.ok());
    CHECK(r.scan.point_time_field == "offset_time");
  }
}

TEST_CASE("PointCloud2 drops and counts non-finite points, times stay aligned with the kept points") {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<Field> fields = XyzFloat32();
  fields.push_back({"time", 12, kF32});
  CloudSpec c = MakeCloud(fields, 16, 6);
  const float bad[6][3] = {{nan, 0, 0}, {1, 1, 1}, {0, inf, 0}, {2, 2, 2}, {0, 0, -inf}, {3, 3, 3}};
  for (std::size_t i = 0; i < 6; ++i) {
    for (std::uint32_t k = 0; k < 3; ++k) c.Set(i, 4 * k, bad[i][k]);
    c.Set(i, 12, 0.01f * static_cast<float>(i));
  }
  for (const Enc enc : kAllEncodings) {
    const ScanResult r = DecodeCloud(enc, EncodeCloud(enc, c));
    REQUIRE(r.status.ok());
    CHECK(r.scan.non_finite_dropped == 3);
    REQUIRE(r.scan.points.size() == 3);
    REQUIRE(r.scan.point_time_s.size() == 3);
    for (std::size_t k = 0; k < 3; ++k) {
      CHECK(r.scan.points[k].x == static_cast<float>(k + 1));
      CHECK(r.scan.point_time_s[k] == 0.01f * static_cast<float>(2 * k + 1));
    }
  }
  SUBCASE("a float64 coordinate beyond float's range is non-finite") {
    CloudSpec d = MakeCloud({{"x", 0, kF64}, {"y", 8, kF64}, {"z", 16, kF64}}, 24, 2);
    d.Set(0, 0, 1e300);
    d.Set(1, 0, 1.0);
    const ScanResult r = DecodeCloud(Enc::kRos1, EncodeCloud(Enc::kRos1, d));
    REQUIRE(r.status.ok());
    CHECK(r.scan.points.size() == 1);
    CHECK(r.scan.non_finite_dropped == 1);
  }
}

TEST_CASE("PointCloud2 with no points decodes to an empty scan") {
  CloudSpec c = MakeCloud(XyzFloat32(), 12, 0);
  c.height = 0;
  const ScanResult r = DecodeCloud(Enc::kCdrLe, EncodeCloud(Enc::kCdrLe, c));
  REQUIRE(r.status.ok());
  CHECK(r.scan.points.empty());
  CHECK(r.scan.frame_id == "lidar");
}

Status CloudError(const CloudSpec& c, Enc enc = Enc::kRos1, RosScanLimits limits = {}) {
  const ScanResult r = DecodeCloud(enc, EncodeCloud(enc, c), limits);
  REQUIRE_FALSE(r.status.ok());
  return r.status;
}

TEST_CASE("PointCloud2 field layouts that lie or are unsupported are errors naming the field") {
  SUBCASE("an offset past point_step") {
    CloudSpec c = MakeCloud({{"x", 14, kF32}, {"y", 4, kF32}, {"z", 8, kF32}}, 16, 2);
    const Status s = CloudError(c);
    CHECK(s.code() == StatusCode::kDataLoss);
    CHECK(s.message() == "PointCloud2: field 'x' at offset 14 + 4 bytes ends past point_step 16");
  }
  SUBCASE("point_step smaller than the fields") {
    CloudSpec c = MakeCloud(XyzFloat32(), 8, 2);
    CHECK(Contains(CloudError(c), "field 'z' at offset 8 + 4 bytes ends past point_step 8"));
  }
  SUBCASE("a count that makes the field too long, without overflowing") {
    std::vector<Field> fields = XyzFloat32();
    fields.push_back({"intensity", 12, kF64, 0xFFFFFFFFu});
    const Status s = CloudError(MakeCloud(fields, 20, 1));
    CHECK(Contains(s, "field 'intensity' at offset 12 + 34359738360 bytes ends past point_step 20"));
  }
  SUBCASE("an offset near 2^32") {
    const Status s = CloudError(MakeCloud({{"x", 0xFFFFFFFEu, kF32}, {"y", 4, kF32}, {"z", 8, kF32}}, 12, 1));
    CHECK(Contains(s, "field 'x' at offset 4294967294 + 4 bytes"));
  }
  SUBCASE("integer coordinates") {
    const Status s = CloudError(MakeCloud({{"x", 0, kF32}, {"y", 4, kI32}, {"z", 8, kF32}}, 12, 1));
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK(Contains(s, "field 'y' has datatype 5"));
  }
  SUBCASE("a missing coordinate") {
    const Status s = CloudError(MakeCloud({{"x", 0, kF32}, {"y", 4, kF32}}, 12, 1));
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK(Contains(s, "no field 'z'"));
  }
  SUBCASE("an unknown datatype") {
    std::vector<Field> fields = XyzFloat32();
    fields.push_back({"intensity", 12, 9});
    const Status s = CloudError(MakeCloud(fields, 16, 1));
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK(Contains(s, "field 'intensity' has datatype 9"));
  }
  SUBCASE("count 0") {
    std::vector<Field> fields = XyzFloat32();
    fields.push_back({"t", 12, kU32, 0});
    CHECK(Contains(CloudError(MakeCloud(fields, 16, 1)), "field 't' has count 0"));
  }
  SUBCASE("big-endian point data") {
    CloudSpec c = MakeCloud(XyzFloat32(), 12, 1);
    c.is_bigendian = 1;
    const Status s = CloudError(c, Enc::kCdrBe);
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK(Contains(s, "big-endian point data is not supported"));
  }
  SUBCASE("an unused field may be anything") {
    std::vector<Field> fields = XyzFloat32();
    fields.push_back({"junk", 1000, 0, 0});
    const ScanResult r = DecodeCloud(Enc::kRos1, EncodeCloud(Enc::kRos1, MakeCloud(fields, 12, 1)));
    CHECK(r.status.ok());
  }
}

TEST_CASE("PointCloud2 data sizes are checked against width, height, point_step and row_step") {
  SUBCASE("data shorter than row_step x height") {
    CloudSpec c = MakeCloud(XyzFloat32(), 12, 4);
    c.data.resize(47);
    const Status s = CloudError(c);
    CHECK(s.code() == StatusCode::kDataLoss);
    CHECK(Contains(s, "has 47 bytes, but row_step 48 x height 1 = 48"));
  }
  SUBCASE("data longer than row_step x height") {
    CloudSpec c = MakeCloud(XyzFloat32(), 12, 4);
    c.data.resize(60);
    CHECK(Contains(CloudError(c, Enc::kCdrLe), "has 60 bytes, but row_step 48"));
  }
  SUBCASE("width x point_step above row_step") {
    CloudSpec c = MakeCloud(XyzFloat32(), 12, 4);
    c.row_step = 24;
    c.height = 2;
    CHECK(Contains(CloudError(c), "width 4 x point_step 12 = 48 bytes exceeds row_step 24"));
  }
  SUBCASE("a data length announced past the message") {
    std::vector<std::uint8_t> bytes = EncodeCloud(Enc::kRos1, MakeCloud(XyzFloat32(), 12, 4));
    // The data's uint32 length is the 4 bytes before the 48 data bytes and is_dense.
    const std::size_t at = bytes.size() - 1 - 48 - 4;
    bytes[at + 3] = 0x7F;
    const ScanResult r = DecodeCloud(Enc::kRos1, bytes);
    CHECK(r.status.code() == StatusCode::kDataLoss);
    CHECK(Contains(r.status, "data announces"));
  }
  SUBCASE("width x height above max_points: an error before anything is allocated") {
    CloudSpec c = MakeCloud(XyzFloat32(), 12, 0);
    c.width = 0xFFFFFFFFu;
    c.height = 0xFFFFFFFFu;
    c.row_step = 0xFFFFFFFFu;
    const Status s = CloudError(c);
    CHECK(s.code() == StatusCode::kInvalidArgument);
    CHECK(Contains(s, "more than the limit of 2097152"));
    RosScanLimits unlimited;
    unlimited.max_points = std::numeric_limits<std::size_t>::max();
    CHECK(CloudError(c, Enc::kRos1, unlimited).code() == StatusCode::kDataLoss);
    RosScanLimits small;
    small.max_points = 3;
    CloudSpec four = MakeCloud(XyzFloat32(), 12, 4);
    CHECK(CloudError(four, Enc::kCdrBe, small).code() == StatusCode::kInvalidArgument);
    small.max_points = 4;
    CHECK(DecodeCloud(Enc::kCdrBe, EncodeCloud(Enc::kCdrBe, four), small).status.ok());
  }
  SUBCASE("fields announced past the message") {
    Wire w(Enc::kCdrLe);
    w.Header(0, 1, 0, "f").U32(1).U32(1).U32(0x10000000u);
    const ScanResult r = DecodeCloud(Enc::kCdrLe, w.bytes);
    CHECK(r.status.code() == StatusCode::kDataLoss);
    CHECK(Contains(r.status, "fields announces 268435456 elements"));
  }
}

/// Every strict prefix of the message is an error (DataLoss: truncated, or an array count the rest cannot hold),
/// and every decoder survives it.
template <class Decode>
void CheckEveryPrefixFails(const std::vector<std::uint8_t>& bytes, Decode decode) {
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    CAPTURE(n);
    const std::vector<std::uint8_t> prefix(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n));
    const Status s = decode(prefix);
    REQUIRE_FALSE(s.ok());
    REQUIRE(s.code() == StatusCode::kDataLoss);
    REQUIRE((Contains(s, "truncated at byte") || Contains(s, " announces ")));
    DecodeWithEverything(prefix);
  }
  REQUIRE(decode(bytes).ok());
}

TEST_CASE("every truncation of the reference messages is an error, never a crash") {
  const auto cloud = [](Enc enc) {
    return [enc](const std::vector<std::uint8_t>& b) { return DecodeCloud(enc, b).status; };
  };
  const auto livox = [](Enc enc) {
    return [enc](const std::vector<std::uint8_t>& b) { return DecodeLivox(enc, b).status; };
  };
  const auto odom = [](Enc enc) {
    return [enc](const std::vector<std::uint8_t>& b) { return DecodeOdom(enc, b).status; };
  };
  const auto pose = [](Enc enc) {
    return [enc](const std::vector<std::uint8_t>& b) { return DecodePose(enc, b).status; };
  };
  CheckEveryPrefixFails(Vec(kRos1Cloud), cloud(Enc::kRos1));
  CheckEveryPrefixFails(Vec(kCdrLeCloud), cloud(Enc::kCdrLe));
  CheckEveryPrefixFails(Vec(kCdrBeCloud), cloud(Enc::kCdrBe));
  CheckEveryPrefixFails(Vec(kRos1Livox), livox(Enc::kRos1));
  CheckEveryPrefixFails(Vec(kCdrLeLivox), livox(Enc::kCdrLe));
  CheckEveryPrefixFails(Vec(kCdrBeLivox), livox(Enc::kCdrBe));
  CheckEveryPrefixFails(Vec(kRos1Odometry), odom(Enc::kRos1));
  CheckEveryPrefixFails(Vec(kCdrLeOdometry), odom(Enc::kCdrLe));
  CheckEveryPrefixFails(Vec(kCdrBeOdometry), odom(Enc::kCdrBe));
  CheckEveryPrefixFails(Vec(kRos1PoseStamped), pose(Enc::kRos1));
  CheckEveryPrefixFails(Vec(kCdrLePoseStamped), pose(Enc::kCdrLe));
}

TEST_CASE("truncation errors name the field and the byte offset, CDR alignment included") {
  std::vector<std::uint8_t> ros1 = Vec(kRos1Odometry);
  ros1.pop_back();
  CHECK(DecodeOdom(Enc::kRos1, ros1).status.message() ==
        "Odometry: truncated at byte 705 reading twist.covariance[35] (message has 712 bytes)");
  // CDR: header 4 + sec 4 + nanosec 4 + "odom" 4 + 5, "base_link" at 24: 4 + 10 -> 38; the first float64 is
  // aligned to 8 from the payload's start (byte 4): 44.
  std::vector<std::uint8_t> cdr = Vec(kCdrLeOdometry);
  cdr.resize(50);
  CHECK(DecodeOdom(Enc::kCdrLe, cdr).status.message() ==
        "Odometry: truncated at byte 44 reading pose.pose.position.x (message has 50 bytes)");
  // ROS 1: the fields start at byte 37 (seq, stamp, "os_sensor" 4 + 9, height, width, count); x, y, z take
  // 14 bytes each, intensity 22: the fifth field's name at 101..106, its offset at 106.
  std::vector<std::uint8_t> cloud = Vec(kRos1Cloud);
  cloud.resize(106);
  CHECK(DecodeCloud(Enc::kRos1, cloud).status.message() ==
        "PointCloud2: truncated at byte 106 reading fields[4].offset (message has 106 bytes)");
  // CDR: the points start at 48, each 19 bytes padded to 20 (the second's offset_time aligned to 68).
  std::vector<std::uint8_t> livox = Vec(kCdrLeLivox);
  livox.resize(86);
  CHECK(DecodeLivox(Enc::kCdrLe, livox).status.message() ==
        "Livox CustomMsg: truncated at byte 86 reading points[1].line (message has 86 bytes)");
}

TEST_CASE("trailing bytes: none in ROS 1, up to 3 bytes of padding in CDR") {
  std::vector<std::uint8_t> ros1 = Vec(kRos1PoseStamped);
  ros1.push_back(0);
  const PoseResult r = DecodePose(Enc::kRos1, ros1);
  CHECK(r.status.code() == StatusCode::kDataLoss);
  CHECK(Contains(r.status, "1 bytes left after the message's last field at byte 75"));
  std::vector<std::uint8_t> cdr = Vec(kCdrLeCloud);
  for (int pad = 1; pad <= 3; ++pad) {
    cdr.push_back(0);
    CHECK(DecodeCloud(Enc::kCdrLe, cdr).status.ok());
  }
  cdr.push_back(0);
  CHECK(DecodeCloud(Enc::kCdrLe, cdr).status.code() == StatusCode::kDataLoss);
}

TEST_CASE("CDR encapsulations other than CDR_LE and CDR_BE are refused, strings need their NUL") {
  std::vector<std::uint8_t> bytes = Vec(kCdrLePoseStamped);
  bytes[1] = 0x03;
  PoseResult r = DecodePose(Enc::kCdrLe, bytes);
  CHECK(r.status.code() == StatusCode::kInvalidArgument);
  CHECK(Contains(r.status, "CDR encapsulation 0x0003 (PL_CDR, parameter lists) at byte 0 is not supported"));
  bytes[1] = 0x07;  // XCDR2 little-endian
  CHECK(DecodePose(Enc::kCdrLe, bytes).status.code() == StatusCode::kInvalidArgument);
  bytes[0] = 0x01;
  bytes[1] = 0x01;
  CHECK(DecodePose(Enc::kCdrLe, bytes).status.code() == StatusCode::kInvalidArgument);

  // "map" + NUL at bytes 16..19 (sec, nanosec, length 4 after the encapsulation header).
  bytes = Vec(kCdrLePoseStamped);
  REQUIRE(bytes[19] == 0);
  bytes[19] = 'x';
  r = DecodePose(Enc::kCdrLe, bytes);
  CHECK(r.status.code() == StatusCode::kDataLoss);
  CHECK(Contains(r.status, "string header.frame_id of 4 bytes at byte 16 does not end with a NUL"));

  SUBCASE("a CDR string of length 0 is the empty string") {
    Wire w(Enc::kCdrLe);
    w.I32(1).U32(2).U32(0);
    PoseSpec p;
    PutPose(&w, p);
    r = DecodePose(Enc::kCdrLe, w.bytes);
    REQUIRE(r.status.ok());
    CHECK(r.pose.frame_id.empty());
  }
}

TEST_CASE("stamps: sec and nsec combined, nsec of 1e9 or more refused") {
  SUBCASE("ROS 1 uint32 seconds up to 2^32 - 1") {
    CloudSpec c = MakeCloud(XyzFloat32(), 12, 0);
    c.sec = 4294967295LL;
    c.nsec = 999999999;
    const ScanResult r = DecodeCloud(Enc::kRos1, EncodeCloud(Enc::kRos1, c));
    REQUIRE(r.status.ok());
    CHECK(r.scan.stamp_ns == 4294967295999999999LL);
  }
  SUBCASE("ROS 2 negative seconds") {
    const PoseResult r = DecodePose(Enc::kCdrLe, Vec(kCdrLePoseStamped));
    REQUIRE(r.status.ok());
    CHECK(r.pose.stamp_ns == -4000000001LL);
  }
  for (const Enc enc : kAllEncodings) {
    CAPTURE(EncName(enc));
    PoseSpec p;
    p.nsec = 1000000000u;
    const PoseResult r = DecodePose(enc, EncodePoseStamped(enc, p));
    CHECK(r.status.code() == StatusCode::kDataLoss);
    CHECK(Contains(r.status, "is not below 1e9"));
    p.nsec = 999999999u;
    CHECK(DecodePose(enc, EncodePoseStamped(enc, p)).pose.stamp_ns == 100999999999LL);
  }
}

void CheckReferenceLivox(const ScanResult& r) {
  REQUIRE_MESSAGE(r.status.ok(), r.status.ToString());
  CHECK(r.scan.stamp_ns == 1700000003250000000LL);
  CHECK(r.scan.frame_id == "livox_frame");
  CHECK(r.scan.point_time_field == "offset_time");
  REQUIRE(r.scan.points.size() == 2);
  CHECK(r.scan.points[0].x == 1.0f);
  CHECK(r.scan.points[0].y == 2.0f);
  CHECK(r.scan.points[0].z == 3.0f);
  CHECK(r.scan.points[0].intensity == 10.0f);
  CHECK(r.scan.points[1].x == -1.0f);
  CHECK(r.scan.points[1].y == -2.0f);
  CHECK(r.scan.points[1].z == -3.5f);
  CHECK(r.scan.points[1].intensity == 200.0f);
  REQUIRE(r.scan.point_time_s.size() == 2);
  CHECK(r.scan.point_time_s[0] == 0.0f);
  CHECK(r.scan.point_time_s[1] == doctest::Approx(1e-4).epsilon(1e-6));
  CHECK(r.scan.non_finite_dropped == 0);
}

TEST_CASE("Livox CustomMsg written by genpy and by the Foxglove CDR writers") {
  SUBCASE("ROS 1") { CheckReferenceLivox(DecodeLivox(Enc::kRos1, Vec(kRos1Livox))); }
  SUBCASE("CDR_LE") { CheckReferenceLivox(DecodeLivox(Enc::kCdrLe, Vec(kCdrLeLivox))); }
  SUBCASE("CDR_BE") { CheckReferenceLivox(DecodeLivox(Enc::kCdrBe, Vec(kCdrBeLivox))); }
}

TEST_CASE("Livox CustomMsg: times from timebase, non-finite points, point_num, limits") {
  for (const Enc enc : kAllEncodings) {
    CAPTURE(EncName(enc));
    LivoxSpec l;
    l.sec = 100;
    l.nsec = 0;
    l.timebase = 100002000000ull;  // 2 ms after the stamp
    l.points = {{0, 1, 1, 1, 5, 0, 0},
                {1000, std::numeric_limits<float>::quiet_NaN(), 0, 0, 6, 0, 0},
                {3000000, 2, 2, 2, 7, 0, 1}};
    l.point_num = 3;
    ScanResult r = DecodeLivox(enc, EncodeLivox(enc, l));
    REQUIRE_MESSAGE(r.status.ok(), r.status.ToString());
    CHECK(r.scan.non_finite_dropped == 1);
    REQUIRE(r.scan.points.size() == 2);
    CHECK(r.scan.points[1].intensity == 7.0f);
    REQUIRE(r.scan.point_time_s.size() == 2);
    CHECK(r.scan.point_time_s[0] == doctest::Approx(0.002).epsilon(1e-6));
    CHECK(r.scan.point_time_s[1] == doctest::Approx(0.005).epsilon(1e-6));

    l.point_num = 4;
    r = DecodeLivox(enc, EncodeLivox(enc, l));
    CHECK(r.status.code() == StatusCode::kDataLoss);
    CHECK(Contains(r.status, "point_num 4 differs from the 3 points"));

    l.point_num = 3;
    RosScanLimits limits;
    limits.max_points = 2;
    r = DecodeLivox(enc, EncodeLivox(enc, l), limits);
    CHECK(r.status.code() == StatusCode::kInvalidArgument);
    CHECK(Contains(r.status, "more than the limit of 2"));
  }
  SUBCASE("a point count the message cannot hold") {
    LivoxSpec l;
    l.point_num = 0xFFFFFFFFu;
    std::vector<std::uint8_t> bytes = EncodeLivox(Enc::kRos1, l);
    for (int i = 1; i <= 4; ++i) bytes[bytes.size() - static_cast<std::size_t>(i)] = 0xFF;
    const ScanResult r = DecodeLivox(Enc::kRos1, bytes);
    CHECK(r.status.code() == StatusCode::kDataLoss);
    CHECK(Contains(r.status, "points announces 4294967295 elements"));
  }
}

void CheckReferenceOdometry(const PoseResult& r) {
  REQUIRE_MESSAGE(r.status.ok(), r.status.ToString());
  CHECK(r.pose.stamp_ns == 1700000001500000000LL);
  CHECK(r.pose.frame_id == "odom");
  CHECK(r.pose.child_frame_id == "base_link");
  CHECK(r.pose.T_parent_child.translation() == Eigen::Vector3d(1.5, -2.25, 3.0));
  const Eigen::Matrix3d expected = Eigen::AngleAxisd(kPi / 6.0, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  CHECK(r.pose.T_parent_child.linear().isApprox(expected, 1e-12));
}

TEST_CASE("Odometry written by genpy and by the Foxglove CDR writers") {
  SUBCASE("ROS 1") { CheckReferenceOdometry(DecodeOdom(Enc::kRos1, Vec(kRos1Odometry))); }
  SUBCASE("CDR_LE") { CheckReferenceOdometry(DecodeOdom(Enc::kCdrLe, Vec(kCdrLeOdometry))); }
  SUBCASE("CDR_BE") { CheckReferenceOdometry(DecodeOdom(Enc::kCdrBe, Vec(kCdrBeOdometry))); }
}

TEST_CASE("PoseStamped written by genpy and by the Foxglove CDR writer") {
  Eigen::Matrix3d cyclic;  // the quaternion (0.5, 0.5, 0.5, 0.5): x -> y, y -> z, z -> x
  cyclic << 0, 0, 1, 1, 0, 0, 0, 1, 0;
  for (const Enc enc : {Enc::kRos1, Enc::kCdrLe}) {
    CAPTURE(EncName(enc));
    const PoseResult r = DecodePose(enc, enc == Enc::kRos1 ? Vec(kRos1PoseStamped) : Vec(kCdrLePoseStamped));
    REQUIRE_MESSAGE(r.status.ok(), r.status.ToString());
    CHECK(r.pose.frame_id == "map");
    CHECK(r.pose.child_frame_id.empty());
    CHECK(r.pose.T_parent_child.translation() == Eigen::Vector3d(-10.0, 20.5, 0.125));
    CHECK(r.pose.T_parent_child.linear().isApprox(cyclic, 1e-15));
  }
  CHECK(DecodePose(Enc::kRos1, Vec(kRos1PoseStamped)).pose.stamp_ns == 1700000002000000000LL);
}

TEST_CASE("poses: quaternions off unit norm or non-finite values are refused, small errors normalised") {
  for (const Enc enc : kAllEncodings) {
    CAPTURE(EncName(enc));
    PoseSpec p;
    p.orientation[3] = 0.5;  // norm 0.5
    PoseResult r = DecodeOdom(enc, EncodeOdometry(enc, p));
    CHECK(r.status.code() == StatusCode::kDataLoss);
    CHECK(Contains(r.status, "Odometry: pose.pose.orientation at byte"));
    CHECK(Contains(r.status, "has norm 0.5"));
    r = DecodePose(enc, EncodePoseStamped(enc, p));
    CHECK(Contains(r.status, "PoseStamped: pose.orientation at byte"));

    p.orientation[3] = 0.0;  // the all-zero quaternion of an unset pose
    CHECK(DecodeOdom(enc, EncodeOdometry(enc, p)).status.code() == StatusCode::kDataLoss);

    p.orientation[3] = 1.0009;  // within 1e-3: accepted, normalised
    r = DecodeOdom(enc, EncodeOdometry(enc, p));
    REQUIRE(r.status.ok());
    CHECK(r.pose.T_parent_child.linear().isApprox(Eigen::Matrix3d::Identity(), 1e-15));
    p.orientation[3] = 1.0011;
    CHECK_FALSE(DecodeOdom(enc, EncodeOdometry(enc, p)).status.ok());

    p.orientation[3] = 1.0;
    p.position[1] = std::numeric_limits<double>::quiet_NaN();
    r = DecodePose(enc, EncodePoseStamped(enc, p));
    CHECK(r.status.code() == StatusCode::kDataLoss);
    CHECK(Contains(r.status, "pose.position.y at byte"));
    p.position[1] = 0.0;
    p.orientation[0] = std::numeric_limits<double>::infinity();
    CHECK(Contains(DecodePose(enc, EncodePoseStamped(enc, p)).status, "pose.orientation.x at byte"));
  }
  SUBCASE("non-finite covariances and twists are read past") {
    PoseSpec p;
    p.twist[2] = std::numeric_limits<double>::quiet_NaN();
    CHECK(DecodeOdom(Enc::kCdrBe, EncodeOdometry(Enc::kCdrBe, p)).status.ok());
  }
}

TEST_CASE("a failed decode leaves the output as it was") {
  RosScan scan;
  scan.frame_id = "before";
  scan.points.resize(3);
  std::vector<std::uint8_t> bytes = Vec(kRos1Cloud);
  bytes.pop_back();
  CHECK_FALSE(DecodePointCloud2(RosEncoding::kRos1, bytes, {}, &scan).ok());
  CHECK(scan.frame_id == "before");
  CHECK(scan.points.size() == 3);
  RosPose pose;
  pose.frame_id = "before";
  CHECK_FALSE(DecodeOdometry(RosEncoding::kCdr, Bytes(kCdrLeOdometry, 700), &pose).ok());
  CHECK(pose.frame_id == "before");
}

TEST_CASE("corrupted reference messages never crash a decoder") {
  const std::vector<std::vector<std::uint8_t>> messages = {
      Vec(kRos1Cloud), Vec(kCdrLeCloud),    Vec(kCdrBeCloud),     Vec(kRos1Livox),        Vec(kCdrLeLivox),
      Vec(kCdrBeLivox), Vec(kRos1Odometry), Vec(kCdrBeOdometry), Vec(kRos1PoseStamped), Vec(kCdrLePoseStamped)};
  std::mt19937 rng(12345);
  for (const std::vector<std::uint8_t>& original : messages) {
    for (int trial = 0; trial < 300; ++trial) {
      std::vector<std::uint8_t> bytes = original;
      const int flips = 1 + static_cast<int>(rng() % 4);
      for (int f = 0; f < flips; ++f) {
        bytes[rng() % bytes.size()] = static_cast<std::uint8_t>(rng() % 4 == 0 ? 0xFF : rng());
      }
      DecodeWithEverything(bytes);
    }
  }
}

}  // namespace
}  // namespace ros_messages_test
}  // namespace commerge::platform
