// SPDX-License-Identifier: BSD-3-Clause
// ServerLink, the server's side of reliable delivery and its merge rounds: a robot's sessions (restarts adopted
// only for a valid message, old sessions refused, its descriptor id held within one), rounds on request and
// settling, the status columns, widening within a round, robots that leave, and replays of a recorded mission
// (with its timing, and following its recorded round steps). The missions with robots and a lossy link are in
// reliable_transfer_support.hpp; the robots' side of delivery is tested in test_reliable_transfer.cpp.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "core/agent/round_replay.hpp"
#include "core/agent/server_link.hpp"
#include "tests/core/agent/keyframe_batch_fixtures.hpp"
#include "tests/core/agent/merge_server_test_support.hpp"
#include "tests/core/agent/reliable_transfer_support.hpp"
#include "tests/core/agent/scan_chunk_fixtures.hpp"
#include "tests/core/agent/server_fixture.hpp"

using namespace commerge;
using commerge::test::BruteForceWiden;
using commerge::test::ChunksOf;
using commerge::test::EncodeForTest;
using commerge::test::kTickUs;
using commerge::test::LatticePoints;
using commerge::test::LinkModel;
using commerge::test::MakeBatch;
using commerge::test::Mission;
using commerge::test::PaperStageA;
using commerge::test::RandomDescriptor;
using commerge::test::SendAllParams;
using commerge::test::ShiftedPairBatches;

