// SPDX-License-Identifier: BSD-3-Clause
// platform/lcm/round_codec: merge_round_t to and from RoundStep, against the generated type's own encoding, and
// every hostile buffer the decoder must refuse.
#include <doctest/doctest.h>

#include <commerge/merge_round_t.hpp>
#include <commerge/merge_result_t.hpp>

#include "platform/lcm/round_codec.hpp"
#include "platform/lcm/status_codec.hpp"
#include "tests/platform/lcm/lcm_test_util.hpp"

namespace commerge::platform {
namespace {

RoundStep MakeStep() {
  RoundStep m;
  m.utime_us = 1763800000123456;
  m.server_session = 1763799999000001;
  m.round = 3;
  m.step = 2;
  m.finished = true;
  for (int r : {0, 1, 4}) {
    RoundRobotInput in;
    in.robot_id = r;
    in.session = 1763799999000100 + r;
    in.keyframe_batches = 17u + static_cast<std::uint32_t>(r);
    in.pose_updates = 3u * static_cast<std::uint32_t>(r);
    in.scan_chunks = 1000u + static_cast<std::uint32_t>(r);
    in.digest = 0xdeadbeefu - static_cast<std::uint32_t>(r);  // above INT32_MAX: travels as its bits
    in.left = r == 4;
    m.robots.push_back(in);
  }
  ScanRequest a;
  a.robot_id = 1;
  a.request_id = 7;
  a.keyframes = {3, 9, 2147483647u};
  ScanRequest b;
  b.robot_id = 4;
  b.request_id = 8;  // an empty request keeps its place
  m.requests = {a, b};
  return m;
}

void CheckSame(const RoundStep& d, const RoundStep& m) {
  CHECK(d.utime_us == m.utime_us);
  CHECK(d.server_session == m.server_session);
  CHECK(d.round == m.round);
  CHECK(d.step == m.step);
  CHECK(d.finished == m.finished);
  CHECK(d.robots == m.robots);
  REQUIRE(d.requests.size() == m.requests.size());
  for (std::size_t i = 0; i < m.requests.size(); ++i) {
    CHECK(d.requests[i].robot_id == m.requests[i].robot_id);
    CHECK(d.requests[i].request_id == m.requests[i].request_id);
    CHECK(d.requests[i].keyframes == m.requests[i].keyframes);
  }
}

// Offsets after the hash: utime 8, server_session 8, round 4, step 2, finished 1 -> num_robots at 31; per robot
// 27 bytes; then num_requests, per request 10 bytes, then num_keyframes.
constexpr std::size_t kNumRobots = 8 + 8 + 8 + 4 + 2 + 1;
std::size_t NumRequests(std::size_t robots) { return kNumRobots + 4 + 27 * robots; }
std::size_t NumKeyframes(std::size_t robots, std::size_t requests) { return NumRequests(robots) + 4 + 10 * requests; }

}  // namespace

TEST_CASE("round codec: a round step round-trips every field, as the generated type reads it") {
  const RoundStep m = MakeStep();
  Buffer b;
  REQUIRE(EncodeRoundStep(m, &b).ok());
  auto d = DecodeRoundStep(S(b));
  REQUIRE(d.ok());
  CheckSame(*d, m);
  // The generated type reads the same values at the layout the .lcm file gives.
  const auto msg = LcmDecode<commerge::merge_round_t>(b);
  CHECK(msg.round == 3);
  CHECK(msg.step == 2);
  CHECK(msg.num_robots == 3);
  CHECK(msg.robot_id == std::vector<std::int16_t>{0, 1, 4});
  CHECK(msg.keyframe_batches == std::vector<std::int32_t>{17, 18, 21});
  CHECK(static_cast<std::uint32_t>(msg.input_digest[0]) == 0xdeadbeefu);
  CHECK(msg.robot_left == std::vector<std::int8_t>{0, 0, 1});
  CHECK(msg.request_keyframes == std::vector<std::int32_t>{3, 0});
  CHECK(msg.keyframe_index == std::vector<std::int32_t>{3, 9, 2147483647});
  CHECK(GetBe(b, kNumRobots, 4) == 3);
  CHECK(GetBe(b, NumRequests(3), 4) == 2);
  CHECK(GetBe(b, NumKeyframes(3, 2), 4) == 3);
  CHECK(b.size() == NumKeyframes(3, 2) + 4 + 3 * 4);
  // An empty step: the header and three zero counts.
  RoundStep empty;
  REQUIRE(EncodeRoundStep(empty, &b).ok());
  CHECK(b.size() == kNumRobots + 12);
  REQUIRE(DecodeRoundStep(S(b)).ok());
}

TEST_CASE("round codec: hostile buffers are refused: truncation, trailing bytes, counts, foreign types") {
  Buffer b;
  REQUIRE(EncodeRoundStep(MakeStep(), &b).ok());
  CheckEveryTruncationRefused(b, DecodeRoundStep, "merge_round_t");
  CheckTrailingBytesRefused(b, DecodeRoundStep, "merge_round_t");
  CheckPatchedCount(b, kNumRobots, 4, 3, 64, "num_robots", DecodeRoundStep);
  CheckPatchedCount(b, NumRequests(3), 4, 2, 64, "num_requests", DecodeRoundStep);
  CheckPatchedCount(b, NumKeyframes(3, 2), 4, 3, 1048576, "num_keyframes", DecodeRoundStep);
  // Another commerge type is refused by its fingerprint, and so is this one by the merge-result decoder.
  MergeResultMessage result;
  Buffer other;
  REQUIRE(EncodeMergeResult(result, &other).ok());
  CheckDataLoss(DecodeRoundStep(S(other)), {"merge_round_t", "fingerprint"});
  CHECK_FALSE(DecodeMergeResult(S(b)).ok());
}

TEST_CASE("round codec: values the layout allows but the record forbids are refused, naming the field") {
  Buffer valid;
  REQUIRE(EncodeRoundStep(MakeStep(), &valid).ok());
  const auto patched = [&](auto edit) {
    auto msg = LcmDecode<commerge::merge_round_t>(valid);
    edit(&msg);
    return LcmEncode(msg);
  };
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->request_keyframes[0] = 4; }))),
                {"request_keyframes[0] = 4", "beyond the 3 keyframes"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->request_keyframes[0] = 2; }))),
                {"2 of the 3 keyframes"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->request_keyframes[0] = -1; }))),
                {"request_keyframes[0]", "negative"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->keyframe_index[1] = -5; }))),
                {"keyframe_index[1]", "negative"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->keyframe_index[1] = 3; }))),
                {"not ascending"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->scan_chunks[2] = -1; }))),
                {"robots[2].scan_chunks", "negative"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->robot_left[0] = 2; }))),
                {"robots[0].robot_left"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->finished = 5; }))), {"finished"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->robot_id[1] = 0; }))),
                {"robot_id[1]", "ascending"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->request_robot_id[0] = 64; }))),
                {"request_robot_id[0]", "outside 0..63"});
  CheckDataLoss(DecodeRoundStep(S(patched([](commerge::merge_round_t* m) { m->step = -1; }))), {"step -1"});
}

