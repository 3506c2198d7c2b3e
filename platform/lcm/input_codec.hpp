// SPDX-License-Identifier: BSD-3-Clause
// The live input of `commerge robot` (core/agent/live_input.hpp: LidarScan, OdometrySample) to and from its LCM
// encoding (lcmtypes/lidar_scan_t, odometry_t). Same guarantees as platform/lcm/message_codec.hpp: the bytes are
// exactly what lcm.publish() puts on the wire, and decoding is bounded (fingerprint first, then num_points against
// MAX_POINTS and the buffer, and every string length against kMaxFrameNameBytes and the buffer, before anything
// is allocated).
//
// Channels: an odometry stack runs on each robot's own board and publishes on a board-local LCM URL (ttl=0),
// separate from the radio bus the robots and the server share; scans (0.5-4 MiB each at 10 Hz) must never reach
// the radio, and multicast traffic reaches every host of a group whatever the channel name. The defaults below
// are therefore the same on every robot (one configuration for every board's odometry stack); `commerge robot`
// and `commerge feed` take --scan-channel / --odometry-channel to match a stack's own names, or to keep several
// robots apart when they share one host (simulation, tests: e.g. COMMERGE_LIDAR_SCAN_3).
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "core/agent/live_input.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {
class lidar_scan_t;  // generated (lcmtypes/lidar_scan_t.lcm)
}  // namespace commerge

namespace commerge::platform {

/// Default channel names (lcm-spy shows them).
extern const char* const kLidarScanChannel;  ///< "COMMERGE_LIDAR_SCAN": lidar_scan_t, odometry stack -> robot
extern const char* const kOdometryChannel;   ///< "COMMERGE_ODOMETRY": odometry_t, odometry stack -> robot
/// Default LCM URL of the live input: "udpm://239.255.76.67:7668?ttl=0&recv_buf_size=16777216". LCM's default
/// group on the next port (LCM's own default, port 7667, may be the radio bus of a deployment), ttl=0 so nothing
/// leaves the board, and a 16 MiB receive buffer: a scan is many UDP datagrams, and with the kernel's default
/// buffer (about 200 KiB) whole scans are lost. The kernel caps the buffer at net.core.rmem_max (LCM then warns).
extern const char* const kDefaultInputLcmUrl;

/// Encoders replace `*out` with the message's wire bytes (on error it is left as it was). Errors (InvalidArgument
/// naming the field): more than kMaxLidarScanPoints points; a frame name longer than kMaxFrameNameBytes or
/// holding a NUL; a T_odom_sensor that is not finite or whose rotation is not orthonormal within 1e-3; a
/// non-finite covariance entry. Non-finite points are encoded as they are (a driver's "no return"); the decoder
/// drops them.
Status EncodeLidarScan(const LidarScan& scan, std::vector<std::uint8_t>* out);
Status EncodeOdometry(const OdometrySample& sample, std::vector<std::uint8_t>* out);

/// Decoders. Errors (DataLoss naming what is wrong): a foreign fingerprint (checked first); truncated or trailing
/// bytes; num_points outside [0, MAX_POINTS] or beyond the buffer; a string length outside 1..257, beyond the
/// buffer, or not ending at the string's NUL; for odometry a non-finite position or covariance entry, and an
/// orientation that is not finite or whose norm is off 1 by more than 1e-3 (it is renormalised otherwise). A scan
/// with non-finite points is not refused: those points are dropped and counted in LidarScan::dropped_nonfinite.
Result<LidarScan> DecodeLidarScan(Span<const std::uint8_t> bytes);
Result<OdometrySample> DecodeOdometry(Span<const std::uint8_t> bytes);

/// DecodeLidarScan for a receive loop: the generated message's arrays and `out->points` keep their capacity
/// between calls, so decoding scans of similar size allocates nothing after the first. On error `*out` holds no
/// points.
class LidarScanDecoder {
 public:
  LidarScanDecoder();
  ~LidarScanDecoder();
  LidarScanDecoder(const LidarScanDecoder&) = delete;
  LidarScanDecoder& operator=(const LidarScanDecoder&) = delete;

  Status Decode(Span<const std::uint8_t> bytes, LidarScan* out);

 private:
  std::unique_ptr<commerge::lidar_scan_t> msg_;
};

}  // namespace commerge::platform
