// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/round_replay.hpp"

#include <algorithm>
#include <array>

namespace commerge {

namespace {

const RoundRobotInput* Find(Span<const RoundRobotInput> robots, int robot_id) {
  for (const RoundRobotInput& r : robots) {
    if (r.robot_id == robot_id) return &r;
  }
  return nullptr;
}

std::uint32_t CountOf(const RoundRobotInput& r, RobotMessageKind kind) {
  switch (kind) {
    case RobotMessageKind::kKeyframeBatch: return r.keyframe_batches;
    case RobotMessageKind::kPoseUpdate: return r.pose_updates;
    case RobotMessageKind::kScanChunk: return r.scan_chunks;
  }
  return 0;
}

std::string KeyframesText(const std::vector<std::uint32_t>& keyframes) {
  constexpr std::size_t kShown = 12;
  std::string text = std::to_string(keyframes.size()) + " keyframes";
  if (keyframes.empty()) return text;
  text += " (";
  for (std::size_t i = 0; i < keyframes.size() && i < kShown; ++i) {
    text += (i > 0 ? " " : "") + std::to_string(keyframes[i]);
  }
  return text + (keyframes.size() > kShown ? " ...)" : ")");
}

std::string HexText(std::uint32_t v) {
  static const char* const kDigits = "0123456789abcdef";
  std::string text(8, '0');
  for (int i = 7; i >= 0; --i, v >>= 4) text[static_cast<std::size_t>(i)] = kDigits[v & 15u];
  return text;
}

std::string InputText(const RoundRobotInput& r) {
  return "session " + std::to_string(r.session) + ", " + std::to_string(r.keyframe_batches) + " keyframe batches, " +
         std::to_string(r.pose_updates) + " pose updates, " + std::to_string(r.scan_chunks) + " scan chunks" +
         " (digest " + HexText(r.digest) + ")" + (r.left ? ", left" : "");
}

}  // namespace

std::vector<std::size_t> MessagesDue(Span<const QueuedRobotMessage> queued, Span<const RoundRobotInput> recorded,
                                     Span<const RoundRobotInput> taken) {
  // Per robot id and kind: how many more of its queued messages the recording had taken.
  std::vector<std::array<std::uint32_t, 3>> wanted(kMaxMergeRobots, {0, 0, 0});
  for (const RoundRobotInput& r : recorded) {
    if (r.robot_id < 0 || static_cast<std::size_t>(r.robot_id) >= kMaxMergeRobots) continue;
    const RoundRobotInput* have = Find(taken, r.robot_id);
    for (RobotMessageKind kind :
         {RobotMessageKind::kKeyframeBatch, RobotMessageKind::kPoseUpdate, RobotMessageKind::kScanChunk}) {
      const std::uint32_t want = CountOf(r, kind), got = have != nullptr ? CountOf(*have, kind) : 0;
      wanted[static_cast<std::size_t>(r.robot_id)][static_cast<std::size_t>(kind)] = want > got ? want - got : 0;
    }
  }
  std::vector<std::size_t> due;
  for (std::size_t i = 0; i < queued.size(); ++i) {
    const QueuedRobotMessage& m = queued[i];
    if (m.robot_id < 0 || static_cast<std::size_t>(m.robot_id) >= kMaxMergeRobots) continue;
    std::uint32_t& left = wanted[static_cast<std::size_t>(m.robot_id)][static_cast<std::size_t>(m.kind)];
    if (left == 0) continue;
    --left;
    due.push_back(i);
  }
  return due;
}

std::string RoundStepMismatch(const RoundStep& recorded, const RoundStep& replayed) {
  std::string text;
  const auto add = [&text](const std::string& part) { text += (text.empty() ? "" : "; ") + part; };
  const std::string where = "round " + std::to_string(recorded.round) + " step " + std::to_string(recorded.step);
  if (replayed.step != recorded.step || replayed.finished != recorded.finished) {
    add("the replay ran step " + std::to_string(replayed.step) + (replayed.finished ? " (round finished)" : "") +
        " where the recording ran step " + std::to_string(recorded.step) +
        (recorded.finished ? " (round finished)" : ""));
  }
  for (const RoundRobotInput& r : recorded.robots) {
    const RoundRobotInput* mine = Find(Span<const RoundRobotInput>(replayed.robots), r.robot_id);
    if (mine == nullptr || !(*mine == r)) {
      add("robot " + std::to_string(r.robot_id) + " input: recorded " + InputText(r) + "; replayed " +
          (mine != nullptr ? InputText(*mine) : std::string("none")));
    }
  }
  const std::size_t n = std::max(recorded.requests.size(), replayed.requests.size());
  for (std::size_t i = 0; i < n; ++i) {
    const ScanRequest* a = i < recorded.requests.size() ? &recorded.requests[i] : nullptr;
    const ScanRequest* b = i < replayed.requests.size() ? &replayed.requests[i] : nullptr;
    if (a != nullptr && b != nullptr && a->robot_id == b->robot_id && a->request_id == b->request_id &&
        a->keyframes == b->keyframes) {
      continue;
    }
    const auto describe = [](const ScanRequest* q) {
      return q == nullptr ? std::string("no request")
                          : "robot " + std::to_string(q->robot_id) + " request " + std::to_string(q->request_id) +
                                " for " + KeyframesText(q->keyframes);
    };
    add("request " + std::to_string(i + 1) + ": recorded " + describe(a) + ", replayed " + describe(b));
  }
  return text.empty() ? text : where + ": " + text;
}

}  // namespace commerge