namespace {

// Answers every scan request in `out` with scans of 2 points each (too few for registration: it refuses the pair)
// and returns the requests it answered.
std::vector<ScanRequest> AnswerWithTinyScans(ServerLink* link, const std::vector<ServerOutgoing>& out,
                                             std::int64_t now_us) {
  std::vector<ScanRequest> answered;
  for (const ServerOutgoing& o : out) {
    if (o.kind != ServerOutgoing::Kind::kScanRequest) continue;
    for (std::uint32_t k : o.request.keyframes) {
      for (ScanChunk c : ChunksOf(o.request.robot_id, k, EncodeForTest(LatticePoints(2)))) {
        c.request_id = o.request.request_id;
        REQUIRE(link->OnScanChunk(c, now_us).ok());
      }
    }
    answered.push_back(o.request);
  }
  return answered;
}

const MergeResultMessage* FindResult(const std::vector<ServerOutgoing>& out) {
  for (const ServerOutgoing& o : out) {
    if (o.kind == ServerOutgoing::Kind::kMergeResult) return &o.result;
  }
  return nullptr;
}

// Replays the recorded robot -> server traffic, with its timing, into a fresh server; returns its last result.
MergeResultMessage Replay(const std::vector<std::pair<std::int64_t, RobotOutgoing>>& recorded,
                          const ServerLinkParams& params) {
  MergeServerParams mp;
  mp.cascade.stage_a = SequentialMatchParams{};  // the paper's stage A: B_ij = [A_ij <= tau_inter]
  mp.cascade.stage_a.tau_area = 4;
  std::unique_ptr<MergeServer> merge_owner = commerge::test::MakeTestServer(2, 64, mp);
  MergeServer& merge = *merge_owner;
  ServerLink link(777, params, &merge);
  std::size_t next = 0;
  const std::int64_t end_us = recorded.back().first + 20000000;
  std::vector<ServerOutgoing> out;
  for (std::int64_t t = 0; t <= end_us; t += kTickUs) {
    for (; next < recorded.size() && recorded[next].first <= t; ++next) {
      const RobotOutgoing& m = recorded[next].second;
      switch (m.kind) {
        case RobotOutgoing::Kind::kKeyframeBatch: (void)link.OnKeyframeBatch(m.batch, t); break;
        case RobotOutgoing::Kind::kPoseUpdate: (void)link.OnPoseUpdate(m.poses, t); break;
        case RobotOutgoing::Kind::kScanChunk: (void)link.OnScanChunk(m.chunk, t); break;
      }
    }
    out.clear();
    REQUIRE(link.Poll(t, &out).ok());
  }
  return link.last_result();
}

// What a replay that follows the recorded round steps did.
struct StepReplay {
  MergeResultMessage result;
  std::vector<RoundStep> steps;        ///< its own steps
  std::vector<std::string> mismatches; ///< FollowStep's errors, in order
};

// Replays `recorded` (robot -> server) and the recorded round steps into a fresh server as `commerge server
// --replay` does: robot messages wait in a queue, and each step record arriving `late` messages after the point
// where the recording server ran it (as a recorder sees it when the server's cascade took a while) first hands
// the link the messages the recording had taken (MessagesDue), then runs the step.
StepReplay ReplaySteps(const std::vector<std::pair<std::int64_t, RobotOutgoing>>& recorded,
                       const std::vector<std::pair<std::size_t, RoundStep>>& steps, std::size_t late, int robots) {
  MergeServerParams mp;
  mp.cascade.stage_a = SequentialMatchParams{};
  mp.cascade.stage_a.tau_area = 4;
  std::unique_ptr<MergeServer> merge_owner = commerge::test::MakeTestServer(robots, 64, mp);
  MergeServer& merge = *merge_owner;
  ServerLinkParams params;
  params.mode = ExchangeMode::kStageABC;
  params.automatic_rounds = false;
  params.follow_recorded_steps = true;
  ServerLink link(777, params, &merge);
  StepReplay replay;
  std::vector<std::pair<std::int64_t, RobotOutgoing>> queue;
  const auto apply = [&](const std::pair<std::int64_t, RobotOutgoing>& m) {
    switch (m.second.kind) {
      case RobotOutgoing::Kind::kKeyframeBatch: (void)link.OnKeyframeBatch(m.second.batch, m.first); break;
      case RobotOutgoing::Kind::kPoseUpdate: (void)link.OnPoseUpdate(m.second.poses, m.first); break;
      case RobotOutgoing::Kind::kScanChunk: (void)link.OnScanChunk(m.second.chunk, m.first); break;
    }
  };
  std::size_t next_step = 0;
  std::vector<ServerOutgoing> out;
  for (std::size_t i = 0; i <= recorded.size() + late; ++i) {
    if (i < recorded.size()) queue.push_back(recorded[i]);
    for (; next_step < steps.size() && std::min(steps[next_step].first + late, recorded.size()) <= i; ++next_step) {
      const RoundStep& step = steps[next_step].second;
      std::vector<QueuedRobotMessage> refs;
      for (const auto& [t, m] : queue) {
        refs.push_back({m.kind == RobotOutgoing::Kind::kKeyframeBatch ? m.batch.robot_id
                        : m.kind == RobotOutgoing::Kind::kPoseUpdate  ? m.poses.robot_id
                                                                      : m.chunk.robot_id,
                        m.kind == RobotOutgoing::Kind::kKeyframeBatch ? RobotMessageKind::kKeyframeBatch
                        : m.kind == RobotOutgoing::Kind::kPoseUpdate  ? RobotMessageKind::kPoseUpdate
                                                                      : RobotMessageKind::kScanChunk});
      }
      const std::vector<RoundRobotInput> taken = link.TakenInputs();
      const std::vector<std::size_t> due = MessagesDue(Span<const QueuedRobotMessage>(refs),
                                                       Span<const RoundRobotInput>(step.robots),
                                                       Span<const RoundRobotInput>(taken));
      std::vector<std::pair<std::int64_t, RobotOutgoing>> kept;
      std::size_t d = 0;
      for (std::size_t q = 0; q < queue.size(); ++q) {
        if (d < due.size() && due[d] == q) {
          apply(queue[q]);
          ++d;
        } else {
          kept.push_back(std::move(queue[q]));
        }
      }
      queue = std::move(kept);
      out.clear();
      const Status st = link.FollowStep(step, step.utime_us, &out);
      if (!st.ok()) replay.mismatches.push_back(st.message());
      for (const ServerOutgoing& o : out) {
        if (o.kind == ServerOutgoing::Kind::kRoundStep) replay.steps.push_back(o.step);
      }
    }
  }
  replay.result = link.last_result();
  return replay;
}

}  // namespace

