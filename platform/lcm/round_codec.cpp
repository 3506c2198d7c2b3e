// SPDX-License-Identifier: BSD-3-Clause
#include "platform/lcm/round_codec.hpp"

#include <limits>
#include <string>
#include <tuple>

#include "commerge/merge_round_t.hpp"
#include "platform/lcm/codec_util.hpp"

namespace commerge::platform {

const char* const kRoundChannel = "COMMERGE_ROUND";

namespace {

using namespace lcm_detail;  // NOLINT(google-build-using-namespace): the shared helpers of platform/lcm

static_assert(commerge::merge_round_t::MAX_ROBOT_ID == kMaxRobotId, "");
static_assert(commerge::merge_round_t::MAX_ROBOTS == static_cast<std::int32_t>(kMaxMergeRobots), "");
static_assert(commerge::merge_round_t::MAX_REQUESTS == static_cast<std::int32_t>(kMaxRoundRequests), "");
static_assert(commerge::merge_round_t::MAX_KEYFRAMES == static_cast<std::int32_t>(kMaxRoundKeyframes), "");

constexpr const char* kRoundType = "merge_round_t";

// The rules both sides enforce on the plain struct (`make`: InvalidArgument when encoding, DataLoss when
// decoding).
Status ValidateRoundStep(const RoundStep& m, MakeError make) {
  if (m.round < 0 || m.step < 0 || m.step > std::numeric_limits<std::int16_t>::max()) {
    return make(std::string(kRoundType) + ": round " + std::to_string(m.round) + " step " + std::to_string(m.step) +
                " (round >= 0, step 0..32767)");
  }
  if (m.robots.size() > kMaxMergeRobots || m.requests.size() > kMaxRoundRequests) {
    return make(std::string(kRoundType) + ": " + std::to_string(m.robots.size()) + " robots and " +
                std::to_string(m.requests.size()) + " requests (at most " + std::to_string(kMaxMergeRobots) + " and " +
                std::to_string(kMaxRoundRequests) + ")");
  }
  for (std::size_t i = 0; i < m.robots.size(); ++i) {
    if (Status st = CheckRobotIdAs(make, m.robots[i].robot_id, kRoundType, Indexed("robot_id", i)); !st.ok()) {
      return st;
    }
    if (i > 0 && m.robots[i].robot_id <= m.robots[i - 1].robot_id) {
      return make(std::string(kRoundType) + ": " + Indexed("robot_id", i) + " = " +
                  std::to_string(m.robots[i].robot_id) + " does not follow " +
                  std::to_string(m.robots[i - 1].robot_id) + " (ascending, unique)");
    }
  }
  std::size_t keyframes = 0;
  for (std::size_t i = 0; i < m.requests.size(); ++i) {
    const ScanRequest& q = m.requests[i];
    if (Status st = CheckRobotIdAs(make, q.robot_id, kRoundType, Indexed("request_robot_id", i)); !st.ok()) {
      return st;
    }
    keyframes += q.keyframes.size();
    for (std::size_t k = 0; k < q.keyframes.size(); ++k) {
      if (q.keyframes[k] > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max()) ||
          (k > 0 && q.keyframes[k] <= q.keyframes[k - 1])) {
        return make(std::string(kRoundType) + ": request " + std::to_string(i) + " keyframe " +
                    std::to_string(q.keyframes[k]) + " is beyond int32 or not ascending and unique");
      }
    }
  }
  if (keyframes > kMaxRoundKeyframes) {
    return make(std::string(kRoundType) + ": " + std::to_string(keyframes) + " request keyframes (at most " +
                std::to_string(kMaxRoundKeyframes) + ")");
  }
  return Status::Ok();
}

}  // namespace

Status EncodeRoundStep(const RoundStep& m, std::vector<std::uint8_t>* out) {
  if (Status st = ValidateRoundStep(m, InvalidArgument); !st.ok()) return st;
  commerge::merge_round_t msg{};
  msg.utime = m.utime_us;
  msg.server_session = m.server_session;
  msg.round = m.round;
  msg.step = static_cast<std::int16_t>(m.step);
  msg.finished = m.finished ? 1 : 0;
  msg.num_robots = static_cast<std::int32_t>(m.robots.size());
  for (std::size_t i = 0; i < m.robots.size(); ++i) {
    const RoundRobotInput& r = m.robots[i];
    std::int32_t batches = 0, poses = 0, chunks = 0;
    const std::string at = Indexed("robots", i) + ".";
    for (const auto& [name, value, wire] : {std::make_tuple("keyframe_batches", r.keyframe_batches, &batches),
                                            std::make_tuple("pose_updates", r.pose_updates, &poses),
                                            std::make_tuple("scan_chunks", r.scan_chunks, &chunks)}) {
      if (Status st = ToWireInt32(value, kRoundType, at + name, wire); !st.ok()) return st;
    }
    msg.robot_id.push_back(static_cast<std::int16_t>(r.robot_id));
    msg.robot_session.push_back(r.session);
    msg.keyframe_batches.push_back(batches);
    msg.pose_updates.push_back(poses);
    msg.scan_chunks.push_back(chunks);
    msg.input_digest.push_back(static_cast<std::int32_t>(r.digest));
    msg.robot_left.push_back(r.left ? 1 : 0);
  }
  msg.num_requests = static_cast<std::int32_t>(m.requests.size());
  for (const ScanRequest& q : m.requests) {
    msg.request_robot_id.push_back(static_cast<std::int16_t>(q.robot_id));
    msg.request_id.push_back(q.request_id);
    msg.request_keyframes.push_back(static_cast<std::int32_t>(q.keyframes.size()));
    for (std::uint32_t k : q.keyframes) msg.keyframe_index.push_back(static_cast<std::int32_t>(k));
  }
  msg.num_keyframes = static_cast<std::int32_t>(msg.keyframe_index.size());
  return EncodeInto(msg, out, kRoundType);
}

