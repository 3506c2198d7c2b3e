// SPDX-License-Identifier: BSD-3-Clause
// The replay's cut (MessagesDue) against a brute-force count of what each recorded step took, and the step
// comparison (RoundStepMismatch) on constructed steps.
#include <doctest/doctest.h>

#include <array>
#include <map>
#include <random>
#include <vector>

#include "core/agent/round_replay.hpp"

namespace commerge {
namespace {

RoundRobotInput Input(int robot, std::uint32_t batches, std::uint32_t poses, std::uint32_t chunks) {
  RoundRobotInput r;
  r.robot_id = robot;
  r.session = 100 + robot;
  r.keyframe_batches = batches;
  r.pose_updates = poses;
  r.scan_chunks = chunks;
  return r;
}

RoundStep Step(std::vector<RoundRobotInput> robots, std::vector<ScanRequest> requests) {
  RoundStep s;
  s.round = 2;
  s.step = 1;
  s.robots = std::move(robots);
  s.requests = std::move(requests);
  return s;
}

ScanRequest Request(int robot, std::int32_t id, std::vector<std::uint32_t> keyframes) {
  ScanRequest q;
  q.robot_id = robot;
  q.request_id = id;
  q.keyframes = std::move(keyframes);
  return q;
}

}  // namespace

TEST_CASE("Round replay: MessagesDue takes, per robot and kind, the first messages the recording had taken") {
  using K = RobotMessageKind;
  const std::vector<QueuedRobotMessage> queued = {{0, K::kKeyframeBatch}, {1, K::kKeyframeBatch}, {0, K::kPoseUpdate},
                                                 {0, K::kKeyframeBatch}, {1, K::kScanChunk},     {0, K::kScanChunk},
                                                 {1, K::kScanChunk},     {0, K::kKeyframeBatch}, {7, K::kScanChunk}};
  // Taken so far: robot 0 one batch; the recording had taken 3 batches, 0 poses, 1 chunk of robot 0 and 1 batch,
  // 1 chunk of robot 1. Robot 7 is not in the record: none of its messages.
  const std::vector<RoundRobotInput> taken = {Input(0, 1, 0, 0), Input(1, 0, 0, 0)};
  const std::vector<RoundRobotInput> recorded = {Input(0, 3, 0, 1), Input(1, 1, 0, 1)};
  const std::vector<std::size_t> due = MessagesDue(Span<const QueuedRobotMessage>(queued),
                                                   Span<const RoundRobotInput>(recorded), Span<const RoundRobotInput>(taken));
  CHECK(due == std::vector<std::size_t>{0, 1, 3, 4, 5});
  // Nothing is due when this server took as much as the recording (or more).
  CHECK(MessagesDue(Span<const QueuedRobotMessage>(queued), Span<const RoundRobotInput>(taken),
                    Span<const RoundRobotInput>(recorded))
            .empty());
}

TEST_CASE("Round replay: MessagesDue agrees with a brute-force replay of random logs") {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    std::vector<QueuedRobotMessage> queued(rng() % 60);
    for (QueuedRobotMessage& m : queued) m = {static_cast<int>(rng() % 3), static_cast<RobotMessageKind>(rng() % 3)};
    std::vector<RoundRobotInput> taken, recorded;
    for (int r = 0; r < 3; ++r) {
      taken.push_back(Input(r, rng() % 3, rng() % 3, rng() % 3));
      recorded.push_back(Input(r, rng() % 25, rng() % 25, rng() % 25));
    }
    const std::vector<std::size_t> due = MessagesDue(Span<const QueuedRobotMessage>(queued),
                                                     Span<const RoundRobotInput>(recorded),
                                                     Span<const RoundRobotInput>(taken));
    // Brute force: walk the queue, counting what this server would have taken after each message.
    std::map<std::pair<int, int>, std::uint32_t> have;
    for (const RoundRobotInput& t : taken) {
      have[{t.robot_id, 0}] = t.keyframe_batches;
      have[{t.robot_id, 1}] = t.pose_updates;
      have[{t.robot_id, 2}] = t.scan_chunks;
    }
    std::vector<std::size_t> expected;
    for (std::size_t i = 0; i < queued.size(); ++i) {
      const RoundRobotInput& want = recorded[static_cast<std::size_t>(queued[i].robot_id)];
      const int kind = static_cast<int>(queued[i].kind);
      const std::uint32_t limit = std::array<std::uint32_t, 3>{want.keyframe_batches, want.pose_updates,
                                                               want.scan_chunks}[static_cast<std::size_t>(kind)];
      std::uint32_t& n = have[{queued[i].robot_id, kind}];
      if (n < limit) {
        ++n;
        expected.push_back(i);
      }
    }
    CAPTURE(trial);
    REQUIRE(due == expected);
  }
}

TEST_CASE("Round replay: RoundStepMismatch is empty for the same step and names each difference") {
  const RoundStep recorded = Step({Input(0, 4, 1, 0), Input(1, 5, 0, 12)}, {Request(1, 3, {2, 4, 6})});
  CHECK(RoundStepMismatch(recorded, recorded).empty());

  RoundStep other = recorded;
  other.requests[0].keyframes = {2, 4, 7};
  std::string text = RoundStepMismatch(recorded, other);
  CHECK(text.find("round 2 step 1") != std::string::npos);
  CHECK(text.find("request 1: recorded robot 1 request 3 for 3 keyframes (2 4 6), replayed robot 1 request 3 for 3 "
                  "keyframes (2 4 7)") != std::string::npos);

  other = recorded;
  other.requests.push_back(Request(0, 4, {9}));
  CHECK(RoundStepMismatch(recorded, other).find("request 2: recorded no request, replayed robot 0 request 4") !=
        std::string::npos);

  other = recorded;
  other.robots[1].scan_chunks = 11;
  text = RoundStepMismatch(recorded, other);
  CHECK(text.find("robot 1 input: recorded session 101, 5 keyframe batches, 0 pose updates, 12 scan chunks (digest "
                  "811c9dc5); replayed session 101, 5 keyframe batches, 0 pose updates, 11 scan chunks") !=
        std::string::npos);

  other = recorded;
  other.robots[0].digest ^= 1u;  // the same counts of other messages
  CHECK(RoundStepMismatch(recorded, other).find("robot 0 input: recorded session 100, 4 keyframe batches, 1 pose "
                                                "updates, 0 scan chunks (digest 811c9dc5); replayed session 100, 4 "
                                                "keyframe batches, 1 pose updates, 0 scan chunks (digest 811c9dc4)") !=
        std::string::npos);
  CHECK(text.find("robot 0") == std::string::npos);

  other = recorded;
  other.finished = true;
  CHECK(RoundStepMismatch(recorded, other).find("the replay ran step 1 (round finished) where the recording ran step 1") !=
        std::string::npos);
  other = recorded;
  other.robots.pop_back();
  CHECK(RoundStepMismatch(recorded, other).find("replayed none") != std::string::npos);
}

}  // namespace commerge
