// SPDX-License-Identifier: BSD-3-Clause
// The server agent: malformed messages are refused and counted without changing the state; scan chunks are
// reassembled whatever their order, de-duplicated and CRC-checked; plans per exchange mode match stage A's
// loops computed by brute force; a pair's submaps built from received scans register to the ground truth.
#include <doctest/doctest.h>

#include <algorithm>
#include <set>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "tests/core/agent/keyframe_batch_fixtures.hpp"
#include "tests/core/agent/scan_chunk_fixtures.hpp"
#include "tests/core/registration/registration_test_support.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/server_link.hpp"
#include "core/cloud/scan_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/geometry/angles.hpp"

using namespace commerge;
using commerge::test::ChunksOf;
using commerge::test::EncodeForTest;
using commerge::test::LatticePoints;
using commerge::test::MakeBatch;
using commerge::test::BruteForceWiden;
using commerge::test::RandomDescriptor;
using commerge::test::ShiftedPairBatches;

namespace {

// The paper's stage A (B_ij = [A_ij <= tau_inter]) at span area `tau_area`, every other server default.
MergeServerParams PaperStageA(std::uint64_t tau_area) {
  MergeServerParams params;
  params.cascade.stage_a = SequentialMatchParams{};
  params.cascade.stage_a.tau_area = tau_area;
  return params;
}


// A server (stage A's tau_area 100) holding ShiftedPairBatches(n, shift), its cascades run.
std::unique_ptr<MergeServer> ShiftedPairServer(int n, int shift) {
  MergeServerParams params = PaperStageA(100);
  auto server = std::make_unique<MergeServer>(2, 100, params);
  for (const KeyframeBatch& b : ShiftedPairBatches(n, shift)) REQUIRE(server->OnKeyframeBatch(b).ok());
  REQUIRE(server->RunCascades().ok());
  return server;
}

// Robot alpha's and robot beta's keyframes selected for one registration.
PairSelection Selection(int alpha, int beta, std::vector<std::uint32_t> alpha_keyframes,
                        std::vector<std::uint32_t> beta_keyframes) {
  PairSelection sel;
  sel.alpha = alpha;
  sel.beta = beta;
  sel.alpha_keyframes = std::move(alpha_keyframes);
  sel.beta_keyframes = std::move(beta_keyframes);
  return sel;
}

PairMergeResult Refused(int alpha, int beta, RegistrationVerdict verdict = RegistrationVerdict::kOverlapTooLow) {
  PairMergeResult r;
  r.alpha = alpha;
  r.beta = beta;
  r.attempted = true;
  r.registration.verdict = verdict;
  return r;
}

}  // namespace

TEST_CASE("Merge server refuses malformed keyframe batches and pose updates and counts them") {
  MergeServer server(2, 100, MergeServerParams{});
  std::mt19937 rng(1);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d = {RandomDescriptor(&rng), RandomDescriptor(&rng)};
  std::vector<Eigen::Vector3d> pos = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)};
  KeyframeBatch good = MakeBatch(0, 0, d, pos, 1000);

  KeyframeBatch foreign = good;
  foreign.robot_id = 2;  // the server was sized for robots 0 and 1
  CHECK(server.OnKeyframeBatch(foreign).code() == StatusCode::kInvalidArgument);
  KeyframeBatch ragged = good;
  ragged.records.pop_back();
  CHECK_FALSE(server.OnKeyframeBatch(ragged).ok());
  CHECK(server.stats().rejected_batches == 2);
  CHECK(server.robot(0).size() == 0);

  // One corrupt record: the other is kept, the corrupt one counted.
  KeyframeBatch corrupt = good;
  corrupt.records[kKeyframeRecordBytes + 20] ^= 0xff;
  corrupt.records[kKeyframeRecordBytes + 21] ^= 0xff;
  const Status st = server.OnKeyframeBatch(corrupt);
  const bool second_refused = !st.ok();
  CHECK(server.robot(0).size() >= 1);
  CHECK(server.robot(0).valid[0] == 1);
  CHECK(server.stats().rejected_records == (second_refused ? 1u : 0u));

  // A keyframe index beyond the server's capacity is refused, not allocated.
  MergeServer small(2, 1, MergeServerParams{});
  CHECK(small.OnKeyframeBatch(good).code() == StatusCode::kResourceExhausted);
  CHECK(small.robot(0).size() == 1);

  PoseUpdate update;
  update.robot_id = 0;
  update.keyframes = {0, 1};
  update.T_map_sensor = {Eigen::Isometry3d::Identity()};
  CHECK_FALSE(server.OnPoseUpdate(update).ok());  // counts differ
  update.T_map_sensor.push_back(Eigen::Isometry3d::Identity());
  update.T_map_sensor[1].translation().x() = std::nan("");
  CHECK_FALSE(server.OnPoseUpdate(update).ok());  // non-finite pose: nothing applied
  CHECK(server.stats().rejected_pose_updates == 2);
  update.T_map_sensor[1] = Eigen::Isometry3d::Identity();
  update.T_map_sensor[1].translation() = Eigen::Vector3d(5, 6, 7);
  REQUIRE(server.OnPoseUpdate(update).ok());
  CHECK(server.robot(0).T_map_sensor[1].translation().isApprox(Eigen::Vector3d(5, 6, 7)));
}

TEST_CASE("Merge server compares only robots of one descriptor id and refuses a batch that changes its robot's id") {
  // Three robots: 0 and 1 see the same places (stage A's loops are known), robot 2 the same places too but with
  // another descriptor id (a robot started with another --lidar): its descriptors are not comparable.
  const int n = 40, shift = 5;
  const std::uint32_t kId = 0x761BEAA5u, kOtherId = 0x12345678u;
  MergeServerParams params = PaperStageA(100);
  MergeServer server(3, 100, params);
  std::vector<KeyframeBatch> batches = ShiftedPairBatches(n, shift);
  REQUIRE(batches.size() == 2);
  KeyframeBatch third = batches[1];
  third.robot_id = 2;
  batches[0].descriptor_id = kId;
  batches[1].descriptor_id = kId;
  third.descriptor_id = kOtherId;
  for (const KeyframeBatch& b : batches) REQUIRE(server.OnKeyframeBatch(b).ok());
  REQUIRE(server.OnKeyframeBatch(third).ok());
  CHECK(server.robot(0).descriptor_id == kId);
  CHECK(server.robot(2).descriptor_id == kOtherId);

  REQUIRE(server.RunCascades().ok());
  // The control: robots 0 and 1 (same id) have their cascade, with stage A's loops.
  REQUIRE(server.cascade(0, 1) != nullptr);
  CHECK(server.cascade(0, 1)->stage_a.found);
  // Robot 2 holds the same descriptors as robot 1, so only the id keeps its pairs out.
  CHECK(server.cascade(0, 2) == nullptr);
  CHECK(server.cascade(1, 2) == nullptr);
  const std::vector<std::pair<int, int>> want = {{0, 2}, {1, 2}};
  CHECK(server.incomparable_pairs() == want);
  auto plan = server.Plan(ExchangeMode::kStageABC);
  REQUIRE(plan.ok());
  REQUIRE(plan->pairs.size() == 1);
  CHECK(plan->pairs[0].alpha == 0);
  CHECK(plan->pairs[0].beta == 1);

  // Within a session a robot's id cannot change: the batch is refused, counted and applies nothing.
  std::mt19937 rng(3);
  KeyframeBatch changed = MakeBatch(0, static_cast<std::uint32_t>(n), {RandomDescriptor(&rng)},
                                    {Eigen::Vector3d(1, 2, 3)}, 500);
  changed.descriptor_id = kOtherId;
  const std::uint64_t rejected = server.stats().rejected_batches;
  CHECK(server.CheckKeyframeBatch(changed).ok());  // what a new session of the robot, reset first, would accept
  const Status st = server.OnKeyframeBatch(changed);
  CHECK(st.code() == StatusCode::kInvalidArgument);
  CHECK(st.message().find("0x12345678") != std::string::npos);
  CHECK(st.message().find("0x761BEAA5") != std::string::npos);
  CHECK(server.stats().rejected_batches == rejected + 1);
  CHECK(server.robot(0).size() == static_cast<std::size_t>(n));
  // Id 0 (unknown) conflicts with nothing; the robot's id stays.
  changed.descriptor_id = 0;
  CHECK(server.OnKeyframeBatch(changed).ok());
  CHECK(server.robot(0).size() == static_cast<std::size_t>(n) + 1);
  CHECK(server.robot(0).descriptor_id == kId);
  // A new session (ResetRobot) may bring another id: robot 2 restarted with the team's setting joins in.
  server.ResetRobot(2);
  CHECK(server.robot(2).descriptor_id == 0u);
  third.descriptor_id = kId;
  REQUIRE(server.OnKeyframeBatch(third).ok());
  REQUIRE(server.RunCascades().ok());
  CHECK(server.incomparable_pairs().empty());
  CHECK(server.cascade(1, 2) != nullptr);
}

