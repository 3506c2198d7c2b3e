// SPDX-License-Identifier: BSD-3-Clause
// platform/lcm/status_codec: transfer_status_t, merge_result_t, robot_status_t and server_status_t to and from
// LCM wire bytes. Expectations come from the generated LCM types (their own encode of a struct filled by hand,
// and fingerprints) and from fields read at hand-computed big-endian offsets; hostile buffers (foreign types,
// every truncation, trailing bytes, counts and string lengths patched beyond MAX and beyond the buffer) are
// refused with DataLoss naming what is wrong; encoders name the field they refuse.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <commerge/merge_result_t.hpp>
#include <commerge/robot_status_t.hpp>
#include <commerge/server_status_t.hpp>
#include <commerge/transfer_status_t.hpp>

#include "core/common/float_limits.hpp"
#include "core/agent/messages.hpp"
#include "platform/lcm/message_codec.hpp"
#include "platform/lcm/status_codec.hpp"
#include "tests/platform/lcm/lcm_test_util.hpp"

namespace commerge::platform {
namespace {

constexpr std::int32_t kInt32Max = std::numeric_limits<std::int32_t>::max();
constexpr std::uint32_t kBeyondInt32 = 0x80000000u;

std::string Text(std::size_t n, char c = 'a') { return std::string(n, c); }

// ---- transfer_status_t ----

TransferStatus MakeTransferStatus() {
  TransferStatus m;
  m.utime_us = 1763800000111111;
  m.robot_id = 9;
  m.server_session = 1763799990000001;
  m.robot_session = 1763799999000009;
  m.keyframes_contiguous = 100;
  m.keyframes_seen = 250;
  m.gaps = {{100, 120}, {130, 131}, {200, 249}};
  m.gaps_truncated = true;
  m.pose_sequences = {3, 4, 7, kInt32Max};
  m.request_id = 17;
  m.request_complete = false;
  m.missing = {{101, 0, 0}, {105, 2, 3}, {105, 7, 1}, {static_cast<std::uint32_t>(kInt32Max), 32766, 1}};
  return m;
}

// The generated type filled by hand from the plain struct.
commerge::transfer_status_t ToLcm(const TransferStatus& m) {
  commerge::transfer_status_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.server_session = m.server_session;
  msg.robot_session = m.robot_session;
  msg.keyframes_contiguous = static_cast<std::int32_t>(m.keyframes_contiguous);
  msg.keyframes_seen = static_cast<std::int32_t>(m.keyframes_seen);
  msg.num_gaps = static_cast<std::int32_t>(m.gaps.size());
  for (const KeyframeGap& g : m.gaps) {
    msg.gap_begin.push_back(static_cast<std::int32_t>(g.begin));
    msg.gap_end.push_back(static_cast<std::int32_t>(g.end));
  }
  msg.gaps_truncated = m.gaps_truncated ? 1 : 0;
  msg.num_pose_acks = static_cast<std::int32_t>(m.pose_sequences.size());
  msg.pose_sequences = m.pose_sequences;
  msg.request_id = m.request_id;
  msg.request_complete = m.request_complete ? 1 : 0;
  msg.num_missing = static_cast<std::int32_t>(m.missing.size());
  for (const MissingChunkRange& r : m.missing) {
    msg.missing_keyframe.push_back(static_cast<std::int32_t>(r.keyframe));
    msg.missing_first_chunk.push_back(static_cast<std::int16_t>(r.first_chunk));
    msg.missing_count.push_back(static_cast<std::int16_t>(r.count));
  }
  return msg;
}

void CheckSame(const TransferStatus& d, const TransferStatus& m) {
  CHECK(d.utime_us == m.utime_us);
  CHECK(d.robot_id == m.robot_id);
  CHECK(d.server_session == m.server_session);
  CHECK(d.robot_session == m.robot_session);
  CHECK(d.keyframes_contiguous == m.keyframes_contiguous);
  CHECK(d.keyframes_seen == m.keyframes_seen);
  REQUIRE(d.gaps.size() == m.gaps.size());
  for (std::size_t i = 0; i < m.gaps.size(); ++i) {
    CHECK(d.gaps[i].begin == m.gaps[i].begin);
    CHECK(d.gaps[i].end == m.gaps[i].end);
  }
  CHECK(d.gaps_truncated == m.gaps_truncated);
  CHECK(d.pose_sequences == m.pose_sequences);
  CHECK(d.request_id == m.request_id);
  CHECK(d.request_complete == m.request_complete);
  REQUIRE(d.missing.size() == m.missing.size());
  for (std::size_t i = 0; i < m.missing.size(); ++i) {
    CHECK(d.missing[i].keyframe == m.missing[i].keyframe);
    CHECK(d.missing[i].first_chunk == m.missing[i].first_chunk);
    CHECK(d.missing[i].count == m.missing[i].count);
  }
}

// Offsets (8-byte fingerprint first): the fixed header ends at 42 with num_gaps.
constexpr std::size_t kTransferNumGaps = 8 + 8 + 2 + 8 + 8 + 4 + 4;  // 42
std::size_t TransferNumPoseAcks(std::size_t gaps) { return kTransferNumGaps + 4 + 8 * gaps + 1; }
std::size_t TransferNumMissing(std::size_t gaps, std::size_t acks) { return TransferNumPoseAcks(gaps) + 4 + 4 * acks + 4 + 1; }

// ---- merge_result_t ----

MergePairOutcome MakePair(int alpha, int beta, bool success, std::string verdict, const Eigen::Isometry3d& T,
                          std::uint32_t base, float overlap, bool consistent) {
  MergePairOutcome p;
  p.alpha = alpha;
  p.beta = beta;
  p.success = success;
  p.verdict = std::move(verdict);
  p.T_alpha_beta = T;
  p.loops_stage_a = base + 1;
  p.loops_stage_c = base + 2;
  p.alpha_scans = base + 3;
  p.beta_scans = base + 4;
  p.overlap = overlap;
  p.inliers = base * 100 + 5;
  p.consistent = consistent;
  p.stage_b = {static_cast<std::uint8_t>(base % 4), 0.25f, base + 6, base + 7};
  p.stage_c = {static_cast<std::uint8_t>((base + 1) % 3), base % 2 == 0 ? 0.0f : 1.0f, base + 8, base + 9};
  p.stage_c_loops_dropped = base + 10;
  return p;
}

MergeResultMessage MakeMergeResult() {
  MergeResultMessage m;
  m.utime_us = 1763800000222222;
  m.server_session = 1763799990000001;
  m.round = 3;
  m.robot_ids = {0, 2, 5, 63};
  m.in_world = {1, 1, 0, 1};
  m.keyframes = {0, 1, 12345, static_cast<std::uint32_t>(kInt32Max)};
  m.T_world_map = {Eigen::Isometry3d::Identity(),
                   Pose(0.7, Eigen::Vector3d(0.3, -1.0, 0.2), Eigen::Vector3d(12.5, -3.25, 0.75)),
                   Eigen::Isometry3d::Identity(),
                   Pose(3.14159, Eigen::Vector3d(0.2, -1.0, 0.3), Eigen::Vector3d(-812.375, 63.3, -0.001))};
  m.pairs = {
      MakePair(0, 2, true, "success", Pose(0.25, Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(3.0, 4.0, 0.1)), 10,
               0.83f, true),
      MakePair(0, 5, false, "stage A: 2 sequential loops (needs 3)",
               Pose(2.9, Eigen::Vector3d(1, 1, 0), Eigen::Vector3d(-150.0, 7.5, 1.0)), 0, 0.0f, false),
      MakePair(2, 5, false, "", Eigen::Isometry3d::Identity(), 0, 0.125f, false),
      MakePair(5, 63, true, Text(kMaxStatusTextBytes, 'v'),
               Pose(1.0, Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0.5, 0.5, 0.5)),
               static_cast<std::uint32_t>(kInt32Max) / 100 - 1, 1.0f, true)};
  m.pairs[3].loops_stage_a = static_cast<std::uint32_t>(kInt32Max);
  m.pairs[3].stage_c.nodes = static_cast<std::uint32_t>(kInt32Max);
  return m;
}

// A result whose transforms are exact in float (identity and half turns, whose quaternions are unit axes), so
// the generated message can be filled by hand value for value.
Eigen::Isometry3d Exact(const Eigen::Vector3d& diagonal, const Eigen::Vector3d& t) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = diagonal.asDiagonal();
  T.translation() = t;
  return T;
}

MergeResultMessage MakeExactMergeResult() {
  MergeResultMessage m;
  m.utime_us = 1763800000333333;
  m.server_session = -2;
  m.round = 1;
  m.robot_ids = {0, 2, 5};
  m.in_world = {1, 1, 0};
  m.keyframes = {200, 17, 0};
  m.T_world_map = {Eigen::Isometry3d::Identity(), Exact({1, 1, 1}, {1.5, -2.25, 100.125}),
                   Exact({1, -1, -1}, {0.5, 0.25, -8.0})};
  m.pairs = {MakePair(0, 2, true, "success", Exact({-1, -1, 1}, {-4.0, 2.5, 0.0}), 7, 0.75f, true),
             MakePair(2, 5, false, "stage A: too few loops", Exact({-1, 1, -1}, {0.0, 0.0, 1.0}), 1, 0.0f, false)};
  return m;
}