TEST_CASE("Server link: a robot restarted with the team's descriptor setting is adopted, within a session its id is held") {
  const std::uint32_t kId = 0x761BEAA5u, kOtherId = 0x12345678u;
  MergeServerParams mp = PaperStageA(100);
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, mp);
  MergeServer& server = *server_owner;
  ServerLinkParams lp;
  lp.automatic_rounds = false;
  ServerLink link(500, lp, &server);
  const std::int64_t now = 1000000;
  std::vector<KeyframeBatch> batches = ShiftedPairBatches(40, 5, 1000);
  batches[0].descriptor_id = kId;
  batches[1].descriptor_id = kOtherId;  // robot 1 was started with another --lidar
  for (const KeyframeBatch& b : batches) REQUIRE(link.OnKeyframeBatch(b, now).ok());
  REQUIRE(server.RunCascades().ok());
  CHECK(server.cascade(0, 1) == nullptr);
  REQUIRE(server.incomparable_pairs().size() == 1);

  // The same session cannot switch its id ...
  KeyframeBatch same_session = batches[1];
  same_session.descriptor_id = kId;
  same_session.sequence = 1;
  const std::uint64_t rejected = server.stats().rejected_batches;
  CHECK_FALSE(link.OnKeyframeBatch(same_session, now).ok());
  CHECK(server.stats().rejected_batches == rejected + 1);
  CHECK(server.robot(1).descriptor_id == kOtherId);
  // ... but the robot restarted with the team's setting (a newer session) replaces it and is compared.
  KeyframeBatch restarted = batches[1];
  restarted.session = batches[1].session + 10;
  restarted.descriptor_id = kId;
  REQUIRE(link.OnKeyframeBatch(restarted, now).ok());
  CHECK(link.robot_session(1) == restarted.session);
  CHECK(server.robot(1).descriptor_id == kId);
  REQUIRE(server.RunCascades().ok());
  CHECK(server.incomparable_pairs().empty());
  REQUIRE(server.cascade(0, 1) != nullptr);
  CHECK(server.cascade(0, 1)->stage_a.found);
}

// Rounds on request (commerge server --replay): a round at a recording's early merge result must not settle the
// server while keyframes keep arriving after it; only a round that saw them does.
TEST_CASE("Server link: with rounds on request, keyframes delivered after the last round keep it unsettled") {
  MergeServerParams mp = PaperStageA(100);
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, mp);
  MergeServer& server = *server_owner;
  ServerLinkParams lp;
  lp.automatic_rounds = false;
  lp.accept_unrequested_scans = true;
  ServerLink link(500, lp, &server);
  std::int64_t now = 1000000;
  const auto run_round = [&] {
    link.RequestRound();
    const int rounds = link.rounds_merged();
    std::vector<ServerOutgoing> out;
    for (int poll = 0; poll < 50 && link.rounds_merged() == rounds; ++poll, now += 100000) {
      out.clear();
      REQUIRE(link.Poll(now, &out).ok());
      for (const ServerOutgoing& o : out) {
        if (o.kind != ServerOutgoing::Kind::kScanRequest) continue;
        for (std::uint32_t k : o.request.keyframes) {
          for (ScanChunk c : ChunksOf(o.request.robot_id, k, EncodeForTest(LatticePoints(2)))) {
            c.request_id = o.request.request_id;
            (void)link.OnScanChunk(c, now);
          }
        }
      }
    }
    REQUIRE(link.rounds_merged() == rounds + 1);
  };
  const auto quiet = static_cast<std::int64_t>(lp.round_quiet_s * 1e6) + 1;
  for (const KeyframeBatch& b : ShiftedPairBatches(40, 5, 1000)) REQUIRE(link.OnKeyframeBatch(b, now).ok());
  CHECK_FALSE(link.Settled(now + quiet));  // no round yet
  run_round();
  CHECK(link.Settled(now + quiet));

  // One more keyframe of robot 1 after that round: the quiet alone does not settle the server ...
  std::mt19937 rng(11);
  KeyframeBatch late = MakeBatch(1, 40, {RandomDescriptor(&rng)}, {Eigen::Vector3d(-40.0, 3.0, 0.0)}, 3000);
  late.session = 1001;
  late.sequence = 1;
  REQUIRE(link.OnKeyframeBatch(late, now).ok());
  now += quiet;
  CHECK_FALSE(link.Settled(now));
  // ... a round that saw it does.
  run_round();
  CHECK(link.Settled(now + quiet));
}