TEST_CASE("Server link: a robot restarted with the team's descriptor setting is adopted, within a session its id is held") {
  const std::uint32_t kId = 0x761BEAA5u, kOtherId = 0x12345678u;
  MergeServerParams mp = PaperStageA(100);
  MergeServer server(2, 100, mp);
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
  MergeServer server(2, 100, mp);
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

TEST_CASE("Server link: the status columns give each robot with a session its keyframes, scans and descriptor id") {
  const std::uint32_t kId = 0x761BEAA5u, kOtherId = 0x12345678u;
  MergeServer server(3, 100, MergeServerParams{});
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

TEST_CASE("Merge server reassembles scan chunks in any order, ignores duplicates and refuses corrupt scans") {
  MergeServerParams params;
  params.max_scan_bytes = 1 << 16;
  MergeServer server(2, 100, params);
  const std::vector<std::uint8_t> scan = EncodeForTest(LatticePoints(1000));  // 6012 bytes
  std::vector<ScanChunk> chunks = ChunksOf(1, 4, scan, 700);
  REQUIRE(chunks.size() == 9);
  std::reverse(chunks.begin(), chunks.end());
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    REQUIRE(server.OnScanChunk(chunks[i]).ok());
    if (i == 3) REQUIRE(server.OnScanChunk(chunks[i]).ok());  // a retransmission
    CHECK(server.has_scan(1, 4) == (i + 1 == chunks.size()));
  }
  CHECK(server.stats().duplicate_chunks == 1);
  CHECK(server.OnScanChunk(chunks[0]).ok());  // after completion: a duplicate too
  CHECK(server.stats().duplicate_chunks == 2);
  CHECK(server.scans_received() == 1);
  CHECK(server.scan_bytes_held() == scan.size());

  // A flipped payload byte: the CRC refuses the scan, which is not kept.
  std::vector<ScanChunk> bad = ChunksOf(0, 2, scan, 700);
  bad[3].payload[5] ^= 0x01;
  Status last;
  for (const ScanChunk& c : bad) last = server.OnScanChunk(c);
  CHECK(last.code() == StatusCode::kDataLoss);
  CHECK_FALSE(server.has_scan(0, 2));
  CHECK(server.stats().corrupt_scans == 1);
  CHECK(server.scan_bytes_held() == scan.size());

  // A payload of the wrong size for its index, and an index beyond the count: refused, nothing held for them.
  std::vector<ScanChunk> odd = ChunksOf(0, 3, scan, 700);
  odd[1].payload.pop_back();
  CHECK(server.OnScanChunk(odd[1]).code() == StatusCode::kInvalidArgument);
  CHECK(server.scan_bytes_held() == scan.size());
  odd[2].chunk_index = odd[2].num_chunks;
  CHECK_FALSE(server.OnScanChunk(odd[2]).ok());

  // The byte budget: scans beyond max_scan_bytes are refused and counted.
  std::size_t refused = 0;
  for (std::uint32_t k = 10; k < 30; ++k) {
    for (const ScanChunk& c : ChunksOf(1, k, scan, 1200)) refused += !server.OnScanChunk(c).ok();
  }
  CHECK(refused > 0);
  CHECK(server.stats().chunks_over_budget > 0);
  CHECK(server.scan_bytes_held() <= params.max_scan_bytes);
  server.ClearScans();
  CHECK(server.scans_received() == 0);
  CHECK(server.scan_bytes_held() == 0);
}

TEST_CASE("Merge server bounds the number of scans it holds, whatever their size") {
  MergeServerParams params;
  params.max_scans_held = 3;
  MergeServer server(2, 100, params);
  const std::vector<std::uint8_t> tiny = EncodeForTest(LatticePoints(2));
  std::size_t accepted = 0;
  for (std::uint32_t k = 0; k < 6; ++k) {
    for (const ScanChunk& c : ChunksOf(0, k, tiny, 1200)) accepted += server.OnScanChunk(c).ok();
  }
  CHECK(accepted == 3);
  CHECK(server.scans_received() == 3);
  CHECK(server.stats().chunks_over_budget == 3);
}

TEST_CASE("Merge server plans per exchange mode: stage A's loops equal the brute-force threshold cells") {
  const int n = 40, shift = 5;
  const std::unique_ptr<MergeServer> owned = ShiftedPairServer(n, shift);
  MergeServer& server = *owned;
  const MergeServerParams& params = server.params();
  const ExchangeCascadeResult* cascade = server.cascade(0, 1);
  REQUIRE(cascade != nullptr);
  REQUIRE(cascade->stage_a.found);

  // Brute force over the decoded descriptors: the cells within tau_inter.
  std::vector<std::uint32_t> want_a, want_b;
  const RobotKeyframeDb& A = server.robot(0);
  const RobotKeyframeDb& B = server.robot(1);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      double s = 0.0;
      for (std::size_t k = 0; k < kKeyframeDescriptorDim; ++k) {
        const float a_k = A.descriptors[static_cast<std::size_t>(i) * kKeyframeDescriptorDim + k];
        const float b_k = B.descriptors[static_cast<std::size_t>(j) * kKeyframeDescriptorDim + k];
        const double diff = static_cast<double>(a_k) - static_cast<double>(b_k);
        s += diff * diff;
      }
      if (std::sqrt(s) <= params.cascade.stage_a.tau_inter) {
        want_a.push_back(static_cast<std::uint32_t>(i));
        want_b.push_back(static_cast<std::uint32_t>(j));
      }
    }
  }
  REQUIRE(want_a.size() == static_cast<std::size_t>(n - shift));
  for (std::size_t c = 0; c < want_a.size(); ++c) CHECK(want_a[c] == want_b[c] + shift);

  auto plan_a = server.Plan(ExchangeMode::kStageA);
  REQUIRE(plan_a.ok());
  REQUIRE(plan_a->pairs.size() == 1);
  CHECK(plan_a->pairs[0].alpha_keyframes == want_a);
  CHECK(plan_a->pairs[0].beta_keyframes == want_b);
  REQUIRE(plan_a->requests.size() == 2);
  CHECK(plan_a->predicted_scan_bytes == want_a.size() * EncodedScanBytes(2000) + want_b.size() * EncodedScanBytes(3000));

  auto plan_all = server.Plan(ExchangeMode::kSendAll);
  REQUIRE(plan_all.ok());
  REQUIRE(plan_all->requests.size() == 2);
  CHECK(plan_all->requests[0].keyframes.size() == static_cast<std::size_t>(n));
  CHECK(plan_all->requests[1].keyframes.size() == static_cast<std::size_t>(n));
  // send-all registers the complete maps: every keyframe of both robots, whatever stage A found.
  REQUIRE(plan_all->pairs.size() == 1);
  CHECK(plan_all->pairs[0].alpha_keyframes == plan_all->requests[0].keyframes);
  CHECK(plan_all->pairs[0].beta_keyframes == plan_all->requests[1].keyframes);

  // Stage B's cover and the full cascade select subsets of stage A's keyframes; the full policy is the
  // cascade's.
  auto plan_b = server.Plan(ExchangeMode::kStageAB);
  auto plan_abc = server.Plan(ExchangeMode::kStageABC);
  auto plan_ac = server.Plan(ExchangeMode::kStageAC);
  REQUIRE(plan_b.ok());
  REQUIRE(plan_abc.ok());
  REQUIRE(plan_ac.ok());
  auto subset = [](const std::vector<std::uint32_t>& s, const std::vector<std::uint32_t>& of) {
    return std::includes(of.begin(), of.end(), s.begin(), s.end());
  };
  CHECK(subset(plan_b->pairs[0].alpha_keyframes, want_a));
  CHECK(subset(plan_b->pairs[0].beta_keyframes, want_b));
  CHECK(plan_b->pairs[0].alpha_keyframes.size() + plan_b->pairs[0].beta_keyframes.size() ==
        static_cast<std::size_t>(cascade->stage_b.objective_scans));
  CHECK(plan_abc->pairs[0].alpha_keyframes == cascade->policy.alpha.keyframes);
  CHECK(plan_abc->pairs[0].beta_keyframes == cascade->policy.beta.keyframes);
  CHECK(subset(plan_ac->pairs[0].alpha_keyframes, want_a));
  CHECK_FALSE(plan_ac->pairs[0].alpha_keyframes.empty());

  // One padding rule for every mode: each robot's selection grows to min_scans_per_robot (10) with stage A's
  // keyframes; the plan counts what the mode selected and what padding added, which add up to the requests.
  const std::size_t min_scans = params.cascade.policy.min_scans_per_robot;
  REQUIRE(min_scans == 10);
  const auto requested = [](const ExchangePlan& p) {
    std::size_t scans = 0;
    for (const ScanRequest& q : p.requests) scans += q.keyframes.size();
    return scans;
  };
  for (const ExchangePlan* p : {&*plan_a, &*plan_all, &*plan_b, &*plan_ac, &*plan_abc}) {
    CAPTURE(ExchangeModeName(p->mode));
    CHECK(p->selected_scans + p->padded_scans == requested(*p));
    for (const auto* side : {&p->pairs[0].alpha_keyframes, &p->pairs[0].beta_keyframes}) {
      CHECK(side->size() >= std::min(min_scans, want_a.size()));
    }
  }
  CHECK(plan_all->padded_scans == 0);
  CHECK(plan_all->selected_scans == static_cast<std::size_t>(2 * n));
  CHECK(plan_a->padded_scans == 0);  // every L_seq endpoint is selected already
  CHECK(plan_b->selected_scans == static_cast<std::size_t>(cascade->stage_b.objective_scans));
  std::size_t l_k_endpoints = 0;
  {
    std::set<std::size_t> ka, kb;
    for (const SequentialLoopCell& l : cascade->stage_c.selected_loops) {
      ka.insert(l.alpha_index);
      kb.insert(l.beta_index);
    }
    l_k_endpoints = ka.size() + kb.size();
  }
  CHECK(plan_abc->selected_scans == l_k_endpoints);
  CHECK(plan_abc->padded_scans == cascade->policy.alpha.padded_scans + cascade->policy.beta.padded_scans);
  for (const ExchangePlan* p : {&*plan_b, &*plan_ac, &*plan_abc}) {  // padding only adds stage A's keyframes
    CHECK(subset(p->pairs[0].alpha_keyframes, want_a));
    CHECK(subset(p->pairs[0].beta_keyframes, want_b));
  }
  CHECK(ExchangeModeFromName("a+b+c").ok());
  CHECK_FALSE(ExchangeModeFromName("B").ok());
}

