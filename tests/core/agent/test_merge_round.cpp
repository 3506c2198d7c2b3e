// SPDX-License-Identifier: BSD-3-Clause
// The merge round (core/agent/merge_round.hpp) on a MergeServer without a network: its requests are the plan's
// scans the server lacks; every pair is registered with its selection exactly as MergeServer::MergePair does;
// refused pairs are widened by the brute-force rule until nothing is left; a pair verified in an earlier round is
// kept without scans while nothing changed (not after a restart), and registered again when a loop closure moves
// its overlap; and ServerLink, which drives the same round over messages, emits the merge result the direct
// round makes.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdlib>
#include <iterator>
#include <memory>
#include <random>
#include <utility>
#include <vector>

#include "tests/core/agent/server_fixture.hpp"
#include "core/agent/merge_round.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/server_link.hpp"
#include "core/cloud/scan_codec.hpp"
#include "tests/core/agent/keyframe_batch_fixtures.hpp"
#include "tests/core/agent/scan_chunk_fixtures.hpp"
#include "tests/core/registration/registration_test_support.hpp"

using namespace commerge;
using commerge::test::ChunksOf;
using commerge::test::EncodeForTest;
using commerge::test::LatticePoints;
using commerge::test::MakeBatch;
using commerge::test::BruteForceWiden;
using commerge::test::RandomDescriptor;
using commerge::test::ShiftedPairBatches;

namespace {

constexpr int kN = 40, kShift = 5;

// Robots 0 and 1 whose descriptors repeat with a shift (stage A finds the diagonal), stage A's tau_area 100.
MergeServerParams ShiftedParams(int max_widen_steps) {
  MergeServerParams params;
  params.cascade.stage_a = SequentialMatchParams{};  // the paper's stage A: B_ij = [A_ij <= tau_inter]
  params.cascade.stage_a.tau_area = 100;
  params.max_widen_steps = max_widen_steps;
  // Both robots start at 10 scans and grow in step: each widening asks both (the widening test expects it).
  params.cascade.policy.min_scans_per_robot = 10;
  params.cascade.policy.min_points_per_robot = 0;
  return params;
}

std::unique_ptr<MergeServer> ShiftedServer(int max_widen_steps) {
  auto server = commerge::test::MakeTestServer(2, 100, ShiftedParams(max_widen_steps));
  for (const KeyframeBatch& b : ShiftedPairBatches(kN, kShift)) REQUIRE(server->OnKeyframeBatch(b).ok());
  return server;
}

// Answers `requests` with scans of 2 points each: too few to register, so registration refuses the pair.
void AnswerTiny(MergeServer* server, const std::vector<ScanRequest>& requests) {
  for (const ScanRequest& q : requests) {
    for (std::uint32_t k : q.keyframes) {
      for (const ScanChunk& c : ChunksOf(q.robot_id, k, EncodeForTest(LatticePoints(2)))) {
        REQUIRE(server->OnScanChunk(c).ok());
      }
    }
  }
}


std::vector<std::uint32_t> Minus(const std::vector<std::uint32_t>& a, const std::vector<std::uint32_t>& b) {
  std::vector<std::uint32_t> out;
  std::set_difference(a.begin(), a.end(), b.begin(), b.end(), std::back_inserter(out));
  return out;
}

const std::vector<std::int64_t> kSessions = {1, 1};

}  // namespace