commerge::merge_result_t ExactMergeResultLcm() {
  commerge::merge_result_t msg{};
  msg.utime = 1763800000333333;
  msg.server_session = -2;
  msg.round = 1;
  msg.num_robots = 3;
  msg.robot_id = {0, 2, 5};
  msg.in_world = {1, 1, 0};
  msg.translation_m = {{0.0f, 0.0f, 0.0f}, {1.5f, -2.25f, 100.125f}, {0.5f, 0.25f, -8.0f}};
  msg.quaternion = {{1.0f, 0.0f, 0.0f, 0.0f}, {1.0f, 0.0f, 0.0f, 0.0f}, {0.0f, 1.0f, 0.0f, 0.0f}};
  msg.keyframes = {200, 17, 0};
  msg.num_pairs = 2;
  msg.alpha = {0, 2};
  msg.beta = {2, 5};
  msg.success = {1, 0};
  msg.verdict = {"success", "stage A: too few loops"};
  msg.pair_translation_m = {{-4.0f, 2.5f, 0.0f}, {0.0f, 0.0f, 1.0f}};
  msg.pair_quaternion = {{0.0f, 0.0f, 0.0f, 1.0f}, {0.0f, 0.0f, 1.0f, 0.0f}};
  msg.loops_stage_a = {8, 2};
  msg.loops_stage_c = {9, 3};
  msg.alpha_scans = {10, 4};
  msg.beta_scans = {11, 5};
  msg.overlap = {0.75f, 0.0f};
  msg.inliers = {705, 105};
  msg.consistent = {1, 0};
  // MakePair's solver stages for base 7 and 1.
  msg.stage_b_status = {3, 1};
  msg.stage_b_gap = {0.25f, 0.25f};
  msg.stage_b_nodes = {13, 7};
  msg.stage_b_lp_solves = {14, 8};
  msg.stage_c_status = {2, 2};
  msg.stage_c_gap = {1.0f, 1.0f};
  msg.stage_c_nodes = {15, 9};
  msg.stage_c_lp_solves = {16, 10};
  msg.stage_c_loops_dropped = {17, 11};
  return msg;
}

void CheckSame(const MergeResultMessage& d, const MergeResultMessage& m) {
  CHECK(d.utime_us == m.utime_us);
  CHECK(d.server_session == m.server_session);
  CHECK(d.round == m.round);
  CHECK(d.robot_ids == m.robot_ids);
  CHECK(d.in_world == m.in_world);
  CHECK(d.keyframes == m.keyframes);
  REQUIRE(d.T_world_map.size() == m.T_world_map.size());
  for (std::size_t i = 0; i < m.T_world_map.size(); ++i) {
    INFO("robot ", i);
    CHECK(NearPose(d.T_world_map[i], m.T_world_map[i]));
  }
  REQUIRE(d.pairs.size() == m.pairs.size());
  for (std::size_t i = 0; i < m.pairs.size(); ++i) {
    INFO("pair ", i);
    const MergePairOutcome &a = d.pairs[i], &b = m.pairs[i];
    CHECK(a.alpha == b.alpha);
    CHECK(a.beta == b.beta);
    CHECK(a.success == b.success);
    CHECK(a.verdict == b.verdict);
    CHECK(NearPose(a.T_alpha_beta, b.T_alpha_beta));
    CHECK(a.loops_stage_a == b.loops_stage_a);
    CHECK(a.loops_stage_c == b.loops_stage_c);
    CHECK(a.alpha_scans == b.alpha_scans);
    CHECK(a.beta_scans == b.beta_scans);
    CHECK(a.overlap == b.overlap);
    CHECK(a.inliers == b.inliers);
    CHECK(a.consistent == b.consistent);
    for (const auto& [x, y] : {std::make_pair(&a.stage_b, &b.stage_b), std::make_pair(&a.stage_c, &b.stage_c)}) {
      CHECK(x->status == y->status);
      CHECK(x->gap == y->gap);
      CHECK(x->nodes == y->nodes);
      CHECK(x->lp_solves == y->lp_solves);
    }
    CHECK(a.stage_c_loops_dropped == b.stage_c_loops_dropped);
  }
}

// Offsets: utime 8, server_session 8, round 4, then num_robots; per robot 2 + 1 + 12 + 16 bytes.
constexpr std::size_t kMergeNumRobots = 8 + 8 + 8 + 4;  // 28
std::size_t MergeNumPairs(std::size_t robots) { return kMergeNumRobots + 4 + 35 * robots; }
std::size_t MergeFirstVerdict(std::size_t robots, std::size_t pairs) { return MergeNumPairs(robots) + 4 + 5 * pairs; }

// ---- robot_status_t / server_status_t ----

ModuleMemory Module(std::string name, std::int64_t budget, std::int64_t used, std::int64_t high_water) {
  ModuleMemory m;
  m.name = std::move(name);
  m.budget_bytes = budget;
  m.used_bytes = used;
  m.high_water_bytes = high_water;
  return m;
}

// The module arrays of robot_status_t / server_status_t, filled by hand.
template <typename LcmStatus>
void FillModules(const std::vector<ModuleMemory>& modules, LcmStatus* msg) {
  msg->num_modules = static_cast<std::int16_t>(modules.size());
  for (const ModuleMemory& mm : modules) {
    msg->module_name.push_back(mm.name);
    msg->module_budget_bytes.push_back(mm.budget_bytes);
    msg->module_used_bytes.push_back(mm.used_bytes);
    msg->module_high_water_bytes.push_back(mm.high_water_bytes);
  }
}

RobotStatus MakeRobotStatus() {
  RobotStatus m;
  m.utime_us = 1763800000444444;
  m.robot_id = 6;
  m.session = 1763799999000006;
  m.peak_rss_bytes = 300LL << 20;
  m.budget_total_bytes = 275LL << 20;
  m.budget_limit_bytes = 2650LL << 20;
  m.modules = {Module("scan_store", 160LL << 20, 12345678, 23456789), Module("descriptor_db", 10LL << 20, 4096, 8192)};
  m.keyframes = 1200;
  m.keyframes_acked = 1100;
  m.queued_keyframes = 100;
  m.queued_poses = 7;
  m.queued_chunks = static_cast<std::uint32_t>(kInt32Max);
  m.bytes_sent = 98765432101LL;
  m.bytes_resent = 12345;
  m.request_id = -1;
  m.state = "sending scans";
  return m;
}

commerge::robot_status_t ToLcm(const RobotStatus& m) {
  commerge::robot_status_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.session = m.session;
  msg.peak_rss_bytes = m.peak_rss_bytes;
  msg.budget_total_bytes = m.budget_total_bytes;
  msg.budget_limit_bytes = m.budget_limit_bytes;
  FillModules(m.modules, &msg);
  msg.keyframes = static_cast<std::int32_t>(m.keyframes);
  msg.keyframes_acked = static_cast<std::int32_t>(m.keyframes_acked);
  msg.queued_keyframes = static_cast<std::int32_t>(m.queued_keyframes);
  msg.queued_poses = static_cast<std::int32_t>(m.queued_poses);
  msg.queued_chunks = static_cast<std::int32_t>(m.queued_chunks);
  msg.bytes_sent = m.bytes_sent;
  msg.bytes_resent = m.bytes_resent;
  msg.request_id = m.request_id;
  msg.state = m.state;
  return msg;
}

void CheckSameModules(const std::vector<ModuleMemory>& d, const std::vector<ModuleMemory>& m) {
  REQUIRE(d.size() == m.size());
  for (std::size_t i = 0; i < m.size(); ++i) {
    CHECK(d[i].name == m[i].name);
    CHECK(d[i].budget_bytes == m[i].budget_bytes);
    CHECK(d[i].used_bytes == m[i].used_bytes);
    CHECK(d[i].high_water_bytes == m[i].high_water_bytes);
  }
}

void CheckSame(const RobotStatus& d, const RobotStatus& m) {
  CHECK(d.utime_us == m.utime_us);
  CHECK(d.robot_id == m.robot_id);
  CHECK(d.session == m.session);
  CHECK(d.peak_rss_bytes == m.peak_rss_bytes);
  CHECK(d.budget_total_bytes == m.budget_total_bytes);
  CHECK(d.budget_limit_bytes == m.budget_limit_bytes);
  CheckSameModules(d.modules, m.modules);
  CHECK(d.keyframes == m.keyframes);
  CHECK(d.keyframes_acked == m.keyframes_acked);
  CHECK(d.queued_keyframes == m.queued_keyframes);
  CHECK(d.queued_poses == m.queued_poses);
  CHECK(d.queued_chunks == m.queued_chunks);
  CHECK(d.bytes_sent == m.bytes_sent);
  CHECK(d.bytes_resent == m.bytes_resent);
  CHECK(d.request_id == m.request_id);
  CHECK(d.state == m.state);
}