TEST_CASE("Merge server builds a pair's submaps from received scans and registers them to the ground truth") {
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &pair).ok());
  // Alpha's keyframe 3 holds the target submap, seen from a pose T_a (so its scan is in that sensor frame);
  // beta's keyframe 0 holds the source submap at the identity.
  const Eigen::Isometry3d T_a = test::YawOffset(-25.0, 4.0, 2.0, 0.0);
  MergeServer server(2, 100, MergeServerParams{});
  std::mt19937 rng(3);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d4 = {RandomDescriptor(&rng), RandomDescriptor(&rng),
                                                               RandomDescriptor(&rng), RandomDescriptor(&rng)};
  std::vector<Eigen::Vector3d> p4(4, Eigen::Vector3d::Zero());
  REQUIRE(server.OnKeyframeBatch(MakeBatch(0, 0, d4, p4, 0)).ok());
  REQUIRE(server.OnKeyframeBatch(MakeBatch(1, 0, {d4[0]}, {Eigen::Vector3d::Zero()}, 0)).ok());
  PoseUpdate update;
  update.robot_id = 0;
  update.keyframes = {3};
  update.T_map_sensor = {T_a};
  REQUIRE(server.OnPoseUpdate(update).ok());
  for (const ScanChunk& c : ChunksOf(0, 3, EncodeForTest(test::Transformed(pair.target.points, T_a.inverse())), 1200)) {
    REQUIRE(server.OnScanChunk(c).ok());
  }
  for (const ScanChunk& c : ChunksOf(1, 0, EncodeForTest(pair.source.points), 1200)) REQUIRE(server.OnScanChunk(c).ok());

  PairSelection sel;
  sel.alpha = 0;
  sel.beta = 1;
  sel.alpha_keyframes = {1, 3};  // keyframe 1 was never received: counted as missing
  sel.beta_keyframes = {0};
  auto merged = server.MergePair(sel);
  REQUIRE(merged.ok());
  REQUIRE(merged->attempted);
  CHECK(merged->alpha_scans == 1);
  CHECK(merged->alpha_missing == 1);
  CHECK(merged->beta_scans == 1);
  REQUIRE(merged->registration.success());
  CHECK(test::TranslationErrorM(pair.T_target_source, merged->registration.T_target_source) < 0.2);
  CHECK(test::RotationErrorDeg(pair.T_target_source, merged->registration.T_target_source) < 1.0);

  auto frames = server.SolveFrames(Span<const PairMergeResult>(&*merged, 1));
  REQUIRE(frames.ok());
  REQUIRE(frames->robots.size() == 2);
  CHECK(frames->robots[1].connected_to_robot0);
  CHECK(test::TranslationErrorM(pair.T_target_source, frames->robots[1].T_world_map) < 0.2);

  PairSelection nothing = sel;
  nothing.beta_keyframes.clear();
  auto skipped = server.MergePair(nothing);
  REQUIRE(skipped.ok());
  CHECK_FALSE(skipped->attempted);
  CHECK_FALSE(skipped->reason.empty());
}

namespace {

// The street pair of the test above with scans stored at `scan_voxel_m`, merged by a server with `params`.
PairMergeResult MergeStreetPair(const MergeServerParams& params, double scan_voxel_m, Eigen::Isometry3d* T_truth) {
  StreetPairSpec spec = test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3));
  spec.voxel_size_m = scan_voxel_m;
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(spec, &pair).ok());
  *T_truth = pair.T_target_source;
  // Each robot's whole submap arrives as one scan: the server takes scans that large.
  MergeServerParams large_scans = params;
  large_scans.max_scan_points = std::max({params.max_scan_points, pair.target.points.size(), pair.source.points.size()});
  MergeServer server(2, 100, large_scans);
  std::mt19937 rng(3);
  const auto d = RandomDescriptor(&rng);
  REQUIRE(server.OnKeyframeBatch(MakeBatch(0, 0, {d}, {Eigen::Vector3d::Zero()}, 0)).ok());
  REQUIRE(server.OnKeyframeBatch(MakeBatch(1, 0, {d}, {Eigen::Vector3d::Zero()}, 0)).ok());
  for (const ScanChunk& c : ChunksOf(0, 0, EncodeForTest(pair.target.points), 1200)) REQUIRE(server.OnScanChunk(c).ok());
  for (const ScanChunk& c : ChunksOf(1, 0, EncodeForTest(pair.source.points), 1200)) REQUIRE(server.OnScanChunk(c).ok());
  auto merged = server.MergePair(Selection(0, 1, {0}, {0}));
  REQUIRE_MESSAGE(merged.ok(), merged.status().ToString());
  REQUIRE(merged->attempted);
  return *merged;
}

}  // namespace

TEST_CASE("Merge server voxelises a small pair's submaps finer while the scans hold more detail, and registers them") {
  Eigen::Isometry3d truth;
  MergeServerParams fixed;
  fixed.min_submap_points = 0;  // the paper: one voxel size
  MergeServerParams wants_more;
  wants_more.min_submap_points = 1000000;  // always below: finer down to the floor while points grow
  const PairMergeResult at_1m = MergeStreetPair(fixed, 0.25, &truth);
  const PairMergeResult finer = MergeStreetPair(wants_more, 0.25, &truth);
  MESSAGE("scans at 0.25 m: submaps " << at_1m.alpha_submap_points << " / " << at_1m.beta_submap_points << " points at "
                                      << at_1m.voxel_size_m << " m, " << finer.alpha_submap_points << " / "
                                      << finer.beta_submap_points << " at " << finer.voxel_size_m << " m");
  CHECK(at_1m.voxel_size_m == 1.0);
  CHECK(finer.voxel_size_m == doctest::Approx(wants_more.min_submap_voxel_size_m));
  CHECK(std::min(finer.alpha_submap_points, finer.beta_submap_points) >
        3 * std::min(at_1m.alpha_submap_points, at_1m.beta_submap_points) / 2);
  for (const PairMergeResult* r : {&at_1m, &finer}) {
    REQUIRE(r->registration.success());
    CHECK(test::TranslationErrorM(truth, r->registration.T_target_source) < 0.2);
    CHECK(test::RotationErrorDeg(truth, r->registration.T_target_source) < 1.0);
  }
  // Scans stored at 1 m hold no finer detail: the ladder stops as soon as a step gains less than 10 %.
  const PairMergeResult coarse_scans = MergeStreetPair(wants_more, 1.0, &truth);
  MESSAGE("scans at 1 m: " << coarse_scans.alpha_submap_points << " / " << coarse_scans.beta_submap_points
                           << " points at " << coarse_scans.voxel_size_m << " m");
  CHECK(coarse_scans.voxel_size_m >= 0.5 - 1e-9);
  REQUIRE(coarse_scans.registration.success());
}