TEST_CASE("Merge round: its requests are the plan's scans the server lacks, and each pair is registered as MergePair does") {
  for (ExchangeMode mode : {ExchangeMode::kStageA, ExchangeMode::kStageAB, ExchangeMode::kStageAC, ExchangeMode::kStageABC}) {
    CAPTURE(ExchangeModeName(mode));
    std::unique_ptr<MergeServer> server = ShiftedServer(0);
    REQUIRE(server->RunCascades().ok());
    auto plan = server->Plan(mode);
    REQUIRE(plan.ok());
    REQUIRE(plan->requests.size() == 2);
    // One scan of the plan is held already: it is not asked for again.
    const std::uint32_t held = plan->requests[0].keyframes.front();
    AnswerTiny(server.get(), {ScanRequest{0, 0, 0, 0, {held}}});

    MergeRound round(server.get(), MergeRoundParams{mode, /*run_cascades=*/true, PairExchangeParams{}});
    std::vector<ScanRequest> requests;
    REQUIRE(round.Begin(Span<const std::int64_t>(kSessions), &requests).ok());
    CHECK(round.active());
    REQUIRE(requests.size() == 2);
    CHECK(requests[0].robot_id == 0);
    CHECK(requests[0].request_id == 1);
    CHECK(requests[0].keyframes == Minus(plan->requests[0].keyframes, {held}));
    CHECK(requests[1].robot_id == 1);
    CHECK(requests[1].request_id == 2);
    CHECK(requests[1].keyframes == plan->requests[1].keyframes);
    AnswerTiny(server.get(), requests);

    auto done = round.Continue(&requests);
    REQUIRE(done.ok());
    CHECK(*done);
    CHECK(requests.empty());
    CHECK_FALSE(round.active());
    const MergeRoundResult& r = round.result();
    CHECK(r.round == 1);
    REQUIRE(r.pairs.size() == 1);
    auto direct = server->MergePair(plan->pairs[0]);
    REQUIRE(direct.ok());
    CHECK(r.pairs[0].attempted == direct->attempted);
    CHECK(r.pairs[0].reason == direct->reason);
    CHECK(r.pairs[0].alpha_scans == direct->alpha_scans);
    CHECK(r.pairs[0].beta_scans == direct->beta_scans);
    CHECK(r.pairs[0].alpha_scans == plan->pairs[0].alpha_keyframes.size());
    CHECK(r.pairs[0].registration.verdict == direct->registration.verdict);
    CHECK_FALSE(r.pairs[0].registration.success());
    CHECK(r.widenings == std::vector<int>{0});
    REQUIRE(r.plan.pairs.size() == 1);
    CHECK(r.plan.pairs[0].alpha_keyframes == plan->pairs[0].alpha_keyframes);
    CHECK(r.plan.requests.size() == 2);
    REQUIRE(r.frames_ok);
    CHECK(r.in_world(0));
    CHECK_FALSE(r.in_world(1));
    CHECK(r.T_world_map(1).isApprox(Eigen::Isometry3d::Identity()));
  }
}

TEST_CASE("Merge round: a refused pair is widened by the brute-force rule, max_widen_steps times at most") {
  std::vector<std::uint32_t> pool_a, pool_b;  // L_seq's endpoints
  for (int i = kShift; i < kN; ++i) pool_a.push_back(static_cast<std::uint32_t>(i));
  for (int j = 0; j + kShift < kN; ++j) pool_b.push_back(static_cast<std::uint32_t>(j));
  for (int steps : {0, 1, 2, 8}) {
    CAPTURE(steps);
    std::unique_ptr<MergeServer> server = ShiftedServer(steps);
    MergeRound round(server.get(), MergeRoundParams{});
    std::vector<ScanRequest> requests;
    REQUIRE(round.Begin(Span<const std::int64_t>(kSessions), &requests).ok());
    REQUIRE(requests.size() == 2);
    std::vector<std::uint32_t> selected_a = requests[0].keyframes, selected_b = requests[1].keyframes;
    const std::size_t first_scans = selected_a.size() + selected_b.size();
    int widened = 0;
    while (true) {
      AnswerTiny(server.get(), requests);
      auto done = round.Continue(&requests);
      REQUIRE(done.ok());
      if (*done) break;
      ++widened;
      REQUIRE(widened <= steps);
      const std::vector<std::uint32_t> wider_a = BruteForceWiden(selected_a, pool_a, 2 * selected_a.size());
      const std::vector<std::uint32_t> wider_b = BruteForceWiden(selected_b, pool_b, 2 * selected_b.size());
      REQUIRE(requests.size() == 2);
      CHECK(requests[0].keyframes == Minus(wider_a, selected_a));
      CHECK(requests[1].keyframes == Minus(wider_b, selected_b));
      CHECK(round.widened_selections() == static_cast<std::uint64_t>(widened));
      selected_a = wider_a;
      selected_b = wider_b;
    }
    // Stage A's loops hold 35 keyframes per robot: the selection can double a few times only.
    const bool used_up = selected_a == pool_a && selected_b == pool_b;
    CHECK((widened == steps || used_up));
    const MergeRoundResult& r = round.result();
    REQUIRE(r.pairs.size() == 1);
    CHECK(r.widenings[0] == widened);
    // The scans by origin: the plan's own and padding, then what widening added.
    CHECK(r.plan.selected_scans + r.plan.padded_scans == first_scans);
    CHECK(r.widened_scans == selected_a.size() + selected_b.size() - first_scans);
    CHECK((widened == 0) == (r.widened_scans == 0));
    CHECK(r.pairs[0].alpha_scans == selected_a.size());
    CHECK(r.pairs[0].beta_scans == selected_b.size());
    CHECK(r.plan.pairs[0].alpha_keyframes == selected_a);
    std::size_t asked = 0;
    for (const ScanRequest& q : r.plan.requests) asked += q.keyframes.size();
    CHECK(asked == selected_a.size() + selected_b.size());
  }
}