TEST_CASE("Server link: rounds that take longer than their interval still let every robot's status out") {
  // Keyframes keep arriving and each poll that does round work costs 2.5 round intervals of wall time (a slow
  // registration), so a new round is due at every poll after one: between two rounds each robot must still get
  // a status (its acknowledgements), or it sends everything again.
  MergeServerParams mp = PaperStageA(100);
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, mp);
  MergeServer& server = *server_owner;
  ServerLinkParams lp;
  lp.round_interval_s = 1.0;
  lp.round_min_new_keyframes = 1;
  ServerLink link(500, lp, &server);
  std::int64_t now = 1000000;
  for (const KeyframeBatch& b : ShiftedPairBatches(40, 5, 1000)) REQUIRE(link.OnKeyframeBatch(b, now).ok());
  std::mt19937 rng(5);
  std::vector<int> statuses_since_round_start(2, 0);
  int round_starts = 0, rounds_checked = 0;
  std::vector<ServerOutgoing> out;
  for (std::uint32_t k = 40; k < 100; ++k) {
    KeyframeBatch more =
        MakeBatch(1, k, {RandomDescriptor(&rng)}, {Eigen::Vector3d(-static_cast<double>(k), 3.0, 0.0)}, 3000);
    more.session = 1001;
    more.sequence = static_cast<std::int32_t>(k - 39);
    REQUIRE(link.OnKeyframeBatch(more, now).ok());
    const std::uint64_t started = link.stats().rounds_started, merged = link.stats().rounds_merged;
    const std::uint64_t widened = link.stats().widened_pairs;
    out.clear();
    REQUIRE(link.Poll(now, &out).ok());
    (void)AnswerWithTinyScans(&link, out, now);
    if (link.stats().rounds_started > started) {
      if (++round_starts > 1) {
        ++rounds_checked;
        CHECK(*std::min_element(statuses_since_round_start.begin(), statuses_since_round_start.end()) >= 1);
      }
      std::fill(statuses_since_round_start.begin(), statuses_since_round_start.end(), 0);
    }
    for (const ServerOutgoing& o : out) {
      if (o.kind == ServerOutgoing::Kind::kTransferStatus) ++statuses_since_round_start[o.status.robot_id];
    }
    const bool round_work = link.stats().rounds_started > started || link.stats().rounds_merged > merged ||
                            link.stats().widened_pairs > widened;
    now += round_work ? static_cast<std::int64_t>(2.5 * lp.round_interval_s * 1e6) : 100000;
  }
  CHECK(link.stats().rounds_merged >= 5);
  CHECK(rounds_checked >= 5);
}

TEST_CASE("Server link: the status columns give each robot with a session its keyframes, scans and descriptor id") {
  const std::uint32_t kId = 0x761BEAA5u, kOtherId = 0x12345678u;
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(3, 100, MergeServerParams{});
  MergeServer& server = *server_owner;
  ServerLinkParams lp;
  lp.automatic_rounds = false;
  ServerLink link(500, lp, &server);
  std::vector<KeyframeBatch> batches = ShiftedPairBatches(40, 5, 1000);
  batches[1] = ShiftedPairBatches(25, 5, 1000)[1];
  batches[0].descriptor_id = kId;
  batches[1].descriptor_id = kOtherId;
  batches[1].robot_id = 2;  // robot 1 never speaks: no session, no column
  for (const KeyframeBatch& b : batches) REQUIRE(link.OnKeyframeBatch(b, 1000000).ok());
  const std::vector<std::uint8_t> scan = EncodeForTest(LatticePoints(200));
  for (const ScanChunk& c : ChunksOf(2, 3, scan, 700)) REQUIRE(server.OnScanChunk(c).ok());
  REQUIRE(server.has_scan(2, 3));

  ServerStatus status;
  link.AppendRobotStatus(&status);
  CHECK(status.robot_ids == std::vector<int>{0, 2});
  CHECK(status.keyframes == std::vector<std::uint32_t>{40, 25});
  CHECK(status.scans == std::vector<std::uint32_t>{0, 1});
  CHECK(status.chunks_missing == std::vector<std::uint32_t>{0, 0});
  CHECK(status.descriptor_ids == std::vector<std::uint32_t>{kId, kOtherId});
}