TEST_CASE("Merge server: a weakly supported pair that robots matched to both place elsewhere asks for no scans") {
  // Every map frame is the world frame. Robot 0 drives x = 0..99 (y = 0). Robot 2 passes robot 0's places 0..49,
  // then new places. Robot 1 passes robot 2's new places (keyframes 0..49), then 22 places that look exactly like
  // robot 0's 70..91 but lie 230 m away: pair 0-1's only cluster is that look-alike (support 22), while robots
  // 0-2 and 2-1 share 50 keyframes each and place robot 1 at the identity.
  std::mt19937 rng(11);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d0, d1, d2;
  std::vector<Eigen::Vector3d> p0, p1, p2;
  for (int i = 0; i < 100; ++i) {
    d0.push_back(RandomDescriptor(&rng));
    p0.emplace_back(i, 0.0, 0.0);
  }
  for (int i = 0; i < 100; ++i) {
    d2.push_back(i < 50 ? d0[static_cast<std::size_t>(i)] : RandomDescriptor(&rng));
    p2.push_back(i < 50 ? p0[static_cast<std::size_t>(i)] : Eigen::Vector3d(150.0 + i, 50.0, 0.0));
  }
  for (int i = 0; i < 72; ++i) {
    d1.push_back(i < 50 ? d2[static_cast<std::size_t>(50 + i)] : d0[static_cast<std::size_t>(20 + i)]);
    p1.push_back(i < 50 ? p2[static_cast<std::size_t>(50 + i)] : Eigen::Vector3d(250.0 + i, 100.0, 0.0));
  }
  auto run = [&](double chain_check_support) {
    MergeServerParams params;
    params.chain_check_support = chain_check_support;
    auto server = std::make_unique<MergeServer>(3, 100, params);
    REQUIRE(server->OnKeyframeBatch(MakeBatch(0, 0, d0, p0, 2000)).ok());
    REQUIRE(server->OnKeyframeBatch(MakeBatch(1, 0, d1, p1, 2000)).ok());
    REQUIRE(server->OnKeyframeBatch(MakeBatch(2, 0, d2, p2, 2000)).ok());
    REQUIRE(server->RunCascades().ok());
    return server;
  };
  const auto off = run(0.0);
  const ExchangeCascadeResult* lone = off->cascade(0, 1);
  REQUIRE(lone != nullptr);
  REQUIRE(lone->outcome == CascadeOutcome::kPolicy);  // without the check the look-alike goes on to registration
  REQUIRE(lone->consensus_measured);
  CHECK(lone->consensus_support_chosen < 40.0);
  const ClusterPlacement& wrong = lone->consensus_placement;  // 230 m off where robots 0 and 1 really are
  CHECK((wrong.Apply(wrong.place_beta_m) - wrong.place_beta_m).norm() > 200.0);
  for (auto [a, b] : {std::pair<int, int>{0, 2}, std::pair<int, int>{1, 2}}) {
    const ExchangeCascadeResult* c = off->cascade(a, b);
    REQUIRE(c != nullptr);
    REQUIRE(c->outcome == CascadeOutcome::kPolicy);
    CHECK(c->consensus_support_chosen >= 40.0);
    // Near the truth (the identity) where they met; the cluster's few cells past the shared stretch (the sequence
    // smoothing carries the diagonal on) pull the fit by metres, not by hundreds.
    const ClusterPlacement& placement = c->consensus_placement;
    CHECK((placement.Apply(placement.place_beta_m) - placement.place_beta_m).norm() < 10.0);
  }

  const auto on = run(40.0);
  const ExchangeCascadeResult* refused = on->cascade(0, 1);
  REQUIRE(refused != nullptr);
  CHECK(refused->outcome == CascadeOutcome::kNoCandidate);
  CHECK(refused->no_candidate_reason.find("place check") == 0);
  CHECK(refused->no_candidate_reason.find("robot 2 places the two maps") != std::string::npos);
  CHECK(on->cascade(0, 2)->outcome == CascadeOutcome::kPolicy);
  CHECK(on->cascade(1, 2)->outcome == CascadeOutcome::kPolicy);
  MergeServerParams bad;
  bad.chain_check_support = -1.0;
  CHECK(ValidateMergeServerParams(bad).message().find("chain_check_support") != std::string::npos);
  bad = MergeServerParams{};
  bad.chain_agreement.agree_deg = std::nan("");
  CHECK(ValidateMergeServerParams(bad).message().find("chain_agreement: place consensus: agree_deg") !=
        std::string::npos);
  for (ExchangeMode mode : {ExchangeMode::kStageA, ExchangeMode::kStageAB, ExchangeMode::kStageAC, ExchangeMode::kStageABC}) {
    auto plan = on->Plan(mode);
    REQUIRE(plan.ok());
    for (const PairSelection& s : plan->pairs) {
      if (s.alpha != 0 || s.beta != 1) continue;
      CHECK(s.alpha_keyframes.empty());
      CHECK(s.beta_keyframes.empty());
      CHECK(s.no_selection_reason.find("place check") == 0);
    }
  }
}

TEST_CASE("Merge server widens a refused pair with stage A's keyframes nearest its selection, asking only for scans it lacks") {
  const int n = 40, shift = 5;
  const std::unique_ptr<MergeServer> owned = ShiftedPairServer(n, shift);
  MergeServer& server = *owned;
  const MergeServerParams& params = server.params();
  std::vector<std::uint32_t> pool_a, pool_b;  // L_seq's endpoints: alpha shift..n-1, beta 0..n-shift-1
  for (int i = shift; i < n; ++i) pool_a.push_back(static_cast<std::uint32_t>(i));
  for (int j = 0; j + shift < n; ++j) pool_b.push_back(static_cast<std::uint32_t>(j));
  auto plan = server.Plan(ExchangeMode::kStageABC);
  REQUIRE(plan.ok());
  REQUIRE(plan->pairs.size() == 1);
  const PairSelection sel = plan->pairs[0];
  REQUIRE_FALSE(sel.alpha_keyframes.empty());
  REQUIRE(sel.alpha_keyframes.size() * 2 < pool_a.size());

  const std::vector<std::uint32_t> want_a = BruteForceWiden(sel.alpha_keyframes, pool_a, 2 * sel.alpha_keyframes.size());
  const std::vector<std::uint32_t> want_b = BruteForceWiden(sel.beta_keyframes, pool_b, 2 * sel.beta_keyframes.size());
  REQUIRE(want_a.size() == 2 * sel.alpha_keyframes.size());
  // The server already holds one scan the widening adds and one of the first selection: neither is asked again.
  std::uint32_t added_held = 0;
  for (std::uint32_t k : want_a) {
    if (!std::binary_search(sel.alpha_keyframes.begin(), sel.alpha_keyframes.end(), k)) added_held = k;
  }
  for (std::uint32_t k : {added_held, sel.alpha_keyframes[0]}) {
    for (const ScanChunk& c : ChunksOf(0, k, EncodeForTest(LatticePoints(20)))) REQUIRE(server.OnScanChunk(c).ok());
  }
  const PairMergeResult refused = Refused(0, 1);
  auto wider = server.WidenPlan(*plan, Span<const PairMergeResult>(&refused, 1), 7);
  REQUIRE(wider.ok());
  REQUIRE(wider->pairs.size() == 1);
  CHECK(wider->pairs[0].alpha_keyframes == want_a);
  CHECK(wider->pairs[0].beta_keyframes == want_b);
  std::vector<std::uint32_t> ask_a;
  for (std::uint32_t k : want_a) {
    if (k != added_held && k != sel.alpha_keyframes[0]) ask_a.push_back(k);
  }
  REQUIRE(wider->requests.size() == 2);
  CHECK(wider->requests[0].robot_id == 0);
  CHECK(wider->requests[0].request_id == 7);
  CHECK(wider->requests[0].keyframes == ask_a);
  CHECK(wider->requests[1].robot_id == 1);
  CHECK(wider->requests[1].request_id == 8);
  CHECK(wider->requests[1].keyframes == want_b);
  CHECK(wider->predicted_scan_bytes == ask_a.size() * EncodedScanBytes(2000) + want_b.size() * EncodedScanBytes(3000));

  // Widening again doubles again until stage A's loops are used up; then there is nothing left to widen.
  ExchangePlan current = *wider;
  std::size_t steps = 1;
  for (;; ++steps) {
    REQUIRE(steps < 10);
    auto next = server.WidenPlan(current, Span<const PairMergeResult>(&refused, 1), 1);
    REQUIRE(next.ok());
    if (next->pairs.empty()) {
      CHECK(next->requests.empty());
      break;
    }
    const PairSelection& was = current.pairs[0];
    CHECK(next->pairs[0].alpha_keyframes == BruteForceWiden(was.alpha_keyframes, pool_a, 2 * was.alpha_keyframes.size()));
    CHECK(next->pairs[0].beta_keyframes == BruteForceWiden(was.beta_keyframes, pool_b, 2 * was.beta_keyframes.size()));
    current = *next;
  }
  CHECK(current.pairs[0].alpha_keyframes == pool_a);
  CHECK(current.pairs[0].beta_keyframes == pool_b);

  // A merged pair, one not attempted (nothing received), stage A's plan (every L_seq endpoint already) and the
  // send-all baseline are not widened.
  PairMergeResult merged = refused;
  merged.registration.verdict = RegistrationVerdict::kSuccess;
  PairMergeResult not_attempted = refused;
  not_attempted.attempted = false;
  for (const PairMergeResult& r : {merged, not_attempted}) {
    auto none = server.WidenPlan(*plan, Span<const PairMergeResult>(&r, 1), 1);
    REQUIRE(none.ok());
    CHECK(none->pairs.empty());
    CHECK(none->requests.empty());
  }
  for (ExchangeMode mode : {ExchangeMode::kStageA, ExchangeMode::kSendAll}) {
    auto other = server.Plan(mode);
    REQUIRE(other.ok());
    auto none = server.WidenPlan(*other, Span<const PairMergeResult>(&refused, 1), 1);
    REQUIRE(none.ok());
    CHECK(none->pairs.empty());
  }
  MergeServerParams bad = params;
  bad.max_widen_steps = 9;
  CHECK(ValidateMergeServerParams(params).ok());
  CHECK_FALSE(ValidateMergeServerParams(bad).ok());
}

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

}  // namespace