ServerStatus MakeServerStatus() {
  ServerStatus m;
  m.utime_us = 1763800000555555;
  m.session = 1763799990000001;
  m.peak_rss_bytes = 900LL << 20;
  m.budget_total_bytes = 800LL << 20;
  m.budget_limit_bytes = 4000LL << 20;
  m.modules = {Module("keyframe_db", 100LL << 20, 5000000, 6000000), Module("scan_store", 500LL << 20, 0, 7),
               Module("", 0, 0, 0)};
  m.round = 2;
  m.state = "waiting for scans";
  m.bytes_received = 123456789012LL;
  m.messages_rejected = 3;
  m.last_rejection = "pose_update_t: robot_id 70 is outside 0..63";
  m.robot_ids = {0, 1, 3};
  m.keyframes = {500, 420, 0};
  m.scans = {40, 38, 0};
  m.chunks_missing = {0, static_cast<std::uint32_t>(kInt32Max), 0};
  m.descriptor_ids = {0x761BEAA5u, 0x761BEAA5u, 0xF00DBEEFu};  // top bit set: the bits travel as int32
  m.pairs = {{0, 1, "B optimal, 3 nodes, 5 LPs; C optimal, 12 nodes, 1 LP"}, {0, 3, "B not run; C not run"},
             {1, 3, ""}};
  return m;
}

commerge::server_status_t ToLcm(const ServerStatus& m) {
  commerge::server_status_t msg{};
  msg.utime = m.utime_us;
  msg.session = m.session;
  msg.peak_rss_bytes = m.peak_rss_bytes;
  msg.budget_total_bytes = m.budget_total_bytes;
  msg.budget_limit_bytes = m.budget_limit_bytes;
  FillModules(m.modules, &msg);
  msg.round = m.round;
  msg.state = m.state;
  msg.bytes_received = m.bytes_received;
  msg.messages_rejected = m.messages_rejected;
  msg.last_rejection = m.last_rejection;
  msg.num_robots = static_cast<std::int32_t>(m.robot_ids.size());
  for (std::size_t i = 0; i < m.robot_ids.size(); ++i) {
    msg.robot_id.push_back(static_cast<std::int16_t>(m.robot_ids[i]));
    msg.keyframes.push_back(static_cast<std::int32_t>(m.keyframes[i]));
    msg.scans.push_back(static_cast<std::int32_t>(m.scans[i]));
    msg.chunks_missing.push_back(static_cast<std::int32_t>(m.chunks_missing[i]));
    msg.descriptor_id.push_back(static_cast<std::int32_t>(m.descriptor_ids[i]));
  }
  msg.num_pairs = static_cast<std::int32_t>(m.pairs.size());
  for (const ServerStatus::PairSolvers& p : m.pairs) {
    msg.pair_alpha.push_back(static_cast<std::int16_t>(p.alpha));
    msg.pair_beta.push_back(static_cast<std::int16_t>(p.beta));
    msg.pair_solvers.push_back(p.text);
  }
  return msg;
}

void CheckSame(const ServerStatus& d, const ServerStatus& m) {
  CHECK(d.utime_us == m.utime_us);
  CHECK(d.session == m.session);
  CHECK(d.peak_rss_bytes == m.peak_rss_bytes);
  CHECK(d.budget_total_bytes == m.budget_total_bytes);
  CHECK(d.budget_limit_bytes == m.budget_limit_bytes);
  CheckSameModules(d.modules, m.modules);
  CHECK(d.round == m.round);
  CHECK(d.state == m.state);
  CHECK(d.bytes_received == m.bytes_received);
  CHECK(d.messages_rejected == m.messages_rejected);
  CHECK(d.last_rejection == m.last_rejection);
  CHECK(d.robot_ids == m.robot_ids);
  CHECK(d.keyframes == m.keyframes);
  CHECK(d.scans == m.scans);
  CHECK(d.chunks_missing == m.chunks_missing);
  CHECK(d.descriptor_ids == m.descriptor_ids);
  REQUIRE(d.pairs.size() == m.pairs.size());
  for (std::size_t i = 0; i < m.pairs.size(); ++i) {
    CHECK(d.pairs[i].alpha == m.pairs[i].alpha);
    CHECK(d.pairs[i].beta == m.pairs[i].beta);
    CHECK(d.pairs[i].text == m.pairs[i].text);
  }
}

// Bytes of the server status's per-pair section: num_pairs, pair_alpha, pair_beta, the pair_solvers strings.
std::size_t ServerPairsBytes(const ServerStatus& m) {
  std::size_t n = 4 + 4 * m.pairs.size();
  for (const ServerStatus::PairSolvers& p : m.pairs) n += 4 + p.text.size() + 1;
  return n;
}

// Offsets: robot_status_t's num_modules (int16) after utime, robot_id, session and three memory figures;
// server_status_t's after utime, session and the three figures. Each module: a string, then (after all names)
// three int64.
constexpr std::size_t kRobotNumModules = 8 + 8 + 2 + 8 + 24;  // 50
constexpr std::size_t kServerNumModules = 8 + 8 + 8 + 24;     // 48
std::size_t StringsBytes(const std::vector<ModuleMemory>& modules) {
  std::size_t n = 0;
  for (const ModuleMemory& m : modules) n += 4 + m.name.size() + 1;
  return n;
}

// ---- encoding helpers ----

Buffer Encoded(const TransferStatus& m) {
  Buffer b;
  REQUIRE(EncodeTransferStatus(m, &b).ok());
  return b;
}
Buffer Encoded(const MergeResultMessage& m) {
  Buffer b;
  REQUIRE(EncodeMergeResult(m, &b).ok());
  return b;
}
Buffer Encoded(const RobotStatus& m) {
  Buffer b;
  REQUIRE(EncodeRobotStatus(m, &b).ok());
  return b;
}
Buffer Encoded(const ServerStatus& m) {
  Buffer b;
  REQUIRE(EncodeServerStatus(m, &b).ok());
  return b;
}

// =====================================================================================================

TEST_CASE("status codec: channel names are the documented ones") {
  CHECK(std::string(kStatusChannel) == "COMMERGE_TRANSFER_STATUS");
  CHECK(std::string(kMergeResultChannel) == "COMMERGE_MERGE_RESULT");
  CHECK(std::string(kRobotStatusChannel) == "COMMERGE_ROBOT_STATUS");
  CHECK(std::string(kServerStatusChannel) == "COMMERGE_SERVER_STATUS");
}

// ---- transfer_status_t ----

TEST_CASE("status codec: transfer status round trip keeps every field") {
  const TransferStatus m = MakeTransferStatus();
  auto d = DecodeTransferStatus(S(Encoded(m)));
  REQUIRE(d.ok());
  CheckSame(*d, m);

  TransferStatus empty;  // nothing held, no request
  const Buffer e = Encoded(empty);
  CHECK(e.size() == 8 + 34 + 4 + 1 + 4 + 4 + 1 + 4);
  auto de = DecodeTransferStatus(S(e));
  REQUIRE(de.ok());
  CheckSame(*de, empty);
  CHECK(de->request_id == -1);
}

TEST_CASE("status codec: transfer status bytes are the generated type's, fields at hand-computed offsets") {
  const TransferStatus m = MakeTransferStatus();
  const Buffer b = Encoded(m);
  CHECK(b == LcmEncode(ToLcm(m)));
  // fingerprint 8, utime 8, robot_id 2, server_session 8, robot_session 8, contiguous 4, seen 4, num_gaps 4,
  // 3 x (begin, end), gaps_truncated 1, num_pose_acks 4, 4 x 4, request_id 4, request_complete 1,
  // num_missing 4, 4 x (keyframe 4, first 2, count 2).
  REQUIRE(b.size() == 42 + 4 + 24 + 1 + 4 + 16 + 4 + 1 + 4 + 32);
  CHECK(GetBe(b, 0, 8) == commerge::transfer_status_t::getHash());
  CHECK(GetBe(b, 8, 8) == 1763800000111111);
  CHECK(GetBe(b, 16, 2) == 9);
  CHECK(GetBe(b, 18, 8) == 1763799990000001);
  CHECK(GetBe(b, 26, 8) == 1763799999000009);
  CHECK(GetBe(b, 34, 4) == 100);
  CHECK(GetBe(b, 38, 4) == 250);
  CHECK(GetBe(b, kTransferNumGaps, 4) == 3);
  CHECK(GetBe(b, 46, 4) == 100);      // gap_begin[0]
  CHECK(GetBe(b, 46 + 8, 4) == 200);  // gap_begin[2]
  CHECK(GetBe(b, 58 + 4, 4) == 131);  // gap_end[1]
  CHECK(GetBe(b, 70, 1) == 1);        // gaps_truncated
  CHECK(GetBe(b, TransferNumPoseAcks(3), 4) == 4);
  CHECK(GetBe(b, 75 + 12, 4) == kInt32Max);  // pose_sequences[3]
  CHECK(GetBe(b, 91, 4) == 17);              // request_id
  CHECK(GetBe(b, 95, 1) == 0);               // request_complete
  CHECK(GetBe(b, TransferNumMissing(3, 4), 4) == 4);
  CHECK(GetBe(b, 100 + 12, 4) == kInt32Max);  // missing_keyframe[3]
  CHECK(GetBe(b, 116 + 6, 2) == 32766);       // missing_first_chunk[3]
  CHECK(GetBe(b, 124 + 2, 2) == 3);           // missing_count[1]
}