TEST_CASE("Server link: a refused pair is widened, the extra scans are asked for, and it is registered again") {
  const int n = 40, shift = 5;
  std::vector<std::uint32_t> pool_a, pool_b;  // L_seq's endpoints
  for (int i = shift; i < n; ++i) pool_a.push_back(static_cast<std::uint32_t>(i));
  for (int j = 0; j + shift < n; ++j) pool_b.push_back(static_cast<std::uint32_t>(j));
  for (int steps : {0, 1, 2}) {
    CAPTURE(steps);
    MergeServerParams mp = PaperStageA(100);
    mp.max_widen_steps = steps;
    std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, mp);
    MergeServer& server = *server_owner;
    ServerLinkParams lp;
    lp.automatic_rounds = false;
    ServerLink link(500, lp, &server);
    std::int64_t now = 1000000;
    for (const KeyframeBatch& b : ShiftedPairBatches(n, shift, 1000)) REQUIRE(link.OnKeyframeBatch(b, now).ok());
    link.RequestRound();
    std::vector<ServerOutgoing> out;
    REQUIRE(link.Poll(now, &out).ok());
    std::vector<ScanRequest> asked = AnswerWithTinyScans(&link, out, now);
    REQUIRE(asked.size() == 2);
    // The poll after that round work sends the robots' statuses (due since they never had one) before the round
    // goes on.
    out.clear();
    now += 100000;
    REQUIRE(link.Poll(now, &out).ok());
    CHECK(std::count_if(out.begin(), out.end(), [](const ServerOutgoing& o) {
            return o.kind == ServerOutgoing::Kind::kTransferStatus;
          }) == 2);
    CHECK(link.stats().widened_pairs == 0);
    CHECK(FindResult(out) == nullptr);
    std::vector<std::uint32_t> selected_a = asked[0].keyframes, selected_b = asked[1].keyframes;
    std::size_t scans_sent = selected_a.size() + selected_b.size();
    for (int step = 1; step <= steps; ++step) {
      CAPTURE(step);
      out.clear();
      now += 100000;
      REQUIRE(link.Poll(now, &out).ok());
      CHECK(FindResult(out) == nullptr);
      CHECK(link.round_active());
      CHECK(link.stats().widened_pairs == static_cast<std::uint64_t>(step));
      // The new requests name exactly the keyframes the doubled selection adds.
      const std::vector<std::uint32_t> wider_a = BruteForceWiden(selected_a, pool_a, 2 * selected_a.size());
      const std::vector<std::uint32_t> wider_b = BruteForceWiden(selected_b, pool_b, 2 * selected_b.size());
      asked = AnswerWithTinyScans(&link, out, now);
      REQUIRE(asked.size() == 2);
      std::vector<std::uint32_t> new_a, new_b;
      std::set_difference(wider_a.begin(), wider_a.end(), selected_a.begin(), selected_a.end(), std::back_inserter(new_a));
      std::set_difference(wider_b.begin(), wider_b.end(), selected_b.begin(), selected_b.end(), std::back_inserter(new_b));
      CHECK(asked[0].keyframes == new_a);
      CHECK(asked[1].keyframes == new_b);
      selected_a = wider_a;
      selected_b = wider_b;
      scans_sent += new_a.size() + new_b.size();
    }
    out.clear();
    now += 100000;
    REQUIRE(link.Poll(now, &out).ok());
    const MergeResultMessage* result = FindResult(out);
    REQUIRE(result != nullptr);
    CHECK_FALSE(link.round_active());
    CHECK(link.stats().widened_pairs == static_cast<std::uint64_t>(steps));
    REQUIRE(result->pairs.size() == 1);
    CHECK_FALSE(result->pairs[0].success);
    CHECK(result->pairs[0].alpha_scans + result->pairs[0].beta_scans == scans_sent);
    CHECK(result->pairs[0].alpha_scans == selected_a.size());
  }
}