TEST_CASE("Merge round: Continue before Begin is an error") {
  std::unique_ptr<MergeServer> server = ShiftedServer(0);
  MergeRound round(server.get(), MergeRoundParams{});
  std::vector<ScanRequest> requests;
  CHECK_FALSE(round.Continue(&requests).ok());
}

namespace {

// Robot 0's keyframe 3 and robot 1's keyframe 0 share a descriptor (stage A's only loop) and hold the two submaps
// of a street: the cascade asks for exactly them and registration recovers the true transform. All poses start at
// the identity.
struct StreetRounds {
  SyntheticSubmapPair pair;
  std::unique_ptr<MergeServer> server;
  std::vector<std::array<float, kKeyframeDescriptorDim>> d4;
  std::vector<std::int64_t> sessions = {10, 20};
  std::size_t scans_delivered = 0;

  StreetRounds() {
    REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &pair).ok());
    MergeServerParams params;
    params.cascade.stage_a = SequentialMatchParams{};  // the paper's stage A: B_ij = [A_ij <= tau_inter]
    params.cascade.stage_a.tau_area = 1;
    server = commerge::test::MakeTestServer(2, 100, params);
    std::mt19937 rng(3);
    d4 = {RandomDescriptor(&rng), RandomDescriptor(&rng), RandomDescriptor(&rng), RandomDescriptor(&rng)};
    REQUIRE(server->OnKeyframeBatch(MakeBatch(0, 0, d4, std::vector<Eigen::Vector3d>(4, Eigen::Vector3d::Zero()), 0)).ok());
    REQUIRE(server->OnKeyframeBatch(MakeBatch(1, 0, {d4[3]}, {Eigen::Vector3d::Zero()}, 0)).ok());
  }
  // Answers the requests with the two submaps' scans (robot 0's keyframes 3 and later hold the target's, robot 1's
  // the source's).
  void Deliver(const std::vector<ScanRequest>& requests) {
    for (const ScanRequest& q : requests) {
      for (std::uint32_t k : q.keyframes) {
        const bool target = q.robot_id == 0;
        REQUIRE(k >= (target ? 3u : 0u));
        for (const ScanChunk& c : ChunksOf(q.robot_id, k, EncodeForTest(target ? pair.target.points : pair.source.points), 1200)) {
          REQUIRE(server->OnScanChunk(c).ok());
        }
        ++scans_delivered;
      }
    }
  }
  // One round: Begin, deliver what it asks (when `answer`), Continue until done. Returns the first requests.
  std::vector<ScanRequest> Round(MergeRound* round, bool answer = true) {
    std::vector<ScanRequest> first, requests;
    REQUIRE(round->Begin(Span<const std::int64_t>(sessions), &requests).ok());
    first = requests;
    for (bool done = false; !done;) {
      if (answer) Deliver(requests);
      auto next = round->Continue(&requests);
      REQUIRE(next.ok());
      done = *next;
    }
    return first;
  }
  // Robot 1's keyframe 0 as a loop closure leaves it: moved by T_moved in its map frame.
  void MoveBeta(const Eigen::Isometry3d& T_moved) {
    PoseUpdate u;
    u.robot_id = 1;
    u.keyframes = {0};
    u.T_map_sensor = {T_moved};
    REQUIRE(server->OnPoseUpdate(u).ok());
  }
  // The robots meet again: robot 0's keyframe 4 (at P0) and robot 1's keyframe 1 (at P1) get one descriptor, so
  // stage A pairs them, and the submaps' scans (Deliver).
  void MeetAgain(const Eigen::Isometry3d& P0, const Eigen::Isometry3d& P1) {
    std::mt19937 rng(8);
    const auto d5 = RandomDescriptor(&rng);
    REQUIRE(server->OnKeyframeBatch(MakeBatch(0, 4, {d5}, {Eigen::Vector3d::Zero()}, 0)).ok());
    REQUIRE(server->OnKeyframeBatch(MakeBatch(1, 1, {d5}, {Eigen::Vector3d::Zero()}, 0)).ok());
    for (const auto& [robot, pose] : {std::make_pair(0, P0), std::make_pair(1, P1)}) {
      PoseUpdate u;
      u.robot_id = robot;
      u.keyframes = {robot == 0 ? 4u : 1u};
      u.T_map_sensor = {pose};
      REQUIRE(server->OnPoseUpdate(u).ok());
    }
  }
};

std::size_t Scans(const std::vector<ScanRequest>& requests) {
  std::size_t n = 0;
  for (const ScanRequest& q : requests) n += q.keyframes.size();
  return n;
}

}  // namespace

