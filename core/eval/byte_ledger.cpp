// SPDX-License-Identifier: BSD-3-Clause
// Byte ledger: fixed table of (robot, kind, direction) counters plus the invalid-robot row.
#include "core/eval/byte_ledger.hpp"

#include <algorithm>
#include <string>

namespace commerge {
namespace {

bool KindValid(MessageKind kind) noexcept { return static_cast<std::size_t>(kind) < kMessageKindCount; }
bool DirectionValid(Direction direction) noexcept { return static_cast<std::size_t>(direction) < kDirectionCount; }

}  // namespace

const char* MessageKindName(MessageKind kind) noexcept {
  switch (kind) {
    case MessageKind::kKeyframes: return "keyframes";
    case MessageKind::kPoseUpdates: return "pose_updates";
    case MessageKind::kPolicies: return "policies";
    case MessageKind::kScans: return "scans";
    case MessageKind::kStatus: return "status";
    case MessageKind::kOther: return "other";
  }
  return "invalid";
}

const char* DirectionName(Direction direction) noexcept {
  switch (direction) {
    case Direction::kRobotToServer: return "robot_to_server";
    case Direction::kServerToRobot: return "server_to_robot";
  }
  return "invalid";
}

Status ValidateByteLedgerParams(const ByteLedgerParams& params) {
  if (params.max_robots < 1 || params.max_robots > kByteLedgerMaxRobots) {
    return InvalidArgument("byte ledger: max_robots must be in [1, " + std::to_string(kByteLedgerMaxRobots) +
                           "], got " + std::to_string(params.max_robots));
  }
  return Status::Ok();
}

ByteLedger::ByteLedger(const ByteLedgerParams& params)
    : max_robots_(std::clamp<std::size_t>(params.max_robots, 1, kByteLedgerMaxRobots)),
      cells_((max_robots_ + 1) * kMessageKindCount * kDirectionCount) {}

bool ByteLedger::Record(std::int64_t robot, MessageKind kind, Direction direction,
                        std::uint64_t encoded_bytes) noexcept {
  if (!KindValid(kind) || !DirectionValid(direction)) {
    ++unclassified_.messages;
    unclassified_.bytes += encoded_bytes;
    return false;
  }
  const bool valid = RobotInRange(robot);
  const std::size_t row = valid ? static_cast<std::size_t>(robot) : max_robots_;
  ByteCount& cell = cells_[Index(row, static_cast<std::size_t>(kind), static_cast<std::size_t>(direction))];
  ++cell.messages;
  cell.bytes += encoded_bytes;
  return valid;
}

ByteCount ByteLedger::Get(std::int64_t robot, MessageKind kind, Direction direction) const noexcept {
  if (!RobotInRange(robot) || !KindValid(kind) || !DirectionValid(direction)) return {};
  return cells_[Index(static_cast<std::size_t>(robot), static_cast<std::size_t>(kind),
                      static_cast<std::size_t>(direction))];
}

ByteCount ByteLedger::KindTotal(MessageKind kind) const noexcept {
  ByteCount sum = KindTotal(kind, Direction::kRobotToServer);
  sum += KindTotal(kind, Direction::kServerToRobot);
  return sum;
}

ByteCount ByteLedger::KindTotal(MessageKind kind, Direction direction) const noexcept {
  ByteCount sum;
  if (!KindValid(kind) || !DirectionValid(direction)) return sum;
  for (std::size_t row = 0; row <= max_robots_; ++row) {
    sum += cells_[Index(row, static_cast<std::size_t>(kind), static_cast<std::size_t>(direction))];
  }
  return sum;
}

ByteCount ByteLedger::RobotTotal(std::int64_t robot) const noexcept {
  ByteCount sum = RobotTotal(robot, Direction::kRobotToServer);
  sum += RobotTotal(robot, Direction::kServerToRobot);
  return sum;
}

ByteCount ByteLedger::RobotTotal(std::int64_t robot, Direction direction) const noexcept {
  ByteCount sum;
  if (!RobotInRange(robot) || !DirectionValid(direction)) return sum;
  for (std::size_t k = 0; k < kMessageKindCount; ++k) {
    sum += cells_[Index(static_cast<std::size_t>(robot), k, static_cast<std::size_t>(direction))];
  }
  return sum;
}

ByteCount ByteLedger::DirectionTotal(Direction direction) const noexcept {
  ByteCount sum;
  if (!DirectionValid(direction)) return sum;
  for (std::size_t row = 0; row <= max_robots_; ++row) {
    for (std::size_t k = 0; k < kMessageKindCount; ++k) {
      sum += cells_[Index(row, k, static_cast<std::size_t>(direction))];
    }
  }
  return sum;
}

ByteCount ByteLedger::InvalidRobot(MessageKind kind, Direction direction) const noexcept {
  if (!KindValid(kind) || !DirectionValid(direction)) return {};
  return cells_[Index(max_robots_, static_cast<std::size_t>(kind), static_cast<std::size_t>(direction))];
}

ByteCount ByteLedger::InvalidRobotTotal() const noexcept {
  ByteCount sum;
  for (std::size_t k = 0; k < kMessageKindCount; ++k) {
    for (std::size_t d = 0; d < kDirectionCount; ++d) sum += cells_[Index(max_robots_, k, d)];
  }
  return sum;
}

ByteCount ByteLedger::Total() const noexcept {
  ByteCount sum = unclassified_;
  for (const ByteCount& c : cells_) sum += c;
  return sum;
}

void ByteLedger::Reset() noexcept {
  std::fill(cells_.begin(), cells_.end(), ByteCount{});
  unclassified_ = ByteCount{};
}

}  // namespace commerge
