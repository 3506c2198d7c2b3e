// SPDX-License-Identifier: BSD-3-Clause
// commerge: what the server received over a mission, by robot and kind, over time: the paper's d_exch (eq.
// exchmetric, the payload of every robot -> server message) and t_comm (eq. commmetric, first to last
// transmission per robot, summed), and the cumulative bytes per robot over time that its figure of exchange data
// per merging round plots (descriptors growing steadily, scans in a few jumps). Fixed memory: the time series
// keeps at most max_samples samples over any mission length (when full, every other one is dropped and the
// sampling interval doubles).
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/status.hpp"

namespace commerge {

/// What a received message brought.
enum class TrafficKind : std::uint8_t {
  kKeyframeRecords = 0,  ///< keyframe batches: descriptors and poses of keyframes new to the server
  kPoseUpdates,          ///< poses a robot's loop closure moved (and the poses before a scan request's chunks)
  kScans,                ///< scan chunks of requested scans
  kResends,              ///< records and chunks the server already held (re-announcements, retransmissions)
  kRobotStatus,          ///< robot_status_t: monitoring, not exchange payload
};
inline constexpr std::size_t kTrafficKinds = 5;
/// "keyframe_records", "pose_updates", "scans", "resends", "robot_status".
const char* TrafficKindName(TrafficKind kind) noexcept;

struct MissionTrafficParams {
  std::size_t max_robots = 8;       ///< robots 0 .. max_robots - 1 (1..64)
  std::size_t max_samples = 2048;   ///< time-series samples kept (16..65536)
  double sample_interval_s = 1.0;   ///< initial spacing of the samples (> 0)
};

Status ValidateMissionTrafficParams(const MissionTrafficParams& params);

class MissionTraffic {
 public:
  /// Parameters outside their ranges are clamped into them (ValidateMissionTrafficParams names them).
  explicit MissionTraffic(const MissionTrafficParams& params = {});

  /// `bytes` from robot `robot` received at `time_s` (any fixed origin; earlier times than the last are taken as
  /// the last). A robot outside 0 .. max_robots - 1 is counted in other_bytes() only.
  void Record(int robot, TrafficKind kind, std::uint64_t bytes, double time_s) noexcept;

  std::size_t max_robots() const noexcept { return max_robots_; }
  std::uint64_t Bytes(int robot, TrafficKind kind) const noexcept;
  std::uint64_t RobotTotal(int robot) const noexcept;
  std::uint64_t KindTotal(TrafficKind kind) const noexcept;
  /// Everything recorded, other_bytes() included.
  std::uint64_t Total() const noexcept;
  std::uint64_t other_bytes() const noexcept { return other_bytes_; }
  /// d_exch: every kind but robot status, over the robots.
  std::uint64_t ExchangedBytes() const noexcept;
  /// First and last exchange message (every kind but robot status) of a robot [s]; -1 when none.
  double first_s(int robot) const noexcept;
  double last_s(int robot) const noexcept;
  /// t_comm: the sum over robots of last_s - first_s.
  double CommSeconds() const noexcept;

  /// The time series: sample i holds time_s(i) (the last message of its interval) and each robot's cumulative
  /// bytes (every kind) after it. The last sample is the state after the last Record.
  std::size_t num_samples() const noexcept { return times_s_.size(); }
  double sample_time_s(std::size_t i) const noexcept { return times_s_[i]; }
  std::uint64_t sample_bytes(std::size_t i, int robot) const noexcept;
  double sample_interval_s() const noexcept { return interval_s_; }

 private:
  void Sample(double time_s);

  std::size_t max_robots_, max_samples_;
  double interval_s_;
  std::vector<std::array<std::uint64_t, kTrafficKinds>> bytes_;  ///< per robot
  std::vector<double> first_s_, last_s_;
  std::uint64_t other_bytes_ = 0;
  double last_time_s_ = -1.0;
  std::vector<double> times_s_;              ///< capacity max_samples
  std::vector<std::uint64_t> sample_bytes_;  ///< max_samples x max_robots, row per sample
  double bucket_start_s_ = 0.0;
};

}  // namespace commerge
