// SPDX-License-Identifier: BSD-3-Clause
// commerge: a ledger of the bytes exchanged between the robots and the server (the paper's d_exch, eq.
// exchmetric): every message is counted at its encoded size, per message kind, robot and direction.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/status.hpp"

namespace commerge {

/// What a message carries.
enum class MessageKind : std::uint8_t {
  kKeyframes = 0,  ///< batches of keyframe descriptors and poses
  kPoseUpdates,    ///< corrected keyframe poses after a robot's pose-graph optimisation
  kPolicies,       ///< exchange policies (scan requests) from the server
  kScans,          ///< keyframe scans
  kStatus,         ///< heartbeats and status reports
  kOther,          ///< anything else
};
inline constexpr std::size_t kMessageKindCount = 6;

enum class Direction : std::uint8_t {
  kRobotToServer = 0,
  kServerToRobot,
};
inline constexpr std::size_t kDirectionCount = 2;

/// "keyframes", "pose_updates", "policies", "scans", "status", "other"; "invalid" for a value outside the enum.
const char* MessageKindName(MessageKind kind) noexcept;
/// "robot_to_server", "server_to_robot"; "invalid" for a value outside the enum.
const char* DirectionName(Direction direction) noexcept;

/// Messages and their encoded bytes.
struct ByteCount {
  std::uint64_t messages = 0;
  std::uint64_t bytes = 0;
  ByteCount& operator+=(const ByteCount& other) noexcept {
    messages += other.messages;
    bytes += other.bytes;
    return *this;
  }
};
inline bool operator==(const ByteCount& a, const ByteCount& b) noexcept {
  return a.messages == b.messages && a.bytes == b.bytes;
}
inline bool operator!=(const ByteCount& a, const ByteCount& b) noexcept { return !(a == b); }

struct ByteLedgerParams {
  /// Robots 0 .. max_robots - 1 have their own counters; in [1, kByteLedgerMaxRobots].
  std::size_t max_robots = 8;
};
inline constexpr std::size_t kByteLedgerMaxRobots = 1024;

/// Checks ByteLedgerParams; InvalidArgument naming the field otherwise.
Status ValidateByteLedgerParams(const ByteLedgerParams& params);

/// Counters of (robot, kind, direction). All memory is allocated by the constructor; Record() and the
/// queries never allocate. A message for a robot outside 0 .. max_robots - 1 (negative ids included) is
/// counted in a separate "invalid robot" bucket (per kind and direction); a message whose kind or direction is
/// not a valid enum value is counted as "unclassified". Both are part of Total(): sum over robots of
/// RobotTotal(r) + InvalidRobotTotal() + Unclassified() == Total(). Counters wrap around only past 2^64.
class ByteLedger {
 public:
  /// max_robots outside [1, kByteLedgerMaxRobots] is clamped into it (ValidateByteLedgerParams reports it).
  explicit ByteLedger(const ByteLedgerParams& params = {});

  /// Counts one message of `encoded_bytes` bytes. False when it went to the invalid-robot or unclassified
  /// bucket.
  bool Record(std::int64_t robot, MessageKind kind, Direction direction, std::uint64_t encoded_bytes) noexcept;

  std::size_t max_robots() const noexcept { return max_robots_; }

  /// One counter; zero for a robot, kind or direction out of range.
  ByteCount Get(std::int64_t robot, MessageKind kind, Direction direction) const noexcept;
  /// Per kind, summed over robots (including the invalid-robot bucket): both directions, or one.
  ByteCount KindTotal(MessageKind kind) const noexcept;
  ByteCount KindTotal(MessageKind kind, Direction direction) const noexcept;
  /// Per robot, summed over kinds: both directions, or one. Zero for a robot out of range.
  ByteCount RobotTotal(std::int64_t robot) const noexcept;
  ByteCount RobotTotal(std::int64_t robot, Direction direction) const noexcept;
  /// Per direction, over everything classified (robots, invalid robots).
  ByteCount DirectionTotal(Direction direction) const noexcept;
  /// Messages addressed to or from a robot id out of range: one cell, or all of them.
  ByteCount InvalidRobot(MessageKind kind, Direction direction) const noexcept;
  ByteCount InvalidRobotTotal() const noexcept;
  /// Messages recorded with a kind or direction outside the enums.
  ByteCount Unclassified() const noexcept { return unclassified_; }
  /// Everything recorded.
  ByteCount Total() const noexcept;

  /// Zeroes every counter (keeps max_robots).
  void Reset() noexcept;

 private:
  std::size_t Index(std::size_t row, std::size_t kind, std::size_t direction) const noexcept {
    return (row * kMessageKindCount + kind) * kDirectionCount + direction;
  }
  bool RobotInRange(std::int64_t robot) const noexcept {
    return robot >= 0 && static_cast<std::uint64_t>(robot) < max_robots_;
  }

  std::size_t max_robots_;
  std::vector<ByteCount> cells_;  ///< rows 0 .. max_robots - 1: robots; row max_robots: invalid robots
  ByteCount unclassified_;
};

}  // namespace commerge