TEST_CASE("Server link: a refused pair is widened, the extra scans are asked for, and it is registered again") {
  const int n = 40, shift = 5;
  std::vector<std::uint32_t> pool_a, pool_b;  // L_seq's endpoints
  for (int i = shift; i < n; ++i) pool_a.push_back(static_cast<std::uint32_t>(i));
  for (int j = 0; j + shift < n; ++j) pool_b.push_back(static_cast<std::uint32_t>(j));
  for (int steps : {0, 1, 2}) {
    CAPTURE(steps);
    MergeServerParams mp = PaperStageA(100);
    mp.max_widen_steps = steps;
    MergeServer server(2, 100, mp);
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

TEST_CASE("Merge server does not widen a refused pair whose stage A cluster was below tau_area (verification)") {
  // ShiftedPairBatches(40, 5): stage A's cluster spans 35 x 35 = 1225 cells.
  const auto widened_pairs = [](std::uint64_t tau_area) {
    MergeServerParams params = PaperStageA(tau_area);
    params.cascade.verification_area_fraction = 0.5;
    MergeServer server(2, 100, params);
    for (const KeyframeBatch& b : ShiftedPairBatches(40, 5)) REQUIRE(server.OnKeyframeBatch(b).ok());
    REQUIRE(server.RunCascades().ok());
    REQUIRE(server.cascade(0, 1) != nullptr);
    REQUIRE(server.cascade(0, 1)->stage_a.found);
    CHECK(server.cascade(0, 1)->verification == (tau_area > 1225));
    auto plan = server.Plan(ExchangeMode::kStageABC);
    REQUIRE(plan.ok());
    REQUIRE(plan->pairs.size() == 1);
    REQUIRE_FALSE(plan->pairs[0].alpha_keyframes.empty());
    const PairMergeResult refused = Refused(0, 1);
    auto wider = server.WidenPlan(*plan, Span<const PairMergeResult>(&refused, 1), 1);
    REQUIRE(wider.ok());
    CHECK(wider->pairs.empty() == wider->requests.empty());
    return wider->pairs.size();
  };
  CHECK(widened_pairs(1000) == 1);  // the cluster met tau_area: refused, it is widened
  CHECK(widened_pairs(2000) == 0);  // 1225 of 2000 cells: verified once, never widened
}

namespace {

// ShiftedPairBatches(40, 5) with alpha's keyframes 30..39 made copies of 5..14 and moved 100 m on: stage A's
// cluster (alpha 5..29 with beta 0..24) then holds 10 places alpha saw twice, far apart, of 25.
std::vector<KeyframeBatch> AmbiguousShiftedPairBatches() {
  std::vector<KeyframeBatch> batches = ShiftedPairBatches(40, 5);
  std::vector<std::uint8_t>& records = batches[0].records;
  for (std::uint32_t k = 30; k < 40; ++k) {
    auto copy = DecodeKeyframeRecord(
        Span<const std::uint8_t>(records.data() + (k - 25) * kKeyframeRecordBytes, kKeyframeRecordBytes));
    auto moved_or = DecodeKeyframeRecord(
        Span<const std::uint8_t>(records.data() + k * kKeyframeRecordBytes, kKeyframeRecordBytes));
    REQUIRE(copy.ok());
    REQUIRE(moved_or.ok());
    KeyframeRecord moved = *moved_or;
    moved.descriptor = copy->descriptor;
    moved.T_map_sensor.translation().x() += 100.0;
    REQUIRE(EncodeKeyframeRecord(moved, Span<std::uint8_t>(records.data() + k * kKeyframeRecordBytes,
                                                          kKeyframeRecordBytes)).ok());
  }
  return batches;
}

}  // namespace

TEST_CASE("Merge server widens a refused pair at an ambiguous place only when the place consensus confirms it") {
  // AmbiguousShiftedPairBatches: 10 of the cluster's 25 alpha keyframes are places alpha saw twice.
  struct Outcome {
    bool ambiguous = false;
    bool selected = false;
    double support = 0.0;
    std::size_t widened = 0;
  };
  const auto run = [](double max_ambiguous_fraction, double widen_ambiguous_support) {
    MergeServerParams params = PaperStageA(200);  // the copies' own cluster with beta (10 x 10) does not qualify
    params.cascade.max_ambiguous_fraction = max_ambiguous_fraction;
    params.cascade.min_ambiguous_support = 0.0;
    params.widen_ambiguous_support = widen_ambiguous_support;
    REQUIRE(ValidateMergeServerParams(params).ok());
    MergeServer server(2, 100, params);
    for (const KeyframeBatch& b : AmbiguousShiftedPairBatches()) REQUIRE(server.OnKeyframeBatch(b).ok());
    REQUIRE(server.RunCascades().ok());
    const ExchangeCascadeResult* c = server.cascade(0, 1);
    REQUIRE(c != nullptr);
    REQUIRE(c->stage_a.found);
    Outcome o;
    o.ambiguous = c->ambiguous;
    o.support = c->consensus_measured ? c->consensus_support_chosen : -1.0;
    CHECK(AmbiguousClusterConfirmed(*c, params) ==
          (c->ambiguous && widen_ambiguous_support > 0.0 && o.support >= widen_ambiguous_support));
    auto plan = server.Plan(ExchangeMode::kStageABC);
    REQUIRE(plan.ok());
    REQUIRE(plan->pairs.size() == 1);
    o.selected = !plan->pairs[0].alpha_keyframes.empty() && !plan->pairs[0].beta_keyframes.empty();
    const PairMergeResult refused = Refused(0, 1);
    auto wider = server.WidenPlan(*plan, Span<const PairMergeResult>(&refused, 1), 1);
    REQUIRE(wider.ok());
    o.widened = wider->pairs.size();
    return o;
  };
  const Outcome plain = run(1.0, 0.0);
  CHECK_FALSE(plain.ambiguous);
  REQUIRE(plain.selected);
  CHECK(plain.widened == 1);  // not measured: widened as any refused pair

  // 10 of alpha's 25 cluster keyframes ambiguous, above 0.1: registered once unless the consensus confirms it.
  const Outcome once = run(0.1, 0.0);
  CHECK(once.ambiguous);
  REQUIRE(once.selected);
  CHECK(once.widened == 0);
  // The place consensus measured the cluster: every loop of the shifted pair places beta's map the same way, so
  // the cluster's support is at least its own 25 loops.
  REQUIRE(once.support >= 25.0);
  CHECK(run(0.1, once.support).widened == 1);        // confirmed at exactly the support asked
  CHECK(run(0.1, once.support + 1.0).widened == 0);  // one keyframe short
  CHECK(run(1.0, once.support + 1.0).widened == 1);  // not ambiguous: the support is not asked for

  MergeServerParams bad = PaperStageA(200);
  for (double v : {-1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    bad.widen_ambiguous_support = v;
    CHECK_FALSE(ValidateMergeServerParams(bad).ok());
  }
}

TEST_CASE("Place check of a confirmed ambiguous pair: a transform is accepted within the tolerances of agreement") {
  MergeServerParams params;
  REQUIRE(params.widen_ambiguous_support > 0.0);
  const double tol_m = params.cascade.consensus.agree_m;
  const double tol_deg = params.cascade.consensus.agree_deg;
  ExchangeCascadeResult c;
  c.ambiguous = true;
  c.consensus_measured = true;
  c.consensus_support_chosen = params.widen_ambiguous_support;
  c.consensus_placement.valid = true;
  c.consensus_placement.yaw_rad = 30.0 * kDegToRad;
  c.consensus_placement.t_alpha_beta_m = Eigen::Vector3d(5.0, 3.0, 0.0);
  c.consensus_placement.place_beta_m = Eigen::Vector3d(-10.0, 3.0, 0.0);
  // The placement as an isometry, and the same turned by theta about the place (which it leaves where it was).
  Eigen::Isometry3d T_p = Eigen::Isometry3d::Identity();
  T_p.linear() = Eigen::AngleAxisd(c.consensus_placement.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_p.translation() = c.consensus_placement.t_alpha_beta_m;
  const auto turned = [&](double theta_deg) {
    Eigen::Isometry3d about = Eigen::Isometry3d::Identity();
    about.translate(c.consensus_placement.place_beta_m);
    about.rotate(Eigen::AngleAxisd(theta_deg * kDegToRad, Eigen::Vector3d::UnitZ()));
    about.translate(-c.consensus_placement.place_beta_m);
    return T_p * about;
  };
  const auto shifted = [&](double d_m) {
    Eigen::Isometry3d T = T_p;
    T.translation() += Eigen::Vector3d(0.6, -0.8, 0.0) * d_m;
    return T;
  };
  PlacementGap gap;
  CHECK(RegistrationAtConfirmedPlace(c, params, T_p, &gap));
  CHECK(gap.distance_m < 1e-9);
  CHECK(gap.yaw_deg < 1e-9);
  CHECK(RegistrationAtConfirmedPlace(c, params, shifted(0.95 * tol_m), &gap));
  CHECK(gap.distance_m == doctest::Approx(0.95 * tol_m));
  CHECK_FALSE(RegistrationAtConfirmedPlace(c, params, shifted(1.05 * tol_m), &gap));
  CHECK(gap.distance_m == doctest::Approx(1.05 * tol_m));
  CHECK(RegistrationAtConfirmedPlace(c, params, turned(-0.95 * tol_deg), &gap));
  CHECK(gap.yaw_deg == doctest::Approx(0.95 * tol_deg));
  CHECK(gap.distance_m < 1e-9);
  CHECK_FALSE(RegistrationAtConfirmedPlace(c, params, turned(1.05 * tol_deg), &gap));
  CHECK_FALSE(RegistrationAtConfirmedPlace(c, params, turned(180.0), &gap));
  CHECK(gap.yaw_deg == doctest::Approx(180.0));

  // Every other pair is not checked: the same 180 deg turn passes.
  const Eigen::Isometry3d T_off = turned(180.0);
  ExchangeCascadeResult other = c;
  other.ambiguous = false;
  CHECK(RegistrationAtConfirmedPlace(other, params, T_off, &gap));
  CHECK(gap.yaw_deg == 0.0);
  other = c;
  other.consensus_support_chosen = params.widen_ambiguous_support - 1.0;
  CHECK(RegistrationAtConfirmedPlace(other, params, T_off));
  other = c;
  other.consensus_placement.valid = false;
  CHECK(RegistrationAtConfirmedPlace(other, params, T_off));
  MergeServerParams off = params;
  off.widen_ambiguous_support = 0.0;
  CHECK(RegistrationAtConfirmedPlace(c, off, T_off));
}

TEST_CASE("Merge server refuses a registration at a confirmed ambiguous place that lies away from its placement") {
  // Stage A's cluster of AmbiguousShiftedPairBatches pairs alpha keyframe j + 5 at (j + 5, 0, 0) with beta keyframe
  // j at (-j, 3, 0): its placement turns beta's map 180 deg and moves it by (5, 3, 0).
  SyntheticSubmapPair street;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &street).ok());
  // The fixture's geometry, independently of the consensus: beta's (-j, 3, 0) lands on alpha's (j + 5, 0, 0).
  Eigen::Isometry3d T_fixture = Eigen::Isometry3d::Identity();
  T_fixture.linear() = Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T_fixture.translation() = Eigen::Vector3d(5.0, 3.0, 0.0);
  const auto merge = [&](const Eigen::Isometry3d& T_alpha_beta, double widen_ambiguous_support,
                         Eigen::Isometry3d* T_placement) {
    MergeServerParams params = PaperStageA(200);
    params.cascade.max_ambiguous_fraction = 0.1;
    params.cascade.min_ambiguous_support = 0.0;
    params.widen_ambiguous_support = widen_ambiguous_support;
    MergeServer server(2, 100, params);
    for (const KeyframeBatch& b : AmbiguousShiftedPairBatches()) REQUIRE(server.OnKeyframeBatch(b).ok());
    REQUIRE(server.RunCascades().ok());
    const ExchangeCascadeResult* c = server.cascade(0, 1);
    REQUIRE(c != nullptr);
    REQUIRE(c->ambiguous);
    REQUIRE(c->consensus_placement.valid);
    CHECK(AmbiguousClusterConfirmed(*c, params) == (widen_ambiguous_support > 0.0));
    T_placement->setIdentity();
    T_placement->linear() = Eigen::AngleAxisd(c->consensus_placement.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T_placement->translation() = c->consensus_placement.t_alpha_beta_m;
    // Alpha's keyframe 10 and beta's keyframe 5 (a loop of the cluster) hold the street pair's scans, placed so
    // that alpha's map = T_alpha_beta beta's map: beta's scan is the source, alpha's the target moved by
    // T_alpha_beta after the pair's own truth undone. Alpha's keyframe moves with its scan (a pose update after
    // the cascade, as a loop closure would send), so registration sees the same scene from the same viewpoints
    // whatever T_alpha_beta is.
    const Eigen::Isometry3d T_map_alpha10 = T_alpha_beta * T_fixture.inverse() * Eigen::Translation3d(10.0, 0.0, 0.0);
    const Eigen::Isometry3d T_map_beta5(Eigen::Translation3d(-5.0, 3.0, 0.0));
    PoseUpdate update;
    update.robot_id = 0;
    update.keyframes = {10};
    update.T_map_sensor = {T_map_alpha10};
    REQUIRE(server.OnPoseUpdate(update).ok());
    const Eigen::Isometry3d T_target = T_map_alpha10.inverse() * T_alpha_beta * street.T_target_source.inverse();
    for (const ScanChunk& ch : ChunksOf(0, 10, EncodeForTest(test::Transformed(street.target.points, T_target)), 1200)) {
      REQUIRE(server.OnScanChunk(ch).ok());
    }
    for (const ScanChunk& ch : ChunksOf(1, 5, EncodeForTest(test::Transformed(street.source.points, T_map_beta5.inverse())), 1200)) {
      REQUIRE(server.OnScanChunk(ch).ok());
    }
    auto merged = server.MergePair(Selection(0, 1, {10}, {5}));
    REQUIRE(merged.ok());
    REQUIRE(merged->attempted);
    return *merged;
  };
  Eigen::Isometry3d T_placement;
  const PairMergeResult at_place = merge(T_fixture, 1.0, &T_placement);
  CHECK(test::TranslationErrorM(T_fixture, T_placement) < 0.5);
  CHECK(test::RotationErrorDeg(T_fixture, T_placement) < 2.0);
  REQUIRE(at_place.registration.success());
  CHECK(test::TranslationErrorM(T_fixture, at_place.registration.T_target_source) < 0.2);

  // The same scans with alpha's turned 180 deg about the place: registration's gates pass, the place check does not.
  Eigen::Isometry3d about = Eigen::Isometry3d::Identity();
  about.translate(Eigen::Vector3d(-12.0, 3.0, 0.0));
  about.rotate(Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()));
  about.translate(Eigen::Vector3d(12.0, -3.0, 0.0));
  const Eigen::Isometry3d T_turned = T_fixture * about;
  const PairMergeResult off_place = merge(T_turned, 1.0, &T_placement);
  CHECK(off_place.registration.verdict == RegistrationVerdict::kOffConfirmedPlace);
  CHECK_FALSE(off_place.registration.success());
  CHECK(off_place.reason.find("off the confirmed place") == 0);
  CHECK(test::TranslationErrorM(T_turned, off_place.registration.T_target_source) < 0.2);
  CHECK(test::RotationErrorDeg(T_turned, off_place.registration.T_target_source) < 1.0);
  // Without the widening of confirmed ambiguous places there is no such check: the turned transform merges.
  const PairMergeResult unchecked = merge(T_turned, 0.0, &T_placement);
  REQUIRE(unchecked.registration.success());
  CHECK(test::TranslationErrorM(T_turned, unchecked.registration.T_target_source) < 0.2);
}

TEST_CASE("Merge server does not widen a refused pair whose robots merged pairs already join") {
  MergeServerParams params = PaperStageA(100);
  MergeServer server(3, 100, params);
  for (const KeyframeBatch& b : ShiftedPairBatches(40, 5)) REQUIRE(server.OnKeyframeBatch(b).ok());
  std::mt19937 rng(11);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d;
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < 40; ++i) {
    d.push_back(RandomDescriptor(&rng));
    p.emplace_back(0.0, i, 0.0);
  }
  REQUIRE(server.OnKeyframeBatch(MakeBatch(2, 0, d, p, 1000)).ok());
  REQUIRE(server.RunCascades().ok());
  auto plan = server.Plan(ExchangeMode::kStageABC);
  REQUIRE(plan.ok());
  REQUIRE(plan->pairs.size() == 3);
  // Pairs 0-2 and 1-2 found no loops here; as results they stand for merges through robot 2.
  const auto merged = [](int a, int b) {
    PairMergeResult r = Refused(a, b);
    r.registration.verdict = RegistrationVerdict::kSuccess;
    return r;
  };
  const std::vector<PairMergeResult> joined = {Refused(0, 1), merged(0, 2), merged(1, 2)};
  auto none = server.WidenPlan(*plan, Span<const PairMergeResult>(joined), 1);
  REQUIRE(none.ok());
  CHECK(none->pairs.empty());
  CHECK(none->requests.empty());
  // Robot 2 joined to robot 0 only: robots 0 and 1 are not joined, so pair 0-1 is widened.
  const std::vector<PairMergeResult> apart = {Refused(0, 1), merged(0, 2), Refused(1, 2)};
  auto wider = server.WidenPlan(*plan, Span<const PairMergeResult>(apart), 1);
  REQUIRE(wider.ok());
  REQUIRE(wider->pairs.size() == 1);
  CHECK(wider->pairs[0].alpha == 0);
  CHECK(wider->pairs[0].beta == 1);
  CHECK(wider->pairs[0].alpha_keyframes.size() == 2 * plan->pairs[0].alpha_keyframes.size());
}

namespace {

// Two robots on one road: alpha's keyframe i at (i, 0, 0); beta's keyframe j where T_alpha_beta places it on
// alpha's (j + 10, 0.5, 0). Beta's first 30 keyframes carry alpha's descriptors (stage A's cluster: beta 0..29
// with alpha 10..39); the next 30 either look like alpha's at the same place (a second stretch of the road,
// descriptors near but above tau_inter, so outside the cluster) or like nothing alpha saw. Alpha's keyframe 15
// and beta's keyframe 5 hold the street pair's scans, placed so that registration finds T_alpha_beta.
PairMergeResult MergeRoadPair(bool rest_agrees, const MergeServerParams& params, const Eigen::Isometry3d& T_alpha_beta) {
  SyntheticSubmapPair street;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &street).ok());
  std::mt19937 rng(11);
  std::vector<std::array<float, kKeyframeDescriptorDim>> da, db;
  std::vector<Eigen::Vector3d> pa, pb;
  for (int i = 0; i < 60; ++i) {
    da.push_back(RandomDescriptor(&rng));
    pa.emplace_back(i, 0.0, 0.0);
  }
  for (int j = 0; j < 60; ++j) {
    std::array<float, kKeyframeDescriptorDim> d = RandomDescriptor(&rng);
    if (j < 30) {
      d = da[static_cast<std::size_t>(j + 10)];
    } else if (rest_agrees && j + 10 < 60) {
      double n = 0.0;
      for (std::size_t k = 0; k < d.size(); ++k) {
        d[k] = 0.6f * da[static_cast<std::size_t>(j + 10)][k] + 0.4f * d[k];
        n += static_cast<double>(d[k]) * static_cast<double>(d[k]);
      }
      for (float& v : d) v = static_cast<float>(static_cast<double>(v) / std::sqrt(n));
    }
    db.push_back(d);
    pb.push_back(T_alpha_beta.inverse() * Eigen::Vector3d(j + 10.0, 0.5, 0.0));
  }
  auto server = std::make_unique<MergeServer>(2, 100, params);
  REQUIRE(server->OnKeyframeBatch(MakeBatch(0, 0, da, pa, 3000)).ok());
  REQUIRE(server->OnKeyframeBatch(MakeBatch(1, 0, db, pb, 3000)).ok());
  REQUIRE(server->RunCascades().ok());
  const ExchangeCascadeResult* c = server->cascade(0, 1);
  REQUIRE(c != nullptr);
  REQUIRE(c->stage_a.found);
  CHECK(c->stage_a.best.col_min == 0);
  CHECK(c->stage_a.best.col_max == 29);
  // Beta's keyframe 5 sees the street's source scan from where T_alpha_beta puts it relative to alpha's keyframe 15
  // (street.T_target_source apart), so the two submaps meet exactly under T_alpha_beta.
  const Eigen::Isometry3d T_map_alpha15(Eigen::Translation3d(15.0, 0.0, 0.0));
  PoseUpdate update;
  update.robot_id = 1;
  update.keyframes = {5};
  update.T_map_sensor = {T_alpha_beta.inverse() * T_map_alpha15 * street.T_target_source};
  REQUIRE(server->OnPoseUpdate(update).ok());
  for (const ScanChunk& ch : ChunksOf(0, 15, EncodeForTest(street.target.points), 1200)) REQUIRE(server->OnScanChunk(ch).ok());
  for (const ScanChunk& ch : ChunksOf(1, 5, EncodeForTest(street.source.points), 1200)) REQUIRE(server->OnScanChunk(ch).ok());
  auto merged = server->MergePair(Selection(0, 1, {15}, {5}));
  REQUIRE_MESSAGE(merged.ok(), merged.status().ToString());
  REQUIRE(merged->attempted);
  return *merged;
}

}  // namespace

