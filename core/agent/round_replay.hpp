// SPDX-License-Identifier: BSD-3-Clause
// commerge: replaying a recorded mission round for round (`commerge server --replay`). The recording server
// published a RoundStep (merge_round_t) at every step of every round: how many messages of each robot it had
// taken, and the scans it asked for. A replaying server keeps the robots' messages from the log in arrival order
// and, at each recorded step, hands its ServerLink exactly the messages the recording had taken by then
// (MessagesDue), runs the same step (ServerLink::FollowStep), and compares its own step with the recorded one
// (RoundStepMismatch). Pure functions, no I/O.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "core/agent/messages.hpp"
#include "core/common/span.hpp"

namespace commerge {

enum class RobotMessageKind : std::uint8_t { kKeyframeBatch, kPoseUpdate, kScanChunk };

/// A robot message waiting in a replay's queue: whose and which kind (the queue holds the bytes).
struct QueuedRobotMessage {
  int robot_id = 0;
  RobotMessageKind kind = RobotMessageKind::kKeyframeBatch;
};

/// The messages of `queued` (arrival order) that a recorded step had taken and this server has not: per robot
/// and kind, the first (recorded - taken) of that robot's queued messages of that kind. Robots absent from
/// `recorded` get none. Returns indices into `queued`, ascending (apply them in that order).
std::vector<std::size_t> MessagesDue(Span<const QueuedRobotMessage> queued, Span<const RoundRobotInput> recorded,
                                     Span<const RoundRobotInput> taken);

/// "" when `replayed` is the step `recorded` describes: the same step number and end, the same input per robot
/// (sessions, message counts, robots that left) and the same requests (robot, request id, keyframes, in order).
/// Otherwise the first differences in words, naming the round, step, robot, request and keyframes.
std::string RoundStepMismatch(const RoundStep& recorded, const RoundStep& replayed);

}  // namespace commerge