TEST_CASE("status codec: transfer status at exactly MAX gaps, pose acks and missing ranges round-trips") {
  TransferStatus m;
  m.robot_id = 63;
  for (std::uint32_t i = 0; i < kMaxStatusGaps; ++i) m.gaps.push_back({2 * i + 1, 2 * i + 2});
  m.keyframes_contiguous = 1;
  m.keyframes_seen = 2 * static_cast<std::uint32_t>(kMaxStatusGaps) + 1;
  for (std::size_t i = 0; i < kMaxStatusPoseAcks; ++i) m.pose_sequences.push_back(static_cast<std::int32_t>(i));
  for (std::size_t i = 0; i < kMaxStatusMissingRanges; ++i) {
    m.missing.push_back({static_cast<std::uint32_t>(i / 2), static_cast<std::uint16_t>(i % 2 == 0 ? 0 : 10),
                         static_cast<std::uint16_t>(i % 2 == 0 ? 5 : 32757)});
  }
  const Buffer b = Encoded(m);
  CHECK(b.size() == 60 + 8 * kMaxStatusGaps + 4 * kMaxStatusPoseAcks + 8 * kMaxStatusMissingRanges);
  auto d = DecodeTransferStatus(S(b));
  REQUIRE(d.ok());
  CheckSame(*d, m);
}

TEST_CASE("status codec: transfer status encoder refuses what the message cannot say, naming the field") {
  Buffer out;
  auto refuse = [&out](const TransferStatus& m, const std::vector<std::string>& parts) {
    CheckInvalid(EncodeTransferStatus(m, &out), parts);
  };
  TransferStatus m = MakeTransferStatus();
  m.robot_id = 64;
  refuse(m, {"transfer_status_t", "robot_id 64"});
  m.robot_id = -1;
  refuse(m, {"robot_id -1"});

  m = MakeTransferStatus();
  m.gaps.assign(kMaxStatusGaps + 1, KeyframeGap{});
  refuse(m, {"gaps", "257 entries", "at most 256"});
  m = MakeTransferStatus();
  m.pose_sequences.assign(kMaxStatusPoseAcks + 1, 0);
  refuse(m, {"pose_sequences", "65 entries"});
  m = MakeTransferStatus();
  m.missing.assign(kMaxStatusMissingRanges + 1, MissingChunkRange{});
  refuse(m, {"missing", "1025 entries"});

  m = MakeTransferStatus();
  m.gaps[1] = {130, 130};
  refuse(m, {"gaps[1] = [130, 130)", "empty"});
  m.gaps[1] = {131, 130};
  refuse(m, {"gaps[1]", "empty"});
  m = MakeTransferStatus();
  m.gaps[1] = {110, 125};  // overlaps gaps[0]
  refuse(m, {"gaps[1]", "not ascending and disjoint"});
  m = MakeTransferStatus();
  std::swap(m.gaps[1], m.gaps[2]);
  refuse(m, {"gaps[2]", "not ascending"});
  m = MakeTransferStatus();
  m.gaps[0].begin = 99;
  refuse(m, {"gaps[0]", "below keyframes_contiguous"});
  m = MakeTransferStatus();
  m.gaps[2].end = 251;
  refuse(m, {"gaps[2]", "beyond keyframes_seen"});
  m = MakeTransferStatus();
  m.keyframes_seen = 99;
  m.gaps.clear();
  refuse(m, {"keyframes_contiguous = 100", "keyframes_seen = 99"});
  m = MakeTransferStatus();
  m.gaps.clear();
  m.keyframes_contiguous = kBeyondInt32;
  m.keyframes_seen = kBeyondInt32;
  refuse(m, {"keyframes_contiguous", "int32"});
  m.keyframes_contiguous = 0;
  refuse(m, {"keyframes_seen", "int32"});

  m = MakeTransferStatus();
  m.missing[3].keyframe = kBeyondInt32;
  refuse(m, {"missing[3].keyframe", "int32"});
  m = MakeTransferStatus();
  m.missing[2].keyframe = 104;  // below missing[1]
  refuse(m, {"missing[2]", "not ascending by keyframe"});
  m = MakeTransferStatus();
  m.missing[2].first_chunk = 4;  // inside missing[1]'s chunks 2..4
  refuse(m, {"missing[2]", "overlaps"});
  m = MakeTransferStatus();
  m.missing[1].count = 0;  // the whole scan, and another range of it
  refuse(m, {"missing[2]", "overlaps"});
  m = MakeTransferStatus();
  m.missing[3].first_chunk = 32767;
  refuse(m, {"missing[3]", "beyond chunk 32767"});
  m.missing[3] = {2000000000u, 30000, 2768};
  refuse(m, {"missing[3]", "beyond chunk"});
  m.missing[3] = {2000000000u, 30000, 2767};  // exactly up to chunk 32766
  CHECK(EncodeTransferStatus(m, &out).ok());
}

TEST_CASE("status codec: transfer status decoder refuses values the encoder never writes") {
  const commerge::transfer_status_t good = ToLcm(MakeTransferStatus());
  auto decode = [](const commerge::transfer_status_t& msg) { return DecodeTransferStatus(S(LcmEncode(msg))); };
  REQUIRE(decode(good).ok());
  for (std::int16_t id : {std::int16_t{-1}, std::int16_t{64}, std::int16_t{32767}}) {
    commerge::transfer_status_t msg = good;
    msg.robot_id = id;
    CheckDataLoss(decode(msg), {"transfer_status_t", "robot_id " + std::to_string(id)});
  }
  commerge::transfer_status_t msg = good;
  msg.keyframes_contiguous = -1;
  CheckDataLoss(decode(msg), {"keyframes_contiguous = -1", "negative"});
  msg = good;
  msg.keyframes_seen = -250;
  CheckDataLoss(decode(msg), {"keyframes_seen = -250", "negative"});
  msg = good;
  msg.gap_begin[0] = -100;
  CheckDataLoss(decode(msg), {"gap_begin[0] = -100"});
  msg = good;
  msg.gap_end[2] = std::numeric_limits<std::int32_t>::min();
  CheckDataLoss(decode(msg), {"gap_end[2]", "negative"});
  msg = good;
  msg.gap_begin[2] = 125;  // [125, 249) begins below gaps[1]'s end, 131
  CheckDataLoss(decode(msg), {"gaps[2]", "not ascending and disjoint"});
  msg = good;
  msg.gap_end[1] = 130;
  CheckDataLoss(decode(msg), {"gaps[1] = [130, 130)", "empty"});
  for (std::int8_t flag : {std::int8_t{2}, std::int8_t{-1}}) {
    msg = good;
    msg.gaps_truncated = flag;
    CheckDataLoss(decode(msg), {"gaps_truncated = " + std::to_string(flag), "not 0 or 1"});
    msg = good;
    msg.request_complete = flag;
    CheckDataLoss(decode(msg), {"request_complete", "not 0 or 1"});
  }
  msg = good;
  msg.missing_keyframe[1] = -105;
  CheckDataLoss(decode(msg), {"missing_keyframe[1] = -105", "negative"});
  msg = good;
  msg.missing_first_chunk[2] = -7;
  CheckDataLoss(decode(msg), {"missing_first_chunk[2] = -7", "negative"});
  msg = good;
  msg.missing_count[0] = -1;
  CheckDataLoss(decode(msg), {"missing_count[0] = -1"});
  msg = good;
  msg.missing_keyframe[3] = 100;
  CheckDataLoss(decode(msg), {"missing[3]", "not ascending by keyframe"});
  msg = good;
  msg.missing_first_chunk[2] = 3;
  CheckDataLoss(decode(msg), {"missing[2]", "overlaps"});
  msg = good;
  msg.missing_first_chunk[3] = 30000;
  msg.missing_count[3] = 5000;
  CheckDataLoss(decode(msg), {"missing[3]", "beyond chunk 32767"});
}

TEST_CASE("status codec: transfer status counts patched beyond MAX or beyond the buffer are refused") {
  const Buffer b = Encoded(MakeTransferStatus());
  CheckPatchedCount(b, kTransferNumGaps, 4, 3, 256, "num_gaps", DecodeTransferStatus);
  CheckPatchedCount(b, TransferNumPoseAcks(3), 4, 4, 64, "num_pose_acks", DecodeTransferStatus);
  CheckPatchedCount(b, TransferNumMissing(3, 4), 4, 4, 1024, "num_missing", DecodeTransferStatus);
}

// ---- merge_result_t ----

