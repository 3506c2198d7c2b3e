// SPDX-License-Identifier: BSD-3-Clause
// lidar_scan_t and odometry_t to and from LidarScan and OdometrySample (see the header): walk the buffer with the
// shared bounded helpers of platform/lcm/codec_util.hpp, then run the generated decoder.
#include "platform/lcm/input_codec.hpp"

#include <cmath>
#include <string>
#include <utility>

#include "commerge/lidar_scan_t.hpp"
#include "commerge/odometry_t.hpp"
#include "core/geometry/se3.hpp"
#include "platform/lcm/codec_util.hpp"

namespace commerge::platform {

const char* const kLidarScanChannel = "COMMERGE_LIDAR_SCAN";
const char* const kOdometryChannel = "COMMERGE_ODOMETRY";
const char* const kDefaultInputLcmUrl = "udpm://239.255.76.67:7668?ttl=0&recv_buf_size=16777216";

namespace {

static_assert(commerge::lidar_scan_t::MAX_POINTS == static_cast<std::int32_t>(kMaxLidarScanPoints), "");
static_assert(commerge::lidar_scan_t::MAX_TEXT_BYTES == static_cast<std::int32_t>(kMaxFrameNameBytes), "");
static_assert(commerge::odometry_t::MAX_TEXT_BYTES == static_cast<std::int32_t>(kMaxFrameNameBytes), "");
static_assert(kMaxFrameNameBytes == kMaxStatusTextBytes, "codec_util checks strings against kMaxStatusTextBytes");

constexpr const char* kScanType = "lidar_scan_t";
constexpr const char* kOdometryType = "odometry_t";
constexpr std::size_t kCovarianceEntries = 36;

// Per point on the wire: x, y, z, intensity (4 float32 each, in four parallel arrays).
constexpr std::int64_t kWireBytesPerPoint = 16;

// A quaternion whose norm is off 1 by more than this is not a rotation (the tolerance of every commerge decoder).
constexpr double kUnitQuaternionTolerance = 1e-3;

}  // namespace

using namespace lcm_detail;  // NOLINT(google-build-using-namespace): the shared helpers of platform/lcm

// ---- lidar_scan_t ----

Status EncodeLidarScan(const LidarScan& scan, std::vector<std::uint8_t>* out) {
  const char* type = kScanType;
  if (Status st = CheckText(scan.frame, InvalidArgument, type, "frame"); !st.ok()) return st;
  const std::size_t n = scan.points.size();
  if (n > kMaxLidarScanPoints) {
    return InvalidArgument(std::string(type) + ": points has " + std::to_string(n) + " entries (at most " +
                           std::to_string(kMaxLidarScanPoints) + ")");
  }
  commerge::lidar_scan_t msg{};
  msg.utime = scan.utime_us;
  msg.frame = scan.frame;
  msg.num_points = static_cast<std::int32_t>(n);
  msg.x.resize(n);
  msg.y.resize(n);
  msg.z.resize(n);
  msg.intensity.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const PointXYZI& p = scan.points[i];
    msg.x[i] = p.x;
    msg.y[i] = p.y;
    msg.z[i] = p.z;
    msg.intensity[i] = p.intensity;
  }
  return EncodeInto(msg, out, type);
}

LidarScanDecoder::LidarScanDecoder() : msg_(std::make_unique<commerge::lidar_scan_t>()) {}
LidarScanDecoder::~LidarScanDecoder() = default;

Status LidarScanDecoder::Decode(Span<const std::uint8_t> bytes, LidarScan* out) {
  const char* type = kScanType;
  out->points.clear();
  out->dropped_nonfinite = 0;
  // After the hash: utime 8, the frame's length 4.
  if (Status st = CheckHeader<commerge::lidar_scan_t>(bytes, 12, type); !st.ok()) return st;
  WireWalker w(bytes, type);
  w.Skip(8, "utime");
  w.String("frame");
  const std::int64_t n =
      w.Count(4, static_cast<std::int64_t>(kMaxLidarScanPoints), "num_points", kWireBytesPerPoint);
  w.Skip(kWireBytesPerPoint * n, "x, y, z, intensity");
  if (Status st = w.Finish(); !st.ok()) return st;
  // Bounded now: the arrays hold n <= MAX_POINTS floats each, all present in the buffer. With n = 0 the generated
  // decoder leaves the arrays of an earlier message as they were, so only the first n entries are read.
  if (Status st = DecodeChecked(bytes, msg_.get(), type); !st.ok()) return st;

  out->utime_us = msg_->utime;
  out->frame = msg_->frame;  // reuses out->frame's capacity
  out->points.reserve(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
    const PointXYZI p{msg_->x[i], msg_->y[i], msg_->z[i], msg_->intensity[i]};
    if (IsFinite(p)) {
      out->points.push_back(p);
    } else {
      ++out->dropped_nonfinite;
    }
  }
  return Status::Ok();
}