TEST_CASE("round codec: the encoder refuses what the decoder would, and accepts exactly the limits") {
  Buffer b = {1, 2, 3};
  RoundStep m = MakeStep();
  m.robots[1].robot_id = 0;
  CheckInvalid(EncodeRoundStep(m, &b), {"robot_id[1]", "ascending"});
  m = MakeStep();
  m.requests[0].keyframes = {4, 4};
  CheckInvalid(EncodeRoundStep(m, &b), {"request 0 keyframe 4", "not ascending"});
  m = MakeStep();
  m.robots[0].scan_chunks = 2147483648u;
  CheckInvalid(EncodeRoundStep(m, &b), {"robots[0].scan_chunks"});
  m = MakeStep();
  m.step = 40000;
  CheckInvalid(EncodeRoundStep(m, &b), {"step 40000"});
  m = MakeStep();
  m.requests.resize(kMaxRoundRequests + 1, m.requests[1]);
  CheckInvalid(EncodeRoundStep(m, &b), {"65 requests", "at most 64"});
  CHECK(b == Buffer{1, 2, 3});  // left as it was
  // Exactly the limits: 64 robots, 64 requests, 2^20 keyframes in all.
  m = RoundStep();
  for (int r = 0; r < 64; ++r) {
    RoundRobotInput in;
    in.robot_id = r;
    m.robots.push_back(in);
  }
  for (int q = 0; q < 64; ++q) {
    ScanRequest req;
    req.robot_id = q;
    for (std::uint32_t k = 0; k < kMaxRoundKeyframes / 64; ++k) req.keyframes.push_back(k);
    m.requests.push_back(std::move(req));
  }
  REQUIRE(EncodeRoundStep(m, &b).ok());
  auto d = DecodeRoundStep(S(b));
  REQUIRE(d.ok());
  CHECK(d->requests.back().keyframes.size() == kMaxRoundKeyframes / 64);
  m.requests[0].keyframes.push_back(kMaxRoundKeyframes);
  CheckInvalid(EncodeRoundStep(m, &b), {"1048577 request keyframes"});
}

}  // namespace commerge::platform