TEST_CASE("Merge server refuses a registration where the keyframes it places together have unlike descriptors") {
  const Eigen::Isometry3d T_alpha_beta = test::YawOffset(30.0, 5.0, 2.0, 0.0);
  MergeServerParams params = PaperStageA(100);
  params.max_colocated_chance = 0.3;
  REQUIRE(ValidateMergeServerParams(params).ok());

  // The rest of beta's road looks like alpha's at the same place: merged, and the keyframes the transform puts
  // together outside the cluster (beta 30..51, 0.5 m aside of alpha's road, within 3 m of alpha's 38..59) are
  // each other's nearest.
  const PairMergeResult agrees = MergeRoadPair(true, params, T_alpha_beta);
  REQUIRE(agrees.registration.success());
  CHECK(test::TranslationErrorM(T_alpha_beta, agrees.registration.T_target_source) < 0.2);
  CHECK(agrees.colocated_keyframes == 22);
  CHECK(agrees.colocated_chance == doctest::Approx(0.0));

  // The rest looks like nothing alpha saw there: the same registration is refused, its transform kept.
  const PairMergeResult strangers = MergeRoadPair(false, params, T_alpha_beta);
  CHECK(strangers.registration.verdict == RegistrationVerdict::kDescriptorsDisagree);
  CHECK_FALSE(strangers.registration.success());
  CHECK(strangers.reason.find("descriptors disagree") == 0);
  CHECK(test::TranslationErrorM(T_alpha_beta, strangers.registration.T_target_source) < 0.2);
  CHECK(strangers.colocated_keyframes == 22);
  CHECK(strangers.colocated_chance > 0.3);
  CHECK(strangers.colocated_chance < 0.9);

  // Too few keyframes placed together to judge, or the check off: merged, the measure still reported.
  MergeServerParams few = params;
  few.min_colocated_keyframes = 23;
  CHECK(MergeRoadPair(false, few, T_alpha_beta).registration.success());
  MergeServerParams off = params;
  off.max_colocated_chance = 0.0;
  const PairMergeResult unchecked = MergeRoadPair(false, off, T_alpha_beta);
  REQUIRE(unchecked.registration.success());
  CHECK(unchecked.colocated_chance == doctest::Approx(strangers.colocated_chance));

  MergeServerParams bad = params;
  for (double v : {-0.1, 1.5, std::numeric_limits<double>::quiet_NaN()}) {
    bad.max_colocated_chance = v;
    CHECK_FALSE(ValidateMergeServerParams(bad).ok());
  }
  bad = params;
  bad.colocation.near_m = 0.0;
  CHECK_FALSE(ValidateMergeServerParams(bad).ok());
}