Result<RoundStep> DecodeRoundStep(Span<const std::uint8_t> bytes) {
  // After the hash: utime 8, server_session 8, round 4, step 2, finished 1, num_robots 4.
  if (Status st = CheckHeader<commerge::merge_round_t>(bytes, 27, kRoundType); !st.ok()) return st;
  WireWalker w(bytes, kRoundType);
  w.Skip(23, "the header");
  // Per robot: robot_id 2, robot_session 8, three int32 counters and the digest 16, robot_left 1.
  const std::int64_t n = w.Count(4, static_cast<std::int64_t>(kMaxMergeRobots), "num_robots", 27);
  w.Skip(27 * n, "the per-robot arrays");
  // Per request: robot id 2, request id 4, keyframe count 4.
  const std::int64_t nq = w.Count(4, static_cast<std::int64_t>(kMaxRoundRequests), "num_requests", 10);
  w.Skip(10 * nq, "the per-request arrays");
  const std::int64_t nk = w.Count(4, static_cast<std::int64_t>(kMaxRoundKeyframes), "num_keyframes", 4);
  w.Skip(4 * nk, "keyframe_index");
  if (Status st = w.Finish(); !st.ok()) return st;
  commerge::merge_round_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, kRoundType); !st.ok()) return st;

  RoundStep m;
  m.utime_us = msg.utime;
  m.server_session = msg.server_session;
  m.round = msg.round;
  m.step = msg.step;
  if (Status st = CheckFlag(msg.finished, DataLoss, kRoundType, "finished"); !st.ok()) return st;
  m.finished = msg.finished == 1;
  m.robots.resize(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < m.robots.size(); ++i) {
    RoundRobotInput& r = m.robots[i];
    r.robot_id = msg.robot_id[i];
    r.session = msg.robot_session[i];
    const std::string at = Indexed("robots", i) + ".";
    for (const auto& [name, wire, value] :
         {std::make_tuple("keyframe_batches", msg.keyframe_batches[i], &r.keyframe_batches),
          std::make_tuple("pose_updates", msg.pose_updates[i], &r.pose_updates),
          std::make_tuple("scan_chunks", msg.scan_chunks[i], &r.scan_chunks)}) {
      if (Status st = FromWireInt32(wire, kRoundType, at + name, value); !st.ok()) return st;
    }
    r.digest = static_cast<std::uint32_t>(msg.input_digest[i]);
    if (Status st = CheckFlag(msg.robot_left[i], DataLoss, kRoundType, at + "robot_left"); !st.ok()) return st;
    r.left = msg.robot_left[i] == 1;
  }
  std::size_t next = 0;
  m.requests.resize(static_cast<std::size_t>(nq));
  for (std::size_t i = 0; i < m.requests.size(); ++i) {
    ScanRequest& q = m.requests[i];
    q.robot_id = msg.request_robot_id[i];
    q.request_id = msg.request_id[i];
    q.server_session = msg.server_session;
    const std::int32_t count = msg.request_keyframes[i];
    if (count < 0 || static_cast<std::size_t>(count) > static_cast<std::size_t>(nk) - next) {
      return DataLoss(std::string(kRoundType) + ": " + Indexed("request_keyframes", i) + " = " +
                      std::to_string(count) + " is negative or beyond the " + std::to_string(nk) + " keyframes");
    }
    for (std::int32_t k = 0; k < count; ++k, ++next) {
      if (msg.keyframe_index[next] < 0) {
        return DataLoss(std::string(kRoundType) + ": " + Indexed("keyframe_index", next) + " = " +
                        std::to_string(msg.keyframe_index[next]) + " is negative");
      }
      q.keyframes.push_back(static_cast<std::uint32_t>(msg.keyframe_index[next]));
    }
  }
  if (next != static_cast<std::size_t>(nk)) {
    return DataLoss(std::string(kRoundType) + ": the requests hold " + std::to_string(next) + " of the " +
                    std::to_string(nk) + " keyframes num_keyframes announces");
  }
  if (Status st = ValidateRoundStep(m, DataLoss); !st.ok()) return st;
  return m;
}

}  // namespace commerge::platform