TEST_CASE("Merge round: an accepted pair asks for the scans spread along its shared path and refines its transform") {
  // Robot 0's keyframes 0-3 at the origin (keyframe 3 matches robot 1's keyframe 0, stage A's only loop), 4 and 5
  // at 6 and 12 m along x; robot 1's keyframes 1 and 2 where the truth places them on robot 0's 4 and 5. Every
  // scan holds its robot's submap of the street, seen from its keyframe.
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &pair).ok());
  const Eigen::Isometry3d& truth = pair.T_target_source;
  const std::vector<Eigen::Vector3d> alpha_at = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(),
                                                 Eigen::Vector3d::Zero(), Eigen::Vector3d(6.0, 0.0, 0.0),
                                                 Eigen::Vector3d(12.0, 0.0, 0.0)};
  const std::vector<Eigen::Vector3d> beta_at = {Eigen::Vector3d::Zero(), truth.inverse() * alpha_at[4],
                                                truth.inverse() * alpha_at[5]};
  for (std::size_t scans_per_robot : {0u, 2u}) {
    CAPTURE(scans_per_robot);
    MergeServerParams params;
    params.cascade.stage_a = SequentialMatchParams{};
    params.cascade.stage_a.tau_area = 1;
    params.refine.scans_per_robot = scans_per_robot;
    params.refine.shared_path_m = 3.0;
    params.refine.min_spacing_m = 4.0;
    auto server = commerge::test::MakeTestServer(2, 100, params);
    std::mt19937 rng(3);
    std::vector<std::array<float, kKeyframeDescriptorDim>> da, db;
    for (int k = 0; k < 6; ++k) da.push_back(RandomDescriptor(&rng));
    db = {da[3], RandomDescriptor(&rng), RandomDescriptor(&rng)};
    REQUIRE(server->OnKeyframeBatch(MakeBatch(0, 0, da, alpha_at, 0)).ok());
    REQUIRE(server->OnKeyframeBatch(MakeBatch(1, 0, db, beta_at, 0)).ok());
    const auto deliver = [&](const std::vector<ScanRequest>& requests) {
      for (const ScanRequest& q : requests) {
        for (std::uint32_t k : q.keyframes) {
          const bool alpha = q.robot_id == 0;
          const Eigen::Vector3f at = (alpha ? alpha_at : beta_at)[k].cast<float>();
          std::vector<PointXYZI> seen = alpha ? pair.target.points : pair.source.points;
          for (PointXYZI& p : seen) {
            p.x -= at.x();
            p.y -= at.y();
            p.z -= at.z();
          }
          for (const ScanChunk& c : ChunksOf(q.robot_id, k, EncodeForTest(seen), 1200)) {
            REQUIRE(server->OnScanChunk(c).ok());
          }
        }
      }
    };
    MergeRound round(server.get(), MergeRoundParams{});
    std::vector<ScanRequest> requests;
    REQUIRE(round.Begin(Span<const std::int64_t>(kSessions), &requests).ok());
    REQUIRE(requests.size() == 2);
    CHECK(requests[0].keyframes == std::vector<std::uint32_t>{3});
    CHECK(requests[1].keyframes == std::vector<std::uint32_t>{0});
    deliver(requests);
    auto done = round.Continue(&requests);
    REQUIRE(done.ok());
    if (scans_per_robot == 0) {
      CHECK(*done);
      CHECK(requests.empty());
      const MergeRoundResult& r = round.result();
      REQUIRE(r.pairs.size() == 1);
      CHECK(r.pairs[0].merged());
      CHECK(r.refined_scans == 0);
      CHECK_FALSE(r.pairs[0].refinement.attempted);
      continue;
    }
    // Accepted: the round asks for robot 0's keyframes 4 and 5 and robot 1's 1 and 2, the spread picks. Robot 1's
    // held keyframe 0 is not on the shared path (the truth places it 3.9 m from robot 0's keyframe 5, beyond 3 m), so
    // the pick nearest it anchors the set.
    REQUIRE_FALSE(*done);
    REQUIRE(requests.size() == 2);
    CHECK(requests[0].robot_id == 0);
    CHECK(requests[0].keyframes == std::vector<std::uint32_t>{4, 5});
    CHECK(requests[1].robot_id == 1);
    CHECK(requests[1].keyframes == std::vector<std::uint32_t>{1, 2});
    deliver(requests);
    done = round.Continue(&requests);
    REQUIRE(done.ok());
    CHECK(*done);
    CHECK(requests.empty());
    const MergeRoundResult& r = round.result();
    REQUIRE(r.pairs.size() == 1);
    const PairMergeResult& p = r.pairs[0];
    CHECK(p.merged());
    CHECK(r.refined_scans == 4);
    CHECK(r.plan.requests.size() == 4);
    CHECK(p.refinement.attempted);
    CHECK(p.refinement.taken);
    CHECK(p.refinement.alpha_scans == 2);
    CHECK(p.refinement.beta_scans == 2);
    CHECK(p.refinement.alpha_missing + p.refinement.beta_missing == 0);
    CHECK(p.refinement.verdict == RegistrationVerdict::kSuccess);
    // The registered transform is kept beside the refined one; both lie at the truth.
    CHECK(p.refinement.moved_m <= params.refine.max_correction_m);
    CHECK(test::TranslationErrorM(truth, p.refinement.T_target_source_registered) < 0.3);
    CHECK(test::TranslationErrorM(truth, p.registration.T_target_source) < 0.2);
    CHECK(test::RotationErrorDeg(truth, p.registration.T_target_source) < 1.0);
    REQUIRE(r.frames_ok);
    CHECK(r.T_world_map(1).isApprox(p.registration.T_target_source));
    // Each spread place registered on its own (one scan of each robot): the same transform, the truth's.
    REQUIRE(p.refinement.places.size() == 2);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> places;
    for (const PlaceRegistration& place : p.refinement.places) {
      places.emplace_back(place.alpha_keyframe, place.beta_keyframe);
      CHECK(place.success);
      CHECK(place.verdict == RegistrationVerdict::kSuccess);
      CHECK(test::TranslationErrorM(truth, place.T_alpha_beta) < 0.2);
      CHECK(test::RotationErrorDeg(truth, place.T_alpha_beta) < 1.0);
    }
    std::sort(places.begin(), places.end());
    CHECK(places == std::vector<std::pair<std::uint32_t, std::uint32_t>>{{4, 1}, {5, 2}});
  }
}