namespace commerge {
namespace {

// A Scan Context grid of one place: random heights in a third of its cells, its columns turned by `turn` sectors
// (the place seen with another heading), with a little noise.
std::vector<float> RandomScanContext(std::uint32_t place, int turn, std::mt19937* noise) {
  std::mt19937 rng(1000 + place);
  std::uniform_real_distribution<float> height(0.5f, 6.0f), jitter(-0.05f, 0.05f), u(0.0f, 1.0f);
  const int rings = kScanContextWireRings, sectors = kScanContextWireSectors;
  std::vector<float> base(static_cast<std::size_t>(rings * sectors));
  for (float& v : base) v = u(rng) < 0.3f ? height(rng) : 0.0f;  // structure in a third of the cells
  std::vector<float> out(base.size());
  for (int r = 0; r < rings; ++r) {
    for (int c = 0; c < sectors; ++c) {
      const float v = base[static_cast<std::size_t>(r * sectors + c)];
      out[static_cast<std::size_t>(r * sectors + (c + turn) % sectors)] = v > 0.0f ? v + jitter(*noise) : 0.0f;
    }
  }
  return out;
}

KeyframeBatch ScanContextBatch(int robot, std::uint32_t first, const std::vector<std::vector<float>>& descriptors) {
  KeyframeBatch b;
  b.robot_id = robot;
  b.record_kind = KeyframeRecordKind::kScanContext;
  const std::size_t bytes = KeyframeRecordBytesOf(KeyframeRecordKind::kScanContext);
  for (std::size_t k = 0; k < descriptors.size(); ++k) {
    KeyframePose pose;
    pose.keyframe_index = first + static_cast<std::uint32_t>(k);
    pose.T_map_sensor.translation() = Eigen::Vector3d(static_cast<double>(k), 0.0, 0.0);
    const std::size_t at = b.records.size();
    b.records.resize(at + bytes);
    REQUIRE(EncodeRecordOfKind(KeyframeRecordKind::kScanContext, pose, Span<const float>(descriptors[k]),
                               Span<std::uint8_t>(b.records.data() + at, bytes))
                .ok());
    b.stored_points.push_back(2000);
  }
  return b;
}

TEST_CASE("Merge server with Scan Context records: the other kind is refused and counted, stage A finds the "
          "revisit by the Scan Context distance") {
  MergeServerParams params;
  params.record_kind = KeyframeRecordKind::kScanContext;
  MergeServer server(2, 200, params);
  CHECK(server.robot(0).dim == 1200);
  CHECK(server.params().cascade.metric.kind == DescriptorMetric::Kind::kScanContext);

  // Robot 0 drives places 0..59; robot 1 places 20..79, every place seen turned by 17 sectors (102 deg).
  const int n = 60, shift = 20;
  std::mt19937 noise(5);
  std::vector<std::vector<float>> a, b;
  for (int k = 0; k < n; ++k) a.push_back(RandomScanContext(static_cast<std::uint32_t>(k), 0, &noise));
  for (int k = 0; k < n; ++k) b.push_back(RandomScanContext(static_cast<std::uint32_t>(k + shift), 17, &noise));
  REQUIRE(server.OnKeyframeBatch(ScanContextBatch(0, 0, a)).ok());
  REQUIRE(server.OnKeyframeBatch(ScanContextBatch(1, 0, b)).ok());
  CHECK(server.stats().records == static_cast<std::uint64_t>(2 * n));

  // A robot that sends 92-byte records to this server: refused as a whole, counted, the message names both kinds.
  std::mt19937 rng(3);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d = {RandomDescriptor(&rng)};
  const KeyframeBatch unit = MakeBatch(1, 100, d, {Eigen::Vector3d::Zero()}, 0);
  const std::uint64_t rejected = server.stats().rejected_batches;
  const Status refused = server.OnKeyframeBatch(unit);
  CHECK(refused.code() == StatusCode::kInvalidArgument);
  CHECK(refused.message().find("unit-40") != std::string::npos);
  CHECK(refused.message().find("scan-context") != std::string::npos);
  CHECK(refused.message().find("--descriptor") != std::string::npos);
  CHECK(server.stats().rejected_batches == rejected + 1);
  CHECK_FALSE(server.CheckKeyframeBatch(unit).ok());
  CHECK(server.robot(1).size() == static_cast<std::size_t>(n));  // nothing of it was applied

  // The decoded descriptors equal the sent ones within the record's quantisation.
  for (std::size_t t = 0; t < 1200; ++t) {
    CHECK(std::fabs(server.robot(0).descriptors[t] - a[0][t]) <= 6.05f / 255.0f);
  }

  // Stage A on the Scan Context distance: L_seq holds every cell of the true revisit (beta j sees alpha's place
  // j + shift, whatever the heading) and, through the sequence smoothing's band, nothing further from it than the
  // smoothing window (4 keyframes) plus one.
  REQUIRE(server.RunCascades().ok());
  const ExchangeCascadeResult* c = server.cascade(0, 1);
  REQUIRE(c != nullptr);
  REQUIRE(c->stage_a.found);
  std::size_t on_diagonal = 0, off_band = 0;
  for (const SequentialLoopCell& l : c->stage_a.cells) {
    const long off = static_cast<long>(l.alpha_index) - static_cast<long>(l.beta_index) - shift;
    on_diagonal += off == 0;
    off_band += std::labs(off) > 5;
  }
  CHECK(on_diagonal == static_cast<std::size_t>(n - shift));
  CHECK(off_band == 0);

  // A robot that restarts (a new session resets it) keeps the server's descriptor width: its new batch applies.
  server.ResetRobot(1);
  CHECK(server.robot(1).size() == 0);
  CHECK(server.robot(1).dim == 1200);
  REQUIRE(server.OnKeyframeBatch(ScanContextBatch(1, 0, b)).ok());
  CHECK(server.robot(1).size() == static_cast<std::size_t>(n));
  REQUIRE(server.RunCascades().ok());
  REQUIRE(server.cascade(0, 1) != nullptr);
  CHECK(server.cascade(0, 1)->stage_a.found);

  // A server of 40-value records refuses the Scan Context batch the same way.
  MergeServer unit_server(2, 200, MergeServerParams{});
  const Status other = unit_server.OnKeyframeBatch(ScanContextBatch(0, 0, a));
  CHECK(other.code() == StatusCode::kInvalidArgument);
  CHECK(unit_server.stats().rejected_batches == 1);
  CHECK(unit_server.robot(0).size() == 0);
}

}  // namespace
}  // namespace commerge