TEST_CASE("Reliable transfer: a restarted robot replaces its keyframes, and its old session is refused") {
  Mission m(2, 12, LinkModel{}, 4, SendAllParams());
  m.RunUntil(600000);
  const std::size_t before = m.merge_->robot(1).size();
  CHECK(before > 0);
  // A late message of the old session after the restart is stale.
  KeyframeBatch old_batch;
  old_batch.robot_id = 1;
  old_batch.session = 1001;
  m.RestartRobot(1, 2001);  // maps from scratch
  m.RunUntil(40000000);
  m.CheckAllKeyframesDelivered();
  m.CheckAllScansDelivered();
  CHECK(m.server_->stats().robot_restarts == 1);
  CHECK(m.server_->robot_session(1) == 2001);
  const std::uint64_t stale = m.server_->stats().stale_messages;
  CHECK_FALSE(m.server_->OnKeyframeBatch(old_batch, m.now_us_).ok());
  CHECK(m.server_->stats().stale_messages == stale + 1);
  CHECK(m.merge_->robot(1).size() == m.robots_[1]->agent->mapper().num_keyframes());
}

TEST_CASE("Reliable transfer: a robot restarted after a merge leaves the world frame until it is merged again") {
  Mission m(2, 12, LinkModel{}, 4, SendAllParams());
  m.RunUntil(40000000);
  REQUIRE(m.merge_results_ >= 1);
  const auto in_world = [&m](int robot) {
    const MergeResultMessage& r = m.server_->last_result();
    for (std::size_t i = 0; i < r.robot_ids.size(); ++i) {
      if (r.robot_ids[i] == robot) return r.in_world[i] != 0;
    }
    return false;
  };
  REQUIRE(in_world(1));
  const int rounds = m.server_->rounds_merged();
  m.RestartRobot(1, 2001);  // its new map frame is unrelated to the old one
  m.RunUntil(m.now_us_ + 300000);
  REQUIRE(m.server_->robot_session(1) == 2001);
  CHECK(m.server_->rounds_merged() == rounds);
  CHECK_FALSE(in_world(1));
  CHECK(in_world(0));  // robot 0's map is the world frame
  m.RunUntil(m.now_us_ + 40000000);
  CHECK(m.server_->rounds_merged() > rounds);
  CHECK(in_world(1));
}

TEST_CASE("Reliable transfer: a robot that left is asked for nothing and the round does not wait for it") {
  // Robot 0 ends (its process exits) as the first round starts, before it sent a scan. Told so (its last status
  // says "merged"), the server withdraws its request and merges at once with what it holds; not told, the round
  // waits the whole request_timeout_s (600 s here) for scans nobody will send: the control.
  for (const bool told : {false, true}) {
    CAPTURE(told);
    Mission m(2, 12, LinkModel{}, 5, SendAllParams());
    while (!m.server_->round_active() && m.now_us_ < 20000000) m.RunUntil(m.now_us_ + kTickUs);
    REQUIRE(m.server_->round_active());
    const int results = m.merge_results_;
    m.Leave(0);
    if (told) {
      m.server_->OnRobotLeft(0, 999);  // another session: ignored
      CHECK_FALSE(m.server_->robot_left(0));
      m.server_->OnRobotLeft(0, 1000);
      CHECK(m.server_->robot_left(0));
    }
    m.RunUntil(m.now_us_ + 20000000);
    if (!told) {
      CHECK(m.server_->round_active());
      CHECK(m.merge_results_ == results);
      CHECK(m.requests_to_gone_ > 0);  // repeated every policy_repeat_s
      continue;
    }
    CHECK_FALSE(m.server_->round_active());
    CHECK(m.merge_results_ == results + 1);
    CHECK(m.server_->stats().rounds_timed_out == 0);
    CHECK(m.requests_to_gone_ == 0);
    const MergeResultMessage& r = m.server_->last_result();
    REQUIRE(r.pairs.size() == 1);
    CHECK_FALSE(r.pairs[0].success);
    CHECK(r.pairs[0].verdict.find("no selected scan was received") != std::string::npos);
    // A restart of robot 0 (a new session) is asked again.
    m.RestartRobot(0, 1001);
    m.gone_[0] = 0;
    m.RunUntil(m.now_us_ + 500000);
    CHECK(m.server_->robot_session(0) == 1001);
    CHECK_FALSE(m.server_->robot_left(0));
  }
}