TEST_CASE("Merge round: a verified pair keeps its result and asks for no scans while nothing changed, not after a restart") {
  StreetRounds s;
  MergeRound round(s.server.get(), MergeRoundParams{});
  CHECK(Scans(s.Round(&round)) == 2);
  REQUIRE(round.result().pairs.size() == 1);
  REQUIRE(round.result().pairs[0].registration.success());
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kRobotNotPlaced);
  CHECK(round.result().decisions[0].scans_requested == 2);
  CHECK(round.result().in_world(1));
  CHECK(test::TranslationErrorM(s.pair.T_target_source, round.result().T_world_map(1)) < 0.2);
  REQUIRE(round.history(0, 1) != nullptr);
  CHECK(round.history(0, 1)->verified.size() == 1);

  // Round 2: nothing changed. The server dropped the scans, so a round that re-ran the exchange would ask for
  // both again: this one asks for none, registers nothing and keeps round 1's registration.
  s.server->ClearScans();
  const std::vector<ScanRequest> asked = s.Round(&round, /*answer=*/false);
  CHECK(asked.empty());
  const MergeRoundResult r2 = round.result();  // a copy: round 3 replaces result()
  CHECK(r2.round == 2);
  CHECK(r2.decisions[0].reason == PairExchangeReason::kUnchanged);
  CHECK(r2.pairs_registered == 0);
  CHECK(r2.pairs_kept == 1);
  CHECK(r2.registration_s[0] == 0.0);
  CHECK(r2.pairs[0].kept_from_round == 1);
  CHECK(r2.pairs[0].registration.success());
  CHECK(r2.in_world(1));
  CHECK(r2.T_world_map(1).isApprox(round.history(0, 1)->verified[0].result.registration.T_target_source));
  // The same round with the rule off asks for both scans again.
  {
    MergeRoundParams every;
    every.exchange.enabled = false;
    StreetRounds t;
    MergeRound plain(t.server.get(), every);
    t.Round(&plain);
    t.server->ClearScans();
    CHECK(Scans(t.Round(&plain, /*answer=*/false)) == 2);
    CHECK(plain.result().decisions[0].reason == PairExchangeReason::kEveryRound);
    CHECK(plain.result().pairs[0].kept_from_round == 1);  // nobody sent them: the verified result stands
  }

  // Round 3: robot 1 restarted (a new session, a new map frame): the old registration no longer holds.
  s.sessions[1] = 21;
  CHECK(Scans(s.Round(&round, /*answer=*/false)) == 2);
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kRobotRestarted);
  CHECK(round.result().pairs[0].kept_from_round == 0);
  CHECK_FALSE(round.result().pairs[0].registration.success());
  CHECK_FALSE(round.result().in_world(1));

  // The merge result message says what the round found, robot by robot and pair by pair.
  const MergeResultMessage m = MakeMergeResultMessage(r2, *s.server, Span<const int>(std::vector<int>{0, 1}),
                                                      Span<const std::uint32_t>(std::vector<std::uint32_t>{4, 1}), 77, 5);
  CHECK(m.server_session == 77);
  CHECK(m.utime_us == 5);
  CHECK(m.round == 2);
  CHECK(m.robot_ids == std::vector<int>{0, 1});
  CHECK(m.in_world == std::vector<std::uint8_t>{1, 1});
  CHECK(m.keyframes == std::vector<std::uint32_t>{4, 1});
  REQUIRE(m.pairs.size() == 1);
  CHECK(m.pairs[0].success);
  CHECK(m.pairs[0].consistent);
  CHECK(m.pairs[0].verdict.find("kept from round 1") != std::string::npos);
  CHECK(m.pairs[0].loops_stage_a == 1);
  CHECK(m.T_world_map[1].isApprox(r2.T_world_map(1)));
}