TEST_CASE("status codec: merge result round trip keeps every field, transforms within float precision") {
  const MergeResultMessage m = MakeMergeResult();
  auto d = DecodeMergeResult(S(Encoded(m)));
  REQUIRE(d.ok());
  CheckSame(*d, m);
  // Decoded rotations are proper (orthonormal, det 1).
  for (const Eigen::Isometry3d& T : d->T_world_map) {
    CHECK((T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-12);
    CHECK(T.linear().determinant() == doctest::Approx(1.0));
  }

  const MergeResultMessage exact = MakeExactMergeResult();
  auto de = DecodeMergeResult(S(Encoded(exact)));
  REQUIRE(de.ok());
  CheckSame(*de, exact);
  for (std::size_t i = 0; i < exact.T_world_map.size(); ++i) {
    CHECK((de->T_world_map[i].matrix() - exact.T_world_map[i].matrix()).cwiseAbs().maxCoeff() == 0.0);
  }

  MergeResultMessage empty;  // the first round of a server that has nothing yet
  const Buffer e = Encoded(empty);
  CHECK(e.size() == 8 + 20 + 4 + 4);
  auto dempty = DecodeMergeResult(S(e));
  REQUIRE(dempty.ok());
  CheckSame(*dempty, empty);
}

TEST_CASE("status codec: merge result bytes are the generated type's, fields at hand-computed offsets") {
  const Buffer b = Encoded(MakeExactMergeResult());
  CHECK(b == LcmEncode(ExactMergeResultLcm()));
  const std::size_t r = 3, p = 2;
  const std::size_t v0 = MergeFirstVerdict(r, p), v1 = v0 + 4 + 8, after = v1 + 4 + 23;
  REQUIRE(b.size() == after + p * (53 + 30));
  CHECK(GetBe(b, 0, 8) == commerge::merge_result_t::getHash());
  CHECK(GetBe(b, 8, 8) == 1763800000333333);
  CHECK(GetBe(b, 16, 8) == -2);
  CHECK(GetBe(b, 24, 4) == 1);
  CHECK(GetBe(b, kMergeNumRobots, 4) == 3);
  CHECK(GetBe(b, 32 + 4, 2) == 5);                        // robot_id[2]
  CHECK(GetBe(b, 32 + 2 * r + 2, 1) == 0);                // in_world[2]
  CHECK(GetBeFloat(b, 32 + 3 * r + 12 + 8) == 100.125f);  // translation_m[1][2]
  CHECK(GetBeFloat(b, 32 + 15 * r + 32 + 4) == 1.0f);     // quaternion[2] x
  CHECK(GetBe(b, 32 + 31 * r, 4) == 200);                 // keyframes[0]
  CHECK(GetBe(b, 32 + 31 * r + 4, 4) == 17);              // keyframes[1]
  CHECK(GetBe(b, MergeNumPairs(r), 4) == 2);
  CHECK(GetBe(b, MergeNumPairs(r) + 4 + 2 * p + 2, 2) == 5);  // beta[1]
  CHECK(GetBe(b, v0, 4) == 8);                                 // "success" + NUL
  CHECK(std::memcmp(b.data() + v0 + 4, "success", 8) == 0);
  CHECK(GetBe(b, v1, 4) == 23);
  CHECK(GetBeFloat(b, after) == -4.0f);                       // pair_translation_m[0][0]
  CHECK(GetBeFloat(b, after + 24 + 12) == 1.0f);              // pair_quaternion[0] z
  CHECK(GetBe(b, after + 56 + 4, 4) == 2);                    // loops_stage_a[1]
  CHECK(GetBeFloat(b, after + 56 + 32) == 0.75f);             // overlap[0]
  CHECK(GetBe(b, after + 56 + 40, 4) == 705);                 // inliers[0]
  const std::size_t solvers = after + p * 53;                 // the solver stages after consistent
  CHECK(GetBe(b, solvers - 2, 1) == 1);                       // consistent[0]
  CHECK(GetBe(b, solvers, 1) == 3);                           // stage_b_status[0]
  CHECK(GetBeFloat(b, solvers + 2 + 4) == 0.25f);             // stage_b_gap[1]
  CHECK(GetBe(b, solvers + 2 + 8 + 4, 4) == 7);               // stage_b_nodes[1]
  CHECK(GetBe(b, solvers + 2 + 16, 4) == 14);                 // stage_b_lp_solves[0]
  CHECK(GetBe(b, solvers + 26 + 1, 1) == 2);                  // stage_c_status[1]
  CHECK(GetBe(b, b.size() - 4, 4) == 11);                     // stage_c_loops_dropped[1]
}

TEST_CASE("status codec: merge result at exactly 64 robots and 2016 pairs round-trips") {
  MergeResultMessage m;
  m.round = 7;
  for (int i = 0; i < static_cast<int>(kMaxMergeRobots); ++i) {
    m.robot_ids.push_back(i);
    m.in_world.push_back(static_cast<std::uint8_t>(i % 2));
    m.T_world_map.push_back(Pose(0.01 * i, Eigen::Vector3d(1, 0, 1), Eigen::Vector3d(i, -i, 0.5)));
    m.keyframes.push_back(static_cast<std::uint32_t>(100 * i));
  }
  for (int a = 0; a < static_cast<int>(kMaxMergeRobots); ++a) {
    for (int b = a + 1; b < static_cast<int>(kMaxMergeRobots); ++b) {
      m.pairs.push_back(MakePair(a, b, (a + b) % 3 == 0, (a + b) % 3 == 0 ? "success" : "not tried",
                                 Eigen::Isometry3d::Identity(), static_cast<std::uint32_t>(a), 0.5f, false));
    }
  }
  REQUIRE(m.pairs.size() == kMaxMergePairs);
  auto d = DecodeMergeResult(S(Encoded(m)));
  REQUIRE(d.ok());
  CheckSame(*d, m);
}

TEST_CASE("status codec: merge result encoder refuses what the message cannot say, naming the field") {
  Buffer out;
  auto refuse = [&out](const MergeResultMessage& m, const std::vector<std::string>& parts) {
    CheckInvalid(EncodeMergeResult(m, &out), parts);
  };
  MergeResultMessage m = MakeMergeResult();
  m.robot_ids.assign(kMaxMergeRobots + 1, 0);
  m.in_world.assign(kMaxMergeRobots + 1, 0);
  m.T_world_map.assign(kMaxMergeRobots + 1, Eigen::Isometry3d::Identity());
  refuse(m, {"merge_result_t", "robot_ids", "65 entries", "at most 64"});
  m = MakeMergeResult();
  m.in_world.pop_back();
  refuse(m, {"in_world", "3 entries for 4 robot_ids"});
  m = MakeMergeResult();
  m.T_world_map.push_back(Eigen::Isometry3d::Identity());
  refuse(m, {"T_world_map", "5 entries for 4 robot_ids"});
  m = MakeMergeResult();
  m.robot_ids[1] = 64;
  refuse(m, {"robot_ids[1] 64", "outside 0..63"});
  m.robot_ids[1] = -2;
  refuse(m, {"robot_ids[1] -2"});
  m = MakeMergeResult();
  m.robot_ids[2] = 2;
  refuse(m, {"robot_ids[2] = 2", "ascending, unique"});
  m = MakeMergeResult();
  m.in_world[3] = 2;
  refuse(m, {"in_world[3] = 2", "not 0 or 1"});
  m = MakeMergeResult();
  m.T_world_map[1].translation().x() = std::numeric_limits<double>::quiet_NaN();
  refuse(m, {"T_world_map[1]", "not finite"});
  m = MakeMergeResult();
  m.pairs.assign(kMaxMergePairs + 1, MergePairOutcome{});
  refuse(m, {"pairs", "2017 entries", "at most 2016"});
  m = MakeMergeResult();
  m.pairs[0].alpha = -1;
  refuse(m, {"pairs[0].alpha -1"});
  m = MakeMergeResult();
  m.pairs[2].beta = 64;
  refuse(m, {"pairs[2].beta 64"});
  m = MakeMergeResult();
  m.pairs[1].verdict = Text(kMaxStatusTextBytes + 1);
  refuse(m, {"pairs[1].verdict", "257 bytes", "longer than 256"});
  m.pairs[1].verdict = std::string("stage\0A", 7);
  refuse(m, {"pairs[1].verdict", "NUL"});
  m = MakeMergeResult();
  m.pairs[3].T_alpha_beta.linear()(2, 2) = std::numeric_limits<double>::infinity();
  refuse(m, {"pairs[3].T_alpha_beta", "not finite"});
  m = MakeMergeResult();
  m.pairs[0].overlap = kFloatNaN;
  refuse(m, {"pairs[0].overlap", "not finite"});
  m = MakeMergeResult();
  m.pairs[1].loops_stage_c = kBeyondInt32;
  refuse(m, {"pairs[1].loops_stage_c", "int32"});
  m = MakeMergeResult();
  m.pairs[2].inliers = 0xffffffffu;
  refuse(m, {"pairs[2].inliers", "int32"});
  m = MakeMergeResult();
  m.pairs[1].stage_b.status = 4;
  refuse(m, {"pairs[1].stage_b_status = 4", "0..3"});
  m = MakeMergeResult();
  m.pairs[0].stage_c.gap = kFloatNaN;
  refuse(m, {"pairs[0].stage_c_gap", "[0, 1]"});
  m.pairs[0].stage_c.gap = 1.5f;
  refuse(m, {"pairs[0].stage_c_gap", "[0, 1]"});
  m = MakeMergeResult();
  m.pairs[3].stage_b.nodes = kBeyondInt32;
  refuse(m, {"pairs[3].stage_b_nodes", "int32"});
}

TEST_CASE("status codec: merge result decoder refuses ids, flags, poses and counters the encoder never writes") {
  const commerge::merge_result_t good = ExactMergeResultLcm();
  auto decode = [](const commerge::merge_result_t& msg) { return DecodeMergeResult(S(LcmEncode(msg))); };
  REQUIRE(decode(good).ok());
  commerge::merge_result_t msg = good;
  msg.robot_id[1] = 64;
  CheckDataLoss(decode(msg), {"merge_result_t", "robot_ids[1] 64"});
  msg.robot_id[1] = -1;
  CheckDataLoss(decode(msg), {"robot_ids[1] -1"});
  msg = good;
  msg.robot_id[2] = 2;
  CheckDataLoss(decode(msg), {"robot_ids[2] = 2", "ascending"});
  msg = good;
  msg.keyframes[1] = -1;
  CheckDataLoss(decode(msg), {"robots[1].keyframes"});
  msg = good;
  msg.alpha[1] = 64;
  CheckDataLoss(decode(msg), {"pairs[1].alpha 64"});
  msg = good;
  msg.beta[0] = -3;
  CheckDataLoss(decode(msg), {"pairs[0].beta -3"});
  msg = good;
  msg.in_world[1] = 2;
  CheckDataLoss(decode(msg), {"in_world[1] = 2", "not 0 or 1"});
  msg = good;
  msg.success[0] = -1;
  CheckDataLoss(decode(msg), {"pairs[0].success = -1"});
  msg = good;
  msg.consistent[1] = 5;
  CheckDataLoss(decode(msg), {"pairs[1].consistent = 5"});
  msg = good;
  msg.quaternion[0] = {1.01f, 0.0f, 0.0f, 0.0f};
  CheckDataLoss(decode(msg), {"T_world_map[0]", "not unit"});
  msg = good;
  msg.quaternion[2] = {0.0f, 0.0f, 0.0f, 0.0f};
  CheckDataLoss(decode(msg), {"T_world_map[2]", "not unit"});
  msg = good;
  msg.translation_m[1][1] = kFloatInf;
  CheckDataLoss(decode(msg), {"T_world_map[1]", "non-finite"});
  msg = good;
  msg.pair_quaternion[1] = {kFloatNaN, 0.0f, 0.0f, 1.0f};
  CheckDataLoss(decode(msg), {"pairs[1].T_alpha_beta", "non-finite"});
  msg = good;
  msg.pair_quaternion[0] = {0.5f, 0.5f, 0.5f, 0.4f};
  CheckDataLoss(decode(msg), {"pairs[0].T_alpha_beta", "not unit"});
  msg = good;
  msg.overlap[1] = kFloatNaN;
  CheckDataLoss(decode(msg), {"pairs[1].overlap", "not finite"});
  msg = good;
  msg.inliers[1] = -1;
  CheckDataLoss(decode(msg), {"pairs[1].inliers = -1", "negative"});
  msg = good;
  msg.loops_stage_a[0] = std::numeric_limits<std::int32_t>::min();
  CheckDataLoss(decode(msg), {"pairs[0].loops_stage_a", "negative"});
  msg = good;
  msg.beta_scans[1] = -4;
  CheckDataLoss(decode(msg), {"pairs[1].beta_scans = -4"});
  msg = good;
  msg.stage_b_status[1] = 4;
  CheckDataLoss(decode(msg), {"pairs[1].stage_b_status = 4", "0..3"});
  msg = good;
  msg.stage_c_status[0] = -1;
  CheckDataLoss(decode(msg), {"pairs[0].stage_c_status = -1"});
  msg = good;
  msg.stage_b_gap[0] = -0.5f;
  CheckDataLoss(decode(msg), {"pairs[0].stage_b_gap", "[0, 1]"});
  msg = good;
  msg.stage_c_gap[1] = kFloatInf;
  CheckDataLoss(decode(msg), {"pairs[1].stage_c_gap", "[0, 1]"});
  msg = good;
  msg.stage_c_nodes[1] = -7;
  CheckDataLoss(decode(msg), {"pairs[1].stage_c_nodes = -7"});
  msg = good;
  msg.stage_c_loops_dropped[0] = -1;
  CheckDataLoss(decode(msg), {"pairs[0].stage_c_loops_dropped"});
  // A verdict longer than 256 bytes, which the generated type encodes, is refused before it is allocated.
  msg = good;
  msg.verdict[1] = Text(kMaxStatusTextBytes + 1);
  CheckDataLoss(decode(msg), {"verdict[1]", "length 258", "outside 1..257"});
  msg.verdict[1] = Text(kMaxStatusTextBytes);
  CHECK(decode(msg).ok());
  // A quaternion off unit by less than 1e-3 is accepted and renormalised.
  msg = good;
  msg.quaternion[0] = {1.0005f, 0.0f, 0.0f, 0.0f};
  auto near = decode(msg);
  REQUIRE(near.ok());
  CHECK((near->T_world_map[0].linear() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() == 0.0);
}

TEST_CASE("status codec: merge result counts and verdict lengths patched beyond MAX or the buffer are refused") {
  const Buffer b = Encoded(MakeExactMergeResult());
  CheckPatchedCount(b, kMergeNumRobots, 4, 3, 64, "num_robots", DecodeMergeResult);
  CheckPatchedCount(b, MergeNumPairs(3), 4, 2, 2016, "num_pairs", DecodeMergeResult);
  const std::size_t v0 = MergeFirstVerdict(3, 2);
  CheckPatchedStringLength(b, v0, "success", "verdict[0]", DecodeMergeResult);
  CheckPatchedStringLength(b, v0 + 4 + 8, "stage A: too few loops", "verdict[1]", DecodeMergeResult);
}

// ---- robot_status_t ----

TEST_CASE("status codec: robot status round trip keeps every field") {
  const RobotStatus m = MakeRobotStatus();
  auto d = DecodeRobotStatus(S(Encoded(m)));
  REQUIRE(d.ok());
  CheckSame(*d, m);

  RobotStatus empty;  // no modules, empty state
  const Buffer e = Encoded(empty);
  CHECK(e.size() == kRobotNumModules + 2 + 40 + 5);
  auto de = DecodeRobotStatus(S(e));
  REQUIRE(de.ok());
  CheckSame(*de, empty);

  RobotStatus full = MakeRobotStatus();  // 32 modules with 256-byte names, a 256-byte state
  full.modules.clear();
  for (std::size_t i = 0; i < kMaxStatusModules; ++i) {
    full.modules.push_back(Module(Text(kMaxStatusTextBytes, static_cast<char>('a' + i % 26)),
                                  static_cast<std::int64_t>(i) << 20, static_cast<std::int64_t>(i), -1));
  }
  full.state = Text(kMaxStatusTextBytes, 's');
  auto dfull = DecodeRobotStatus(S(Encoded(full)));
  REQUIRE(dfull.ok());
  CheckSame(*dfull, full);
}

TEST_CASE("status codec: robot status bytes are the generated type's, fields at hand-computed offsets") {
  const RobotStatus m = MakeRobotStatus();
  const Buffer b = Encoded(m);
  CHECK(b == LcmEncode(ToLcm(m)));
  const std::size_t names = kRobotNumModules + 2, arrays = names + StringsBytes(m.modules);
  const std::size_t counters = arrays + 2 * 24, state = counters + 5 * 4 + 2 * 8 + 4;
  REQUIRE(b.size() == state + 4 + 13 + 1);
  CHECK(GetBe(b, 0, 8) == commerge::robot_status_t::getHash());
  CHECK(GetBe(b, 8, 8) == 1763800000444444);
  CHECK(GetBe(b, 16, 2) == 6);
  CHECK(GetBe(b, 18, 8) == 1763799999000006);
  CHECK(GetBe(b, 26, 8) == 300LL << 20);
  CHECK(GetBe(b, 42, 8) == 2650LL << 20);
  CHECK(GetBe(b, kRobotNumModules, 2) == 2);
  CHECK(GetBe(b, names, 4) == 11);  // "scan_store" + NUL
  CHECK(std::memcmp(b.data() + names + 4, "scan_store", 11) == 0);
  CHECK(GetBe(b, arrays + 8, 8) == 10LL << 20);      // module_budget_bytes[1]
  CHECK(GetBe(b, arrays + 16 + 8, 8) == 4096);       // module_used_bytes[1]
  CHECK(GetBe(b, arrays + 32, 8) == 23456789);       // module_high_water_bytes[0]
  CHECK(GetBe(b, counters, 4) == 1200);              // keyframes
  CHECK(GetBe(b, counters + 16, 4) == kInt32Max);    // queued_chunks
  CHECK(GetBe(b, counters + 20, 8) == 98765432101LL);  // bytes_sent
  CHECK(GetBe(b, counters + 36, 4) == -1);           // request_id
  CHECK(GetBe(b, state, 4) == 14);
  CHECK(std::memcmp(b.data() + state + 4, "sending scans", 14) == 0);
}

TEST_CASE("status codec: robot status encoder refuses what the message cannot say, naming the field") {
  Buffer out;
  auto refuse = [&out](const RobotStatus& m, const std::vector<std::string>& parts) {
    CheckInvalid(EncodeRobotStatus(m, &out), parts);
  };
  RobotStatus m = MakeRobotStatus();
  m.robot_id = 64;
  refuse(m, {"robot_status_t", "robot_id 64"});
  m = MakeRobotStatus();
  m.modules.assign(kMaxStatusModules + 1, ModuleMemory{});
  refuse(m, {"modules", "33 entries", "at most 32"});
  m = MakeRobotStatus();
  m.modules[1].name = Text(kMaxStatusTextBytes + 1);
  refuse(m, {"modules[1].name", "257 bytes"});
  m = MakeRobotStatus();
  m.state = Text(kMaxStatusTextBytes + 1);
  refuse(m, {"state", "257 bytes", "longer than 256"});
  m.state = std::string("done\0", 5);
  refuse(m, {"state", "NUL"});
  m = MakeRobotStatus();
  m.keyframes = kBeyondInt32;
  refuse(m, {"keyframes = 2147483648", "int32"});
  m = MakeRobotStatus();
  m.queued_poses = 0xffffffffu;
  refuse(m, {"queued_poses", "int32"});
}

TEST_CASE("status codec: robot status decoder refuses negative counters, bad ids and long strings") {
  const commerge::robot_status_t good = ToLcm(MakeRobotStatus());
  auto decode = [](const commerge::robot_status_t& msg) { return DecodeRobotStatus(S(LcmEncode(msg))); };
  REQUIRE(decode(good).ok());
  commerge::robot_status_t msg = good;
  msg.robot_id = 64;
  CheckDataLoss(decode(msg), {"robot_status_t", "robot_id 64"});
  msg = good;
  msg.keyframes = -1;
  CheckDataLoss(decode(msg), {"keyframes = -1", "negative"});
  msg = good;
  msg.keyframes_acked = -5;
  CheckDataLoss(decode(msg), {"keyframes_acked = -5"});
  msg = good;
  msg.queued_chunks = std::numeric_limits<std::int32_t>::min();
  CheckDataLoss(decode(msg), {"queued_chunks", "negative"});
  msg = good;
  msg.state = Text(kMaxStatusTextBytes + 1);
  CheckDataLoss(decode(msg), {"state", "length 258"});
  msg = good;
  msg.module_name[0] = Text(1000);
  CheckDataLoss(decode(msg), {"module_name[0]", "length 1001"});
}

TEST_CASE("status codec: robot status counts and string lengths patched beyond MAX or the buffer are refused") {
  const RobotStatus m = MakeRobotStatus();
  const Buffer b = Encoded(m);
  CheckPatchedCount(b, kRobotNumModules, 2, 2, 32, "num_modules", DecodeRobotStatus);
  CheckPatchedStringLength(b, kRobotNumModules + 2, "scan_store", "module_name[0]", DecodeRobotStatus);
  CheckPatchedStringLength(b, kRobotNumModules + 2 + 4 + 11, "descriptor_db", "module_name[1]", DecodeRobotStatus);
  CheckPatchedStringLength(b, b.size() - 4 - 14, "sending scans", "state", DecodeRobotStatus);
}

// ---- server_status_t ----

TEST_CASE("status codec: server status round trip keeps every field") {
  const ServerStatus m = MakeServerStatus();
  auto d = DecodeServerStatus(S(Encoded(m)));
  REQUIRE(d.ok());
  CheckSame(*d, m);

  ServerStatus empty;
  const Buffer e = Encoded(empty);
  CHECK(e.size() == kServerNumModules + 2 + 4 + 5 + 16 + 5 + 4 + 4);
  auto de = DecodeServerStatus(S(e));
  REQUIRE(de.ok());
  CheckSame(*de, empty);

  ServerStatus full = MakeServerStatus();  // 64 robots, 32 modules, 256-byte strings
  full.modules.assign(kMaxStatusModules, Module(Text(kMaxStatusTextBytes, 'm'), 1, 2, 3));
  full.state = Text(kMaxStatusTextBytes, 's');
  full.last_rejection = Text(kMaxStatusTextBytes, 'r');
  full.robot_ids.clear();
  full.keyframes.clear();
  full.scans.clear();
  full.chunks_missing.clear();
  full.descriptor_ids.clear();
  for (int i = 0; i < static_cast<int>(kMaxMergeRobots); ++i) {
    full.robot_ids.push_back(63 - i);
    full.keyframes.push_back(static_cast<std::uint32_t>(1000 * i));
    full.scans.push_back(static_cast<std::uint32_t>(i));
    full.chunks_missing.push_back(static_cast<std::uint32_t>(i % 5));
    full.descriptor_ids.push_back(0xFFFFFFFFu - static_cast<std::uint32_t>(i));
  }
  full.pairs.clear();
  for (int a = 0; a < static_cast<int>(kMaxMergeRobots); ++a) {
    for (int b = a + 1; b < static_cast<int>(kMaxMergeRobots); ++b) {
      full.pairs.push_back({a, b, a == 0 && b == 1 ? Text(kMaxStatusTextBytes, 'p') : StageSolverText("B", {2, 0.5f, 7, 9})});
    }
  }
  REQUIRE(full.pairs.size() == kMaxMergePairs);
  auto dfull = DecodeServerStatus(S(Encoded(full)));
  REQUIRE(dfull.ok());
  CheckSame(*dfull, full);
}

TEST_CASE("status codec: server status bytes are the generated type's, fields at hand-computed offsets") {
  const ServerStatus m = MakeServerStatus();
  const Buffer b = Encoded(m);
  CHECK(b == LcmEncode(ToLcm(m)));
  const std::size_t names = kServerNumModules + 2, arrays = names + StringsBytes(m.modules);
  const std::size_t round = arrays + 3 * 24, state = round + 4, figures = state + 4 + 17 + 1;
  const std::size_t rejection = figures + 16, robots = rejection + 4 + m.last_rejection.size() + 1;
  REQUIRE(b.size() == robots + 4 + 3 * 18 + ServerPairsBytes(m));
  CHECK(GetBe(b, 0, 8) == commerge::server_status_t::getHash());
  CHECK(GetBe(b, 8, 8) == 1763800000555555);
  CHECK(GetBe(b, 16, 8) == 1763799990000001);
  CHECK(GetBe(b, 24, 8) == 900LL << 20);
  CHECK(GetBe(b, kServerNumModules, 2) == 3);
  CHECK(GetBe(b, names, 4) == 12);  // "keyframe_db" + NUL
  CHECK(GetBe(b, arrays - 5, 4) == 1);  // the empty third module name: its NUL only
  CHECK(GetBe(b, arrays + 24 + 8, 8) == 0);          // module_used_bytes[1]
  CHECK(GetBe(b, arrays + 48 + 8, 8) == 7);          // module_high_water_bytes[1]
  CHECK(GetBe(b, round, 4) == 2);
  CHECK(std::memcmp(b.data() + state + 4, "waiting for scans", 18) == 0);
  CHECK(GetBe(b, figures, 8) == 123456789012LL);
  CHECK(GetBe(b, figures + 8, 8) == 3);
  CHECK(GetBe(b, robots, 4) == 3);
  CHECK(GetBe(b, robots + 4 + 4, 2) == 3);                       // robot_id[2]
  CHECK(GetBe(b, robots + 4 + 6 + 4, 4) == 420);                 // keyframes[1]
  CHECK(GetBe(b, robots + 4 + 6 + 12 + 12 + 4, 4) == kInt32Max);  // chunks_missing[1]
  CHECK(static_cast<std::uint32_t>(GetBe(b, robots + 4 + 6 + 12 + 12 + 12 + 8, 4)) == 0xF00DBEEFu);  // descriptor_id[2]
  const std::size_t pairs = robots + 4 + 3 * 18;
  CHECK(GetBe(b, pairs, 4) == 3);                            // num_pairs
  CHECK(GetBe(b, pairs + 4 + 6 + 2, 2) == 3);                // pair_beta[1]
  CHECK(GetBe(b, pairs + 4 + 12, 4) == 53);                  // pair_solvers[0] length with its NUL
  CHECK(std::memcmp(b.data() + pairs + 4 + 12 + 4, "B optimal, 3 nodes", 18) == 0);
}

TEST_CASE("status codec: server status encoder refuses what the message cannot say, naming the field") {
  Buffer out;
  auto refuse = [&out](const ServerStatus& m, const std::vector<std::string>& parts) {
    CheckInvalid(EncodeServerStatus(m, &out), parts);
  };
  ServerStatus m = MakeServerStatus();
  m.modules.assign(kMaxStatusModules + 1, ModuleMemory{});
  refuse(m, {"server_status_t", "modules", "33 entries"});
  m = MakeServerStatus();
  m.modules[2].name = Text(300);
  refuse(m, {"modules[2].name", "300 bytes"});
  m = MakeServerStatus();
  m.state = Text(kMaxStatusTextBytes + 1);
  refuse(m, {"state", "257 bytes"});
  m = MakeServerStatus();
  m.last_rejection = Text(kMaxStatusTextBytes + 1);
  refuse(m, {"last_rejection", "257 bytes"});
  m = MakeServerStatus();
  m.robot_ids.assign(kMaxMergeRobots + 1, 0);
  refuse(m, {"robot_ids", "65 entries", "at most 64"});
  m = MakeServerStatus();
  m.keyframes.pop_back();
  refuse(m, {"keyframes", "2 entries for 3 robot_ids"});
  m = MakeServerStatus();
  m.scans.push_back(1);
  refuse(m, {"scans", "4 entries for 3 robot_ids"});
  m = MakeServerStatus();
  m.chunks_missing.clear();
  refuse(m, {"chunks_missing", "0 entries for 3 robot_ids"});
  m = MakeServerStatus();
  m.descriptor_ids.pop_back();
  refuse(m, {"descriptor_ids", "2 entries for 3 robot_ids"});
  m = MakeServerStatus();
  m.robot_ids[1] = 64;
  refuse(m, {"robot_ids[1] 64", "outside 0..63"});
  m = MakeServerStatus();
  m.keyframes[2] = kBeyondInt32;
  refuse(m, {"keyframes[2]", "int32"});
  m = MakeServerStatus();
  m.chunks_missing[0] = 0xffffffffu;
  refuse(m, {"chunks_missing[0]", "int32"});
  m = MakeServerStatus();
  m.pairs.assign(kMaxMergePairs + 1, ServerStatus::PairSolvers{});
  refuse(m, {"pairs", "2017 entries", "at most 2016"});
  m = MakeServerStatus();
  m.pairs[1].beta = 64;
  refuse(m, {"pairs[1].beta 64"});
  m = MakeServerStatus();
  m.pairs[2].text = Text(kMaxStatusTextBytes + 1);
  refuse(m, {"pairs[2].solvers", "257 bytes"});
}

TEST_CASE("status codec: server status decoder refuses negative counters, bad ids and long strings") {
  const commerge::server_status_t good = ToLcm(MakeServerStatus());
  auto decode = [](const commerge::server_status_t& msg) { return DecodeServerStatus(S(LcmEncode(msg))); };
  REQUIRE(decode(good).ok());
  commerge::server_status_t msg = good;
  msg.robot_id[1] = -1;
  CheckDataLoss(decode(msg), {"server_status_t", "robot_ids[1] -1"});
  msg.robot_id[1] = 64;
  CheckDataLoss(decode(msg), {"robot_ids[1] 64"});
  msg = good;
  msg.keyframes[0] = -500;
  CheckDataLoss(decode(msg), {"keyframes[0] = -500", "negative"});
  msg = good;
  msg.scans[2] = -1;
  CheckDataLoss(decode(msg), {"scans[2] = -1"});
  msg = good;
  msg.chunks_missing[1] = std::numeric_limits<std::int32_t>::min();
  CheckDataLoss(decode(msg), {"chunks_missing[1]", "negative"});
  msg = good;
  msg.last_rejection = Text(kMaxStatusTextBytes + 1);
  CheckDataLoss(decode(msg), {"last_rejection", "length 258"});
  msg = good;
  msg.module_name[2] = Text(kMaxStatusTextBytes + 1);
  CheckDataLoss(decode(msg), {"module_name[2]", "length 258"});
  msg = good;
  msg.pair_alpha[0] = -1;
  CheckDataLoss(decode(msg), {"pairs[0].alpha -1"});
  msg = good;
  msg.pair_solvers[1] = Text(kMaxStatusTextBytes + 1);
  CheckDataLoss(decode(msg), {"pair_solvers[1]", "length 258"});
}

TEST_CASE("status codec: server status counts and string lengths patched beyond MAX or the buffer are refused") {
  const ServerStatus m = MakeServerStatus();
  const Buffer b = Encoded(m);
  const std::size_t robots = b.size() - ServerPairsBytes(m) - 4 - 3 * 18;
  CheckPatchedCount(b, kServerNumModules, 2, 3, 32, "num_modules", DecodeServerStatus);
  CheckPatchedCount(b, robots, 4, 3, 64, "num_robots", DecodeServerStatus);
  CheckPatchedCount(b, robots + 4 + 3 * 18, 4, 3, 2016, "num_pairs", DecodeServerStatus);
  CheckPatchedStringLength(b, robots + 4 + 3 * 18 + 4 + 12, m.pairs[0].text, "pair_solvers[0]", DecodeServerStatus);
  CheckPatchedStringLength(b, kServerNumModules + 2, "keyframe_db", "module_name[0]", DecodeServerStatus);
  const std::size_t state = kServerNumModules + 2 + StringsBytes(m.modules) + 3 * 24 + 4;
  CheckPatchedStringLength(b, state, "waiting for scans", "state", DecodeServerStatus);
  const std::size_t rejection = robots - 4 - m.last_rejection.size() - 1;
  CheckPatchedStringLength(b, rejection, m.last_rejection, "last_rejection", DecodeServerStatus);
  // The empty third module name (length 1): 0 and 2 are refused as well.
  const std::size_t third = kServerNumModules + 2 + 4 + 12 + 4 + 11;
  REQUIRE(GetBe(b, third, 4) == 1);
  CheckPatchedStringLength(b, third, "", "module_name[2]", DecodeServerStatus);
}

// ---- all four ----

TEST_CASE("status codec: every truncation of a valid buffer is refused") {
  CheckEveryTruncationRefused(Encoded(MakeTransferStatus()), DecodeTransferStatus, "transfer_status_t");
  CheckEveryTruncationRefused(Encoded(MakeExactMergeResult()), DecodeMergeResult, "merge_result_t");
  CheckEveryTruncationRefused(Encoded(MakeRobotStatus()), DecodeRobotStatus, "robot_status_t");
  CheckEveryTruncationRefused(Encoded(MakeServerStatus()), DecodeServerStatus, "server_status_t");
}

TEST_CASE("status codec: trailing bytes after a valid message are refused") {
  CheckTrailingBytesRefused(Encoded(MakeTransferStatus()), DecodeTransferStatus, "transfer_status_t");
  CheckTrailingBytesRefused(Encoded(MakeExactMergeResult()), DecodeMergeResult, "merge_result_t");
  CheckTrailingBytesRefused(Encoded(MakeRobotStatus()), DecodeRobotStatus, "robot_status_t");
  CheckTrailingBytesRefused(Encoded(MakeServerStatus()), DecodeServerStatus, "server_status_t");
}

TEST_CASE("status codec: every decoder refuses a foreign message type by its fingerprint, before its length") {
  Buffer batch, poses, request, chunk;
  REQUIRE(EncodeKeyframeBatch(KeyframeBatch{}, &batch).ok());
  REQUIRE(EncodePoseUpdate(PoseUpdate{}, &poses).ok());
  REQUIRE(EncodeScanRequest(ScanRequest{}, &request).ok());
  REQUIRE(EncodeScanChunk(ScanChunk{}, &chunk).ok());
  const Buffer transfer = Encoded(MakeTransferStatus()), merge = Encoded(MakeExactMergeResult()),
               robot = Encoded(MakeRobotStatus()), server = Encoded(MakeServerStatus());
  const std::vector<std::pair<const char*, const Buffer*>> all = {
      {"keyframe_batch_t", &batch},       {"pose_update_t", &poses},   {"exchange_policy_t", &request},
      {"scan_chunk_t", &chunk},           {"transfer_status_t", &transfer}, {"merge_result_t", &merge},
      {"robot_status_t", &robot},         {"server_status_t", &server}};
  for (const auto& entry : all) {
    const char* name = entry.first;
    const Buffer* buffer = entry.second;
    // The whole buffer and its first 8 and 12 bytes: shorter than every header, still refused by fingerprint.
    for (std::size_t len : {buffer->size(), std::size_t{8}, std::size_t{12}}) {
      INFO("a ", name, " buffer cut to ", len, " bytes");
      const Buffer b(buffer->begin(), buffer->begin() + static_cast<std::ptrdiff_t>(len));
      const std::string own(name);
      auto expect = [&own, &b](const auto& r, const char* type) {
        if (own == type) {
          if (b.size() > 12) CHECK(r.ok());
        } else {
          CheckDataLoss(r, {type, "fingerprint"});
        }
      };
      expect(DecodeTransferStatus(S(b)), "transfer_status_t");
      expect(DecodeMergeResult(S(b)), "merge_result_t");
      expect(DecodeRobotStatus(S(b)), "robot_status_t");
      expect(DecodeServerStatus(S(b)), "server_status_t");
      expect(DecodeKeyframeBatch(S(b)), "keyframe_batch_t");
      expect(DecodePoseUpdate(S(b)), "pose_update_t");
      expect(DecodeScanRequest(S(b)), "exchange_policy_t");
      expect(DecodeScanChunk(S(b)), "scan_chunk_t");
    }
  }
  // One flipped bit anywhere in the fingerprint.
  for (std::size_t byte : {std::size_t{0}, std::size_t{3}, std::size_t{7}}) {
    Buffer bad = robot;
    bad[byte] ^= 0x10;
    CheckDataLoss(DecodeRobotStatus(S(bad)), {"robot_status_t", "fingerprint"});
  }
}

TEST_CASE("status codec: the encoded bytes are exactly what lcm publish of the generated types delivers") {
  lcm::LCM lcm("memq://");
  REQUIRE(lcm.good());
  std::vector<std::pair<std::string, Buffer>> got;
  for (const char* ch : {kStatusChannel, kMergeResultChannel, kRobotStatusChannel, kServerStatusChannel}) {
    lcm.subscribeFunction(ch, &KeepBytes, &got);
  }
  const commerge::transfer_status_t transfer = ToLcm(MakeTransferStatus());
  const commerge::merge_result_t merge = ExactMergeResultLcm();
  const commerge::robot_status_t robot = ToLcm(MakeRobotStatus());
  const commerge::server_status_t server = ToLcm(MakeServerStatus());
  REQUIRE(lcm.publish(kStatusChannel, &transfer) == 0);
  REQUIRE(lcm.publish(kMergeResultChannel, &merge) == 0);
  REQUIRE(lcm.publish(kRobotStatusChannel, &robot) == 0);
  REQUIRE(lcm.publish(kServerStatusChannel, &server) == 0);
  while (lcm.handleTimeout(0) > 0) {
  }
  REQUIRE(got.size() == 4);
  CHECK(got[0].first == kStatusChannel);
  CHECK(got[0].second == Encoded(MakeTransferStatus()));
  CHECK(got[1].first == kMergeResultChannel);
  CHECK(got[1].second == Encoded(MakeExactMergeResult()));
  CHECK(got[2].first == kRobotStatusChannel);
  CHECK(got[2].second == Encoded(MakeRobotStatus()));
  CHECK(got[3].first == kServerStatusChannel);
  CHECK(got[3].second == Encoded(MakeServerStatus()));
  auto decoded = DecodeMergeResult(S(got[1].second));
  REQUIRE(decoded.ok());
  CheckSame(*decoded, MakeExactMergeResult());
}

}  // namespace
}  // namespace commerge::platform