TEST_CASE("Reliable transfer: after a robot left, later rounds register with the scans held and keep it merged") {
  // Robot 0 maps 12 scans, robot 1 24 on the same street. Round 1 runs (requested) when robot 1 is half way and
  // places it; robot 0 then leaves. Round 2 (robot 1's new keyframes) asks robot 0 for nothing and registers with
  // the scans the server holds. (When a round holds none of the scans it selects of one robot, the pair keeps
  // the earlier round's result: KeepVerifiedPairs, tested on its own.)
  ServerLinkParams params = SendAllParams();
  params.mode = ExchangeMode::kStageABC;
  params.request_timeout_s = 5.0;
  Mission m(2, 24, LinkModel{}, 6, params);
  m.scans_per_robot_ = {12, 24};
  m.RunUntil(1500000);
  m.server_->RequestRound();
  while (m.server_->rounds_merged() < 1 && m.now_us_ < 20000000) m.RunUntil(m.now_us_ + kTickUs);
  REQUIRE(m.server_->rounds_merged() == 1);
  const MergeResultMessage first = m.server_->last_result();
  REQUIRE(first.in_world.size() == 2);
  REQUIRE(first.in_world[1] == 1);
  REQUIRE(first.keyframes[1] < 24);
  m.Leave(0);
  m.server_->OnRobotLeft(0, 1000);
  m.RunUntil(m.now_us_ + 30000000);
  REQUIRE(m.server_->rounds_merged() >= 2);
  const MergeResultMessage& r = m.server_->last_result();
  CHECK(r.keyframes[1] == m.robots_[1]->agent->mapper().num_keyframes());
  CHECK(r.in_world[1] == 1);
  CHECK(m.requests_to_gone_ == 0);
  CHECK(m.server_->stats().rounds_timed_out == 0);
  const Eigen::Isometry3d d = first.T_world_map[1].inverse() * r.T_world_map[1];
  CHECK(d.translation().norm() < 0.3);
}

TEST_CASE("Reliable transfer: a recorded mission replayed into a fresh server reproduces the merge") {
  ServerLinkParams params = SendAllParams();
  params.mode = ExchangeMode::kStageABC;
  Mission m(2, 12, LinkModel{}, 4, params);
  m.RunUntil(40000000);
  const MergeResultMessage& original = m.server_->last_result();
  REQUIRE(original.robot_ids.size() == 2);
  REQUIRE(original.in_world[1] == 1);
  // The replayed server computes its own plan; no robot answers it, so it takes the recorded answers to the
  // recording server's requests. Those may carry other request ids (the recording server's round 3, say).
  std::vector<std::pair<std::int64_t, RobotOutgoing>> recorded = m.recorded_;
  for (auto& [t, msg] : recorded) {
    if (msg.kind == RobotOutgoing::Kind::kScanChunk) msg.chunk.request_id += 40;
  }
  params.accept_unrequested_scans = true;
  for (const auto* log : {&m.recorded_, &recorded}) {
    const MergeResultMessage replayed = Replay(*log, params);
    REQUIRE(replayed.robot_ids == original.robot_ids);
    CHECK(replayed.in_world == original.in_world);
    for (std::size_t i = 0; i < original.robot_ids.size(); ++i) {
      CAPTURE(i);
      CHECK((replayed.T_world_map[i].matrix() - original.T_world_map[i].matrix()).cwiseAbs().maxCoeff() < 1e-9);
    }
  }
  // Live rules refuse chunks that answer another request: the robot is not merged.
  params.accept_unrequested_scans = false;
  params.request_timeout_s = 5.0;
  const MergeResultMessage live_rules = Replay(recorded, params);
  REQUIRE(live_rules.in_world.size() == 2);
  CHECK(live_rules.in_world[1] == 0);
}