TEST_CASE("Merge round: new keyframes that change the cascade's selection cost a verified pair no scans") {
  StreetRounds s;
  MergeRound round(s.server.get(), MergeRoundParams{});
  s.Round(&round);
  REQUIRE(round.result().in_world(1));
  // Both robots drive on and meet again: robot 1's keyframes 1..3 see robot 0's places 0..2, so stage A's L_seq
  // and the plan grow to keyframes the server has no scans of.
  REQUIRE(s.server->OnKeyframeBatch(MakeBatch(1, 1, {s.d4[0], s.d4[1], s.d4[2]},
                                              std::vector<Eigen::Vector3d>(3, Eigen::Vector3d::Zero()), 0)).ok());
  REQUIRE(s.server->RunCascades().ok());
  auto plan = s.server->Plan(ExchangeMode::kStageABC);
  REQUIRE(plan.ok());
  std::size_t unheld = 0;
  for (const ScanRequest& q : plan->requests) {
    for (std::uint32_t k : q.keyframes) unheld += s.server->has_scan(q.robot_id, k) ? 0 : 1;
  }
  REQUIRE(unheld > 0);
  const std::vector<ScanRequest> asked = s.Round(&round, /*answer=*/false);
  CHECK(asked.empty());
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kUnchanged);
  CHECK(round.result().pairs[0].kept_from_round == 1);
  CHECK(round.result().in_world(1));
}

TEST_CASE("Merge round: a bridge registers a new overlap far from its verified one as a second region") {
  StreetRounds s;
  MergeRound round(s.server.get(), MergeRoundParams{});
  s.Round(&round);
  REQUIRE(round.result().pairs[0].registration.success());
  // Two robots: nothing else checks the pair's transform.
  REQUIRE(round.history(0, 1)->verified.size() == 1);
  CHECK(round.history(0, 1)->verified[0].verdict == MeasurementVerdict::kUnverified);
  // The robots meet again 120 m on: robot 0's keyframe 4 and robot 1's keyframe 1 see the street again, placed so
  // that the same T relates the two maps (robot 1's pose there is T^-1 * P0 * T).
  const Eigen::Isometry3d T = s.pair.T_target_source;
  const Eigen::Isometry3d P0 = test::YawOffset(0.0, 120.0, 0.0, 0.0);
  const Eigen::Isometry3d P1 = T.inverse() * P0 * T;
  s.MeetAgain(P0, P1);
  const std::vector<ScanRequest> asked = s.Round(&round);
  const MergeRoundResult& r2 = round.result();
  CHECK(r2.decisions[0].reason == PairExchangeReason::kNewOverlap);
  CHECK(r2.decisions[0].region == 1);
  CHECK(r2.decisions[0].overlap_distance_m > 100.0);
  CHECK(Scans(asked) == 2);  // the new place's scans; the verified ones are held
  // Two entries for the pair, both registered right, both measurements of the frame solver, which now checks one
  // against the other.
  REQUIRE(r2.pairs.size() == 2);
  CHECK(r2.pairs[0].kept_from_round == 1);
  REQUIRE(r2.pairs[1].registration.success());
  CHECK(r2.pairs[1].kept_from_round == 0);
  CHECK(test::TranslationErrorM(T, r2.pairs[1].registration.T_target_source) < 0.2);
  REQUIRE(r2.frames_ok);
  REQUIRE(r2.frames.measurements.size() == 2);
  CHECK(r2.frames.measurements[0].verdict == MeasurementVerdict::kAccepted);
  CHECK(r2.frames.measurements[1].verdict == MeasurementVerdict::kAccepted);
  REQUIRE(round.history(0, 1)->verified.size() == 2);
  // Checked now: later rounds keep both and ask for nothing.
  CHECK(s.Round(&round).empty());
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kUnchanged);
  CHECK(round.result().pairs.size() == 2);
  CHECK(round.result().pairs_kept == 1);
  CHECK(round.result().in_world(1));
}