Result<LidarScan> DecodeLidarScan(Span<const std::uint8_t> bytes) {
  LidarScanDecoder decoder;
  LidarScan scan;
  if (Status st = decoder.Decode(bytes, &scan); !st.ok()) return st;
  return scan;
}

// ---- odometry_t ----

Status EncodeOdometry(const OdometrySample& m, std::vector<std::uint8_t>* out) {
  const char* type = kOdometryType;
  if (Status st = CheckText(m.odom_frame, InvalidArgument, type, "odom_frame"); !st.ok()) return st;
  if (Status st = CheckText(m.sensor_frame, InvalidArgument, type, "sensor_frame"); !st.ok()) return st;
  if (!IsValidRigidTransform(m.T_odom_sensor, kUnitQuaternionTolerance)) {
    return InvalidArgument(std::string(type) + ": T_odom_sensor is not finite or its rotation is not orthonormal");
  }
  commerge::odometry_t msg{};
  msg.utime = m.utime_us;
  msg.odom_frame = m.odom_frame;
  msg.sensor_frame = m.sensor_frame;
  const Eigen::Vector3d t = m.T_odom_sensor.translation();
  const Eigen::Quaterniond q = Eigen::Quaterniond(m.T_odom_sensor.linear()).normalized();
  for (int i = 0; i < 3; ++i) msg.position[i] = t[i];
  msg.orientation[0] = q.w();
  msg.orientation[1] = q.x();
  msg.orientation[2] = q.y();
  msg.orientation[3] = q.z();
  for (std::size_t i = 0; i < kCovarianceEntries; ++i) {
    if (!std::isfinite(m.covariance[i])) {
      return InvalidArgument(std::string(type) + ": covariance[" + std::to_string(i) + "] is not finite");
    }
    msg.covariance[i / 6][i % 6] = m.covariance[i];
  }
  return EncodeInto(msg, out, type);
}

Result<OdometrySample> DecodeOdometry(Span<const std::uint8_t> bytes) {
  const char* type = kOdometryType;
  // After the hash: utime 8, the odom_frame's length 4.
  if (Status st = CheckHeader<commerge::odometry_t>(bytes, 12, type); !st.ok()) return st;
  WireWalker w(bytes, type);
  w.Skip(8, "utime");
  w.String("odom_frame");
  w.String("sensor_frame");
  w.Skip(8 * (3 + 4 + 36), "position, orientation, covariance");
  if (Status st = w.Finish(); !st.ok()) return st;
  commerge::odometry_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;

  const Eigen::Vector3d t(msg.position[0], msg.position[1], msg.position[2]);
  if (!t.allFinite()) return DataLoss(std::string(type) + ": position is not finite");
  const Eigen::Vector4d q(msg.orientation[0], msg.orientation[1], msg.orientation[2], msg.orientation[3]);
  if (!q.allFinite()) return DataLoss(std::string(type) + ": orientation is not finite");
  if (std::abs(q.norm() - 1.0) > kUnitQuaternionTolerance) {
    return DataLoss(std::string(type) + ": orientation has norm " + std::to_string(q.norm()) +
                    ", not 1 +- 0.001 (not a unit quaternion)");
  }
  OdometrySample m;
  m.utime_us = msg.utime;
  m.odom_frame = std::move(msg.odom_frame);
  m.sensor_frame = std::move(msg.sensor_frame);
  m.T_odom_sensor = Eigen::Isometry3d::Identity();
  m.T_odom_sensor.linear() = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  m.T_odom_sensor.translation() = t;
  for (std::size_t i = 0; i < kCovarianceEntries; ++i) {
    const double c = msg.covariance[i / 6][i % 6];
    if (!std::isfinite(c)) {
      return DataLoss(std::string(type) + ": covariance[" + std::to_string(i) + "] is not finite");
    }
    m.covariance[i] = c;
  }
  return m;
}

}  // namespace commerge::platform