TEST_CASE("Reliable transfer: a replay that follows the recorded round steps reproduces every round and request") {
  // Three robots, loss, duplicates and reordering, rounds every second: messages keep arriving between a
  // round's steps, so where a step cuts the data matters.
  ServerLinkParams params = SendAllParams();
  params.mode = ExchangeMode::kStageABC;
  params.round_interval_s = 1.0;
  params.round_min_new_keyframes = 8;
  params.request_timeout_s = 3.0;
  Mission m(3, 48, LinkModel{0.1, 0.05, 20000, 60000}, 11, params);
  m.RunUntil(60000000);
  REQUIRE(m.server_->rounds_merged() >= 3);
  REQUIRE(m.steps_.size() >= 6);
  const MergeResultMessage& original = m.server_->last_result();
  REQUIRE(original.in_world.size() == 3);
  for (std::size_t late : {std::size_t{0}, std::size_t{7}, std::size_t{40}}) {
    CAPTURE(late);
    const StepReplay replay = ReplaySteps(m.recorded_, m.steps_, late, 3);
    CHECK(replay.mismatches.empty());
    if (!replay.mismatches.empty()) MESSAGE(replay.mismatches.front());
    REQUIRE(replay.steps.size() == m.steps_.size());
    for (std::size_t i = 0; i < replay.steps.size(); ++i) {
      CAPTURE(i);
      CHECK(RoundStepMismatch(m.steps_[i].second, replay.steps[i]).empty());
      CHECK(replay.steps[i].requests.size() == m.steps_[i].second.requests.size());
    }
    REQUIRE(replay.result.round == original.round);
    CHECK(replay.result.in_world == original.in_world);
    for (std::size_t r = 0; r < original.robot_ids.size(); ++r) {
      CHECK((replay.result.T_world_map[r].matrix() - original.T_world_map[r].matrix()).cwiseAbs().maxCoeff() == 0.0);
    }
  }
  // A log that lacks one of robot 1's keyframe batches: the step that had taken it says so, by robot and count.
  std::vector<std::pair<std::int64_t, RobotOutgoing>> lacking = m.recorded_;
  std::vector<std::pair<std::size_t, RoundStep>> steps = m.steps_;
  for (std::size_t i = 0; i < lacking.size(); ++i) {
    if (lacking[i].second.kind != RobotOutgoing::Kind::kKeyframeBatch || lacking[i].second.batch.robot_id != 1) continue;
    lacking.erase(lacking.begin() + static_cast<std::ptrdiff_t>(i));
    for (auto& [at, step] : steps) at -= at > i ? 1 : 0;
    break;
  }
  const StepReplay broken = ReplaySteps(lacking, steps, 0, 3);
  REQUIRE(!broken.mismatches.empty());
  MESSAGE(broken.mismatches.front());
  CHECK(broken.mismatches.front().find("robot 1 input: recorded session 1001") != std::string::npos);
}

TEST_CASE("Reliable transfer: a refused message of a newer session neither resets the robot nor locks it out") {
  // Found by the server-inbox fuzzer: the newer session used to be adopted (wiping the robot) before the message
  // was validated, and the robot's real session was refused as stale from then on.
  Mission m(2, 6, LinkModel{}, 3, SendAllParams());
  m.RunUntil(2000000);
  const std::size_t held = m.merge_->robot(0).size();
  REQUIRE(held > 0);
  const std::int64_t session = m.server_->robot_session(0);
  PoseUpdate beyond;  // a keyframe beyond the server's capacity (64)
  beyond.robot_id = 0;
  beyond.session = session + 1;
  beyond.keyframes = {100000};
  beyond.T_map_sensor = {Eigen::Isometry3d::Identity()};
  CHECK_FALSE(m.server_->OnPoseUpdate(beyond, m.now_us_).ok());
  KeyframeBatch corrupt;  // one record whose bytes decode to nothing valid
  corrupt.robot_id = 0;
  corrupt.session = session + 2;
  corrupt.records.assign(kKeyframeRecordBytes, 0xff);
  corrupt.stored_points = {10};
  CHECK_FALSE(m.server_->OnKeyframeBatch(corrupt, m.now_us_).ok());
  CHECK(m.server_->robot_session(0) == session);
  CHECK(m.server_->stats().robot_restarts == 0);
  CHECK(m.merge_->robot(0).size() == held);
  m.RunUntil(40000000);  // the real session goes on
  m.CheckAllKeyframesDelivered();
}