TEST_CASE("Merge round: a verified region the frame solver rejects is dropped at the next round, its place stays tried") {
  StreetRounds s;
  MergeRound round(s.server.get(), MergeRoundParams{});
  s.Round(&round);
  REQUIRE(round.result().pairs[0].registration.success());
  // A second meeting 120 m on whose poses put robot 1's map 6 m off where the first one does (a map that bent
  // between the two places): its registration succeeds but disagrees with the first by more than the frame
  // solver's 2 m.
  const Eigen::Isometry3d T = s.pair.T_target_source;
  const Eigen::Isometry3d P0 = test::YawOffset(0.0, 120.0, 0.0, 0.0);
  const Eigen::Isometry3d P1 = test::YawOffset(0.0, 6.0, 0.0, 0.0) * T.inverse() * P0 * T;
  s.MeetAgain(P0, P1);
  s.Round(&round);
  const MergeRoundResult r2 = round.result();
  REQUIRE(r2.pairs.size() == 2);
  REQUIRE(r2.pairs[1].registration.success());
  REQUIRE(r2.frames.measurements.size() == 2);
  int rejected = -1;
  for (int i = 0; i < 2; ++i) {
    if (r2.frames.measurements[static_cast<std::size_t>(i)].verdict == MeasurementVerdict::kRejected) rejected = i;
  }
  REQUIRE(rejected >= 0);  // two parallel measurements 6 m apart: one of them is rejected
  // Round 3: the rejected region is no longer trusted; the other stays, and where the rejected one was stays
  // tried (the cascade's selection there is nothing new).
  s.Round(&round);
  const PairHistory* h = round.history(0, 1);
  REQUIRE(h != nullptr);
  CHECK(h->verified.size() == 1);
  CHECK(h->rejected_round == 2);
  CHECK(h->tried.size() == 2);
  CHECK(round.result().pairs.size() == 1);
  CHECK(round.result().pairs[0].registration.success());
  CHECK(round.result().in_world(1));
}

TEST_CASE("Merge round: a loop closure that moves the verified overlap beyond the bound registers the pair again") {
  StreetRounds s;
  MergeRound round(s.server.get(), MergeRoundParams{});
  s.Round(&round);
  REQUIRE(round.result().pairs[0].registration.success());
  const Eigen::Isometry3d T_first = round.result().pairs[0].registration.T_target_source;

  // A move below the bound (0.3 m): kept, no registration.
  s.MoveBeta(test::YawOffset(0.0, 0.3, 0.0, 0.0));
  CHECK(s.Round(&round).empty());
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kUnchanged);
  CHECK(round.result().decisions[0].motion.max_translation_m == doctest::Approx(0.3).epsilon(1e-6));
  CHECK(round.result().pairs_registered == 0);
  CHECK(round.result().pairs[0].registration.T_target_source.isApprox(T_first));

  // Robot 1's loop closure turns and shifts its map where the robots met: 4 deg and 2.5 m. The scans are held,
  // so the round asks for none and registers the overlap again at the moved poses: p_0 = T p_1 with the moved
  // map frame of robot 1 is T_first * inv(T_moved).
  const Eigen::Isometry3d T_moved = test::YawOffset(4.0, 2.5, -1.0, 0.0);
  s.MoveBeta(T_moved);
  CHECK(s.Round(&round).empty());
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kPosesMoved);
  CHECK(round.result().decisions[0].motion.max_translation_m > 2.0);
  CHECK(round.result().pairs_registered == 1);
  CHECK(round.result().registration_s[0] > 0.0);
  REQUIRE(round.result().pairs[0].registration.success());
  CHECK(round.result().pairs[0].kept_from_round == 0);
  const Eigen::Isometry3d T_expected = s.pair.T_target_source * T_moved.inverse();
  CHECK(test::TranslationErrorM(T_expected, round.result().T_world_map(1)) < 0.2);
  CHECK(test::TranslationErrorM(T_first, round.result().T_world_map(1)) > 1.0);
  CHECK(round.history(0, 1)->verified[0].region.round == round.result().round);

  // Another move, on a server that no longer holds the scans: the round requests the overlap's scans, then
  // registers it at the new poses.
  s.server->ClearScans();
  const Eigen::Isometry3d T_again = test::YawOffset(-3.0, -1.0, 2.0, 0.0);
  s.MoveBeta(T_again);
  const std::size_t before = s.scans_delivered;
  const std::vector<ScanRequest> asked = s.Round(&round);
  CHECK(Scans(asked) == 2);
  CHECK(s.scans_delivered - before == 2);
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kPosesMoved);
  CHECK(round.result().decisions[0].scans_requested == 2);
  REQUIRE(round.result().pairs[0].registration.success());
  CHECK(test::TranslationErrorM(s.pair.T_target_source * T_again.inverse(), round.result().T_world_map(1)) < 0.2);

  // Moved again while nobody sends the scans: the registration at the moved poses cannot run, the verified
  // result stands, and the next round asks again; answered, it registers the overlap at the moved poses.
  s.server->ClearScans();
  const Eigen::Isometry3d T_far = test::YawOffset(0.0, 5.0, 0.0, 0.0);
  s.MoveBeta(T_far);
  CHECK(Scans(s.Round(&round, /*answer=*/false)) == 2);
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kPosesMoved);
  CHECK(round.result().pairs[0].registration.success());
  CHECK(round.result().pairs[0].kept_from_round > 0);
  CHECK(round.result().in_world(1));
  CHECK(Scans(s.Round(&round)) == 2);
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kPosesMoved);
  REQUIRE(round.result().pairs[0].registration.success());
  CHECK(round.result().pairs[0].kept_from_round == 0);
  CHECK(test::TranslationErrorM(s.pair.T_target_source * T_far.inverse(), round.result().T_world_map(1)) < 0.2);
  CHECK(s.Round(&round).empty());
  CHECK(round.result().decisions[0].reason == PairExchangeReason::kUnchanged);
}