TEST_CASE("Merge server without the A+C ablation: the same A+B+C plan, no stage C over L_seq, and Plan(A+C) refused") {
  MergeServerParams with;
  with.cascade.stage_a = SequentialMatchParams{};
  with.cascade.stage_a.tau_area = 100;
  MergeServerParams without = with;
  without.stage_ac_ablation = false;
  MergeServer a(2, 100, with), b(2, 100, without);
  for (const KeyframeBatch& batch : ShiftedPairBatches(40, 5)) {
    REQUIRE(a.OnKeyframeBatch(batch).ok());
    REQUIRE(b.OnKeyframeBatch(batch).ok());
  }
  REQUIRE(a.RunCascades().ok());
  REQUIRE(b.RunCascades().ok());
  REQUIRE(a.cascade(0, 1) != nullptr);
  REQUIRE(a.cascade(0, 1)->stage_a.found);
  CHECK(a.stage_ac(0, 1) != nullptr);
  CHECK(b.stage_ac(0, 1) == nullptr);
  auto plan_a = a.Plan(ExchangeMode::kStageABC), plan_b = b.Plan(ExchangeMode::kStageABC);
  REQUIRE(plan_a.ok());
  REQUIRE(plan_b.ok());
  REQUIRE(plan_a->requests.size() == plan_b->requests.size());
  for (std::size_t i = 0; i < plan_a->requests.size(); ++i) {
    CHECK(plan_a->requests[i].robot_id == plan_b->requests[i].robot_id);
    CHECK(plan_a->requests[i].keyframes == plan_b->requests[i].keyframes);
  }
  CHECK(a.Plan(ExchangeMode::kStageAC).ok());
  auto refused = b.Plan(ExchangeMode::kStageAC);
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().message().find("stage_ac_ablation") != std::string::npos);
}
