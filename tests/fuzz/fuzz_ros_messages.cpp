// SPDX-License-Identifier: BSD-3-Clause
// libFuzzer target for the ROS message decoders (platform/ros/ros_messages.hpp). The first input byte picks the
// decoder: bit 0 the encoding (0 ROS 1, 1 CDR), bits 1-2 the message (0 PointCloud2, 1 Livox CustomMsg,
// 2 Odometry, 3 PoseStamped); the other bits are ignored. The rest of the input is the message. Every message must
// be refused or decoded, never crash (ASan, UBSan). Also checked, for every input:
//   * a refusal is DataLoss or InvalidArgument, and its text starts with the message kind's name;
//   * bounded decoding: no single allocation exceeds kAmplification x the message size + kSlackBytes (every count
//     is checked against the bytes left, and a cloud's size against its data, before anything is allocated);
//   * an accepted scan has finite points only, one time per kept point (or none), at most max_points points; an
//     accepted pose has a finite translation and a proper rotation;
//   * an accepted ROS 1 message is refused without its last byte or with one more byte; an accepted CDR message
//     is refused with 4 more bytes (more than the padding allowed).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "platform/ros/ros_messages.hpp"
#include "tests/fuzz/fuzz_support.hpp"

namespace commerge::fuzz {
namespace {

using platform::RosEncoding;
using platform::RosMessageKind;

constexpr std::size_t kMaxPoints = std::size_t{1} << 16;
// A decoded point takes 16 bytes for at least 4 on the wire (PointCloud2: x, y, z may share one float32) and 4 more
// for its time; a PointField ~48 bytes for at least 13: 8x holds with room.
constexpr std::size_t kAmplification = 8;
constexpr std::size_t kSlackBytes = 4096;

constexpr RosMessageKind kKinds[] = {RosMessageKind::kPointCloud2, RosMessageKind::kLivoxCustom,
                                     RosMessageKind::kOdometry, RosMessageKind::kPoseStamped};

void CheckScan(const platform::RosScan& scan, const char* name) {
  if (scan.points.size() > kMaxPoints) Fail("%s: %zu points, above max_points", name, scan.points.size());
  if (!scan.point_time_s.empty() && scan.point_time_s.size() != scan.points.size()) {
    Fail("%s: %zu point times for %zu points", name, scan.point_time_s.size(), scan.points.size());
  }
  if (!scan.point_time_s.empty() && scan.point_time_field.empty()) Fail("%s: point times without a field", name);
  for (const PointXYZI& p : scan.points) {
    if (!IsFinite(p)) Fail("%s: a non-finite point was kept", name);
  }
}

void CheckPose(const platform::RosPose& pose, const char* name) {
  const Eigen::Matrix3d r = pose.T_parent_child.linear();
  const double orthonormal = (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (!(orthonormal < 1e-9) || !(std::fabs(r.determinant() - 1.0) < 1e-9)) {
    Fail("%s: the decoded rotation is not a rotation", name);
  }
  if (!pose.T_parent_child.translation().allFinite()) Fail("%s: a non-finite translation", name);
}

/// Decodes `message` as `kind`, checks the result, returns whether it was accepted.
bool DecodeChecked(RosEncoding encoding, RosMessageKind kind, Span<const std::uint8_t> message) {
  const char* name = platform::RosMessageKindName(kind);
  platform::RosScanLimits limits;
  limits.max_points = kMaxPoints;
  platform::RosScan scan;
  platform::RosPose pose;
  Status status;
  {
    static const bool hooked = AllocationWatch::Available();
    AllocationWatch watch;
    if (kind == RosMessageKind::kPointCloud2) {
      status = platform::DecodePointCloud2(encoding, message, limits, &scan);
    } else if (kind == RosMessageKind::kLivoxCustom) {
      status = platform::DecodeLivoxCustomMsg(encoding, message, limits, &scan);
    } else if (kind == RosMessageKind::kOdometry) {
      status = platform::DecodeOdometry(encoding, message, &pose);
    } else {
      status = platform::DecodePoseStamped(encoding, message, &pose);
    }
    const std::size_t bound = kAmplification * message.size() + kSlackBytes;
    if (hooked && watch.largest_bytes() > bound) {
      Fail("%s: decoding %zu bytes (%s) allocated one block of %zu bytes, above %zu x the input + %zu", name,
           message.size(), status.ok() ? "accepted" : "refused", watch.largest_bytes(), kAmplification,
           kSlackBytes);
    }
  }
  if (!status.ok()) {
    const bool known = status.code() == StatusCode::kDataLoss || status.code() == StatusCode::kInvalidArgument;
    if (!known || status.message().rfind(std::string(name) + ": ", 0) != 0) {
      Fail("%s: refused %zu bytes with '%s' (expected DataLoss or InvalidArgument naming the message)", name,
           message.size(), status.ToString().c_str());
    }
    return false;
  }
  if (platform::IsScanKind(kind)) {
    CheckScan(scan, name);
  } else {
    CheckPose(pose, name);
  }
  return true;
}

}  // namespace
}  // namespace commerge::fuzz

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace commerge;        // NOLINT(google-build-using-namespace): a fuzz entry point
  using namespace commerge::fuzz;  // NOLINT(google-build-using-namespace)
  if (size == 0) return 0;
  const RosEncoding encoding = (data[0] & 1) != 0 ? RosEncoding::kCdr : RosEncoding::kRos1;
  const platform::RosMessageKind kind = kKinds[(data[0] >> 1) & 3];
  const Span<const std::uint8_t> message(data + 1, size - 1);
  if (!DecodeChecked(encoding, kind, message)) return 0;

  const char* name = platform::RosMessageKindName(kind);
  std::vector<std::uint8_t> longer;
  longer.reserve(message.size() + 4);  // exactly: a doubling push_back would be the largest block of the run
  longer.assign(message.begin(), message.end());
  if (encoding == RosEncoding::kRos1) {
    if (!message.empty() && DecodeChecked(encoding, kind, message.subspan(0, message.size() - 1))) {
      Fail("%s: accepted %zu ROS 1 bytes and also their first %zu (a truncated message)", name, message.size(),
           message.size() - 1);
    }
    longer.push_back(0);
  } else {
    longer.insert(longer.end(), 4, 0);
  }
  if (DecodeChecked(encoding, kind, Span<const std::uint8_t>(longer))) {
    Fail("%s: accepted %zu bytes and also the same followed by %zu zero bytes (trailing bytes)", name,
         message.size(), longer.size() - message.size());
  }
  return 0;
}