TEST_CASE("Server link emits the merge result the direct round makes on the same data") {
  for (int steps : {0, 2}) {
    CAPTURE(steps);
    // Direct: the round driven by calls, as commerge run does.
    std::unique_ptr<MergeServer> direct_server = ShiftedServer(steps);
    MergeRound round(direct_server.get(), MergeRoundParams{});
    std::vector<ScanRequest> requests;
    const std::vector<std::int64_t> sessions = {1000, 1001};  // ShiftedPairBatches' sessions
    REQUIRE(round.Begin(Span<const std::int64_t>(sessions), &requests).ok());
    for (bool done = false; !done;) {
      AnswerTiny(direct_server.get(), requests);
      auto next = round.Continue(&requests);
      REQUIRE(next.ok());
      done = *next;
    }
    const MergeResultMessage direct =
        MakeMergeResultMessage(round.result(), *direct_server, Span<const int>(std::vector<int>{0, 1}),
                               Span<const std::uint32_t>(std::vector<std::uint32_t>{kN, kN}), 500, 0);

    // Over messages, as commerge server does.
    std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, ShiftedParams(steps));
    MergeServer& server = *server_owner;
    ServerLinkParams lp;
    lp.automatic_rounds = false;
    ServerLink link(500, lp, &server);
    std::int64_t now = 1000000;
    for (const KeyframeBatch& b : ShiftedPairBatches(kN, kShift, 1000)) REQUIRE(link.OnKeyframeBatch(b, now).ok());
    link.RequestRound();
    const MergeResultMessage* result = nullptr;
    std::vector<ServerOutgoing> out;
    for (int poll = 0; poll < 20 && result == nullptr; ++poll, now += 100000) {
      out.clear();
      REQUIRE(link.Poll(now, &out).ok());
      for (const ServerOutgoing& o : out) {
        if (o.kind == ServerOutgoing::Kind::kMergeResult) result = &o.result;
        if (o.kind != ServerOutgoing::Kind::kScanRequest) continue;
        for (std::uint32_t k : o.request.keyframes) {
          for (ScanChunk c : ChunksOf(o.request.robot_id, k, EncodeForTest(LatticePoints(2)))) {
            c.request_id = o.request.request_id;
            (void)link.OnScanChunk(c, now);  // repeated requests: duplicates are fine
          }
        }
      }
    }
    REQUIRE(result != nullptr);
    CHECK(result->robot_ids == direct.robot_ids);
    CHECK(result->in_world == direct.in_world);
    CHECK(result->keyframes == direct.keyframes);
    REQUIRE(result->pairs.size() == direct.pairs.size());
    CHECK(result->pairs[0].verdict == direct.pairs[0].verdict);
    CHECK(result->pairs[0].alpha_scans == direct.pairs[0].alpha_scans);
    CHECK(result->pairs[0].beta_scans == direct.pairs[0].beta_scans);
    CHECK(result->pairs[0].loops_stage_a == direct.pairs[0].loops_stage_a);
    CHECK(result->pairs[0].loops_stage_c == direct.pairs[0].loops_stage_c);
    CHECK(link.last_round().widenings == round.result().widenings);
  }
}
