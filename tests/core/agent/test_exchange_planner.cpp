// SPDX-License-Identifier: BSD-3-Clause
// The merge server's exchange planner (core/agent/exchange_planner.hpp): plans per exchange mode match stage A's
// loops computed by brute force, the A+C ablation can be left out, the place check across pairs refuses a weakly
// supported pair other robots place elsewhere, widening follows the brute-force rule and asks only for scans the
// server lacks (not below tau_area, at an unconfirmed ambiguous place, or between robots merged pairs join), and
// RequestsFor asks each robot once for its pairs' keyframes.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <memory>
#include <random>
#include <set>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "core/agent/exchange_planner.hpp"
#include "core/agent/keyframe_database.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/scan_inbox.hpp"
#include "core/cloud/scan_codec.hpp"
#include "tests/core/agent/keyframe_batch_fixtures.hpp"
#include "tests/core/agent/merge_server_test_support.hpp"
#include "tests/core/agent/scan_chunk_fixtures.hpp"
#include "tests/core/agent/server_fixture.hpp"

using namespace commerge;
using commerge::test::AmbiguousShiftedPairBatches;
using commerge::test::BruteForceWiden;
using commerge::test::ChunksOf;
using commerge::test::EncodeForTest;
using commerge::test::LatticePoints;
using commerge::test::MakeBatch;
using commerge::test::PaperStageA;
using commerge::test::RandomDescriptor;
using commerge::test::ShiftedPairBatches;

namespace {

// The padding rule of the first plan test: at least `scans` scans per robot, no points rule.
ExchangePolicyParams ScanCountPolicy(std::uint32_t scans) {
  ExchangePolicyParams policy;
  policy.min_scans_per_robot = scans;
  policy.min_points_per_robot = 0;
  return policy;
}

// A server (stage A's tau_area 100, the given exchange policy) holding ShiftedPairBatches(n, shift), its cascades
// run.
std::unique_ptr<MergeServer> ShiftedPairServer(int n, int shift,
                                               const ExchangePolicyParams& policy = ScanCountPolicy(10)) {
  MergeServerParams params = PaperStageA(100);
  params.cascade.policy = policy;
  auto server = commerge::test::MakeTestServer(2, 100, params);
  for (const KeyframeBatch& b : ShiftedPairBatches(n, shift)) REQUIRE(server->OnKeyframeBatch(b).ok());
  REQUIRE(server->RunCascades().ok());
  return server;
}

// A registration of pair (alpha, beta) that ran and was refused (by `verdict`).
PairMergeResult Refused(int alpha, int beta, RegistrationVerdict verdict = RegistrationVerdict::kOverlapTooLow) {
  PairMergeResult r;
  r.alpha = alpha;
  r.beta = beta;
  r.attempted = true;
  r.registration.verdict = verdict;
  r.stop = PairStop::kRegistration;
  return r;
}

}  // namespace

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

TEST_CASE("Merge server plans: min_points_per_robot pads every mode by the points the robots reported") {
  // ShiftedPairBatches: alpha reports 2 000 stored points a scan, beta 3 000; stage A's loops are (j + 5, j).
  const int n = 40, shift = 5;
  for (const std::uint32_t min_points : {1u, 9000u, 24000u, 1000000u}) {
    CAPTURE(min_points);
    ExchangePolicyParams policy;
    policy.min_scans_per_robot = 0;
    policy.min_points_per_robot = min_points;
    const std::unique_ptr<MergeServer> owned = ShiftedPairServer(n, shift, policy);
    const ExchangeCascadeResult* cascade = owned->cascade(0, 1);
    REQUIRE(cascade != nullptr);
    REQUIRE(cascade->stage_a.found);
    std::set<std::uint32_t> pool_a, pool_b;
    for (const SequentialLoopCell& l : cascade->stage_a.cells) {
      pool_a.insert(static_cast<std::uint32_t>(l.alpha_index));
      pool_b.insert(static_cast<std::uint32_t>(l.beta_index));
    }
    for (ExchangeMode mode : {ExchangeMode::kStageAB, ExchangeMode::kStageAC, ExchangeMode::kStageABC}) {
      CAPTURE(ExchangeModeName(mode));
      auto plan = owned->Plan(mode);
      REQUIRE(plan.ok());
      REQUIRE(plan->pairs.size() == 1);
      const PairSelection& s = plan->pairs[0];
      for (const auto& [side, per_scan, pool] :
           {std::make_tuple(&s.alpha_keyframes, 2000u, &pool_a), std::make_tuple(&s.beta_keyframes, 3000u, &pool_b)}) {
        REQUIRE_FALSE(side->empty());
        for (std::uint32_t k : *side) CHECK(pool->count(k) == 1);  // only keyframes of stage A's loops
        // At least the fewest scans whose counts reach min_points, or the whole pool when it holds fewer points
        // (a mode's own selection may be larger).
        const std::size_t need = (min_points + per_scan - 1) / per_scan;
        CHECK(side->size() >= std::min(need, pool->size()));
        if (mode == ExchangeMode::kStageABC) {  // exactly: L_K's keyframes, or the fewest that reach the points
          const RobotScanRequest& r = side == &s.alpha_keyframes ? cascade->policy.alpha : cascade->policy.beta;
          const std::size_t own = r.keyframes.size() - r.padded_scans;
          CHECK(side->size() == std::max(own, std::min(need, pool->size())));
        }
      }
    }
  }
}

TEST_CASE("Merge server without the A+C ablation: the same A+B+C plan, no stage C over L_seq, and Plan(A+C) refused") {
  MergeServerParams with;
  with.cascade.stage_a = SequentialMatchParams{};
  with.cascade.stage_a.tau_area = 100;
  MergeServerParams without = with;
  without.stage_ac_ablation = false;
  std::unique_ptr<MergeServer> a_owner = commerge::test::MakeTestServer(2, 100, with);
  std::unique_ptr<MergeServer> b_owner = commerge::test::MakeTestServer(2, 100, without);
  MergeServer& a = *a_owner;
  MergeServer& b = *b_owner;
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
    params.decision.chain_check_support = chain_check_support;
    auto server = commerge::test::MakeTestServer(3, 100, params);
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
  // Every placed cluster of every pair has its descriptor agreement measured, in the cascade's order; the one
  // passed on comes first.
  for (auto [a, b] : {std::pair<int, int>{0, 1}, std::pair<int, int>{0, 2}, std::pair<int, int>{1, 2}}) {
    const ExchangeCascadeResult* c = off->cascade(a, b);
    REQUIRE(c != nullptr);
    REQUIRE_FALSE(c->placed_clusters.empty());
    CHECK(c->placed_clusters[0].passed_on);
    auto agreement = off->MeasurePlacementAgreement(a, b);
    REQUIRE(agreement.ok());
    REQUIRE(agreement->size() == c->placed_clusters.size());
    for (std::size_t k = 0; k < c->placed_clusters.size(); ++k) {
      CHECK((*agreement)[k].measured == c->placed_clusters[k].placement.valid);
      CHECK((*agreement)[k].ranked <= (*agreement)[k].colocated);
      CHECK((*agreement)[k].agreeing <= (*agreement)[k].ranked);
    }
  }
  CHECK(off->MeasurePlacementAgreement(0, 7).status().message().find("no cascade of robots 0 and 7") !=
        std::string::npos);
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
  bad.decision.chain_check_support = -1.0;
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

TEST_CASE("Merge server: a cluster that matched strangers, whose placement lays the rest of the robots side by side "
          "with unlike descriptors, asks for no scans") {
  // Every map frame is the world frame. Robot 0 drives x = 0..199 (y = 0). Robot 1 never meets it (x = 400..599,
  // y = 0), but its keyframes 90..111 look exactly like robot 0's 40..61 (the look-alike a forward-looking sensor
  // sees driving the other way): stage A's only cluster. Its placement moves robot 1 by -350 m, on top of robot
  // 0's keyframes 0..149 whose descriptors are unrelated: as many agree as chance lets (agree_chance), far fewer
  // than at a true place. The true pair (robot 1 along robot 0's path, alike all the way) is the control.
  std::mt19937 rng(47);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d0, d1, d_true;
  std::vector<Eigen::Vector3d> p0, p1;
  for (int i = 0; i < 200; ++i) {
    d0.push_back(RandomDescriptor(&rng));
    p0.emplace_back(i, 0.0, 0.0);
  }
  for (int j = 0; j < 200; ++j) {
    d1.push_back(j >= 90 && j <= 111 ? d0[static_cast<std::size_t>(j - 50)] : RandomDescriptor(&rng));
    p1.emplace_back(400.0 + j, 0.0, 0.0);
    d_true.push_back(d0[static_cast<std::size_t>(j)]);
  }
  auto run = [&](double disagree_odds, const std::vector<std::array<float, kKeyframeDescriptorDim>>& d,
                 const std::vector<Eigen::Vector3d>& p) {
    MergeServerParams params;
    params.decision.disagree_odds = disagree_odds;
    auto server = commerge::test::MakeTestServer(2, 200, params);
    REQUIRE(server->OnKeyframeBatch(MakeBatch(0, 0, d0, p0, 2000)).ok());
    REQUIRE(server->OnKeyframeBatch(MakeBatch(1, 0, d, p, 2000)).ok());
    REQUIRE(server->RunCascades().ok());
    return server;
  };
  // The reference: the log of how much likelier k of n agreeing keyframes are at a true place (each agrees with
  // probability 0.25) than among strangers (0.05), from the two binomial probabilities.
  const auto log_odds = [](std::size_t n, std::size_t k) {
    const auto log_binomial = [&](double q) {
      return std::lgamma(n + 1.0) - std::lgamma(k + 1.0) - std::lgamma(n - k + 1.0) + k * std::log(q) +
             (n - k) * std::log(1.0 - q);
    };
    return log_binomial(0.25) - log_binomial(0.05);
  };

  const auto off = run(0.0, d1, p1);
  const ExchangeCascadeResult* lone = off->cascade(0, 1);
  REQUIRE(lone != nullptr);
  REQUIRE(lone->outcome == CascadeOutcome::kPolicy);  // without the check the look-alike goes on to registration
  CHECK_FALSE(off->evidence(0, 1)->placement_agreement.measured);  // off: not measured either
  const ClusterPlacement& wrong = lone->consensus_placement;
  CHECK((wrong.Apply(wrong.place_beta_m) - wrong.place_beta_m).norm() > 300.0);

  const auto on = run(100.0, d1, p1);
  const PairEvidence* e = on->evidence(0, 1);
  REQUIRE(e != nullptr);
  REQUIRE(e->placement_agreement.measured);
  const PlacementAgreement& a = e->placement_agreement;
  CHECK(a.ranked >= 100);                 // robot 1's keyframes outside the cluster, on top of robot 0's
  CHECK(a.agreeing * 10 <= a.ranked);     // strangers: about agree_chance of them
  CHECK(PlacementLogOdds(*e, PairDecisionParams{}) == doctest::Approx(log_odds(a.ranked, a.agreeing)));
  CHECK(log_odds(a.ranked, a.agreeing) < -std::log(100.0));
  const ExchangeCascadeResult* refused = on->cascade(0, 1);
  CHECK(refused->outcome != CascadeOutcome::kPolicy);  // stage B never ran
  CHECK(refused->no_candidate_reason.find("at its cluster's placement " + std::to_string(a.agreeing) + " of " +
                                          std::to_string(a.ranked) + " co-located keyframes agree") !=
        std::string::npos);
  for (ExchangeMode mode : {ExchangeMode::kStageA, ExchangeMode::kStageAB, ExchangeMode::kStageAC, ExchangeMode::kStageABC}) {
    auto plan = on->Plan(mode);
    REQUIRE(plan.ok());
    REQUIRE(plan->pairs.size() == 1);
    CHECK(plan->pairs[0].stop == PairStop::kPlacementDisagrees);
    CHECK(plan->pairs[0].alpha_keyframes.empty());
    CHECK(plan->pairs[0].beta_keyframes.empty());
    CHECK(plan->requests.empty());
  }
  auto all = on->Plan(ExchangeMode::kSendAll);  // the send-all baseline still ships everything
  REQUIRE(all.ok());
  CHECK(all->pairs[0].alpha_keyframes.size() == 200);

  // The control: robot 1 drives robot 0's path; its keyframes outside the cluster agree where they lie.
  const auto truth = run(100.0, d_true, p0);
  const PairEvidence* t = truth->evidence(0, 1);
  REQUIRE(t != nullptr);
  CHECK(truth->cascade(0, 1)->outcome == CascadeOutcome::kPolicy);
  // Its cluster covers the whole shared path: nothing outside it to rank, no evidence against it.
  REQUIRE(t->placement_agreement.measured);
  CHECK(t->placement_agreement.ranked == 0);
  CHECK(PlacementLogOdds(*t, PairDecisionParams{}) == 0.0);
  CHECK(truth->Plan(ExchangeMode::kStageABC)->requests.size() == 2);
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
  merged.stop = PairStop::kNone;
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

TEST_CASE("Merge server does not widen a refused pair whose stage A cluster was below tau_area (verification)") {
  // ShiftedPairBatches(40, 5): stage A's cluster spans 35 x 35 = 1225 cells.
  const auto widened_pairs = [](std::uint64_t tau_area) {
    MergeServerParams params = PaperStageA(tau_area);
    params.cascade.verification_area_fraction = 0.5;
    std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, params);
    MergeServer& server = *server_owner;
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
    params.decision.min_ambiguous_support = 0.0;
    params.decision.widen_ambiguous_support = widen_ambiguous_support;
    REQUIRE(ValidateMergeServerParams(params).ok());
    std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, params);
    MergeServer& server = *server_owner;
    for (const KeyframeBatch& b : AmbiguousShiftedPairBatches()) REQUIRE(server.OnKeyframeBatch(b).ok());
    REQUIRE(server.RunCascades().ok());
    const ExchangeCascadeResult* c = server.cascade(0, 1);
    REQUIRE(c != nullptr);
    REQUIRE(c->stage_a.found);
    Outcome o;
    o.ambiguous = c->ambiguous;
    o.support = c->consensus_measured ? c->consensus_support_chosen : -1.0;
    CHECK(AmbiguousPlaceConfirmed(CascadeEvidence(*c), params.decision) ==
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
    bad.decision.widen_ambiguous_support = v;
    CHECK_FALSE(ValidateMergeServerParams(bad).ok());
  }
}

TEST_CASE("Merge server: a place consensus over its memory cap lowers an ambiguous pair's support to its own "
          "weight and says so, it does not switch the check off") {
  // AmbiguousShiftedPairBatches: stage A's cluster (25 x 25) is at a place alpha saw twice. With the consensus
  // measured its support is at least its own 25 loops; with more cells below threshold than the cap allows no
  // other cluster votes, so the support is the cluster's own weight, and 40 are asked of an ambiguous place. (A
  // cap that left the support unmeasured would leave the rule nothing to judge, and the pair requested.)
  const auto run = [](std::size_t consensus_max_cells) {
    MergeServerParams params = PaperStageA(200);
    params.cascade.max_ambiguous_fraction = 0.1;
    params.cascade.consensus_max_cells = consensus_max_cells;
    params.decision.min_ambiguous_support = 40.0;
    auto server = commerge::test::MakeTestServer(2, 100, params);
    for (const KeyframeBatch& b : AmbiguousShiftedPairBatches()) REQUIRE(server->OnKeyframeBatch(b).ok());
    REQUIRE(server->RunCascades().ok());
    return server;
  };
  const auto measured = run(50000);
  const ExchangeCascadeResult* m = measured->cascade(0, 1);
  REQUIRE(m != nullptr);
  REQUIRE(m->ambiguous);
  REQUIRE(m->consensus_measured);
  CHECK_FALSE(m->consensus_capped);
  const std::uint64_t cells = m->stage_a.num_cells_below_threshold;
  REQUIRE(cells > 1);

  const auto capped = run(static_cast<std::size_t>(cells - 1));  // one cell over the cap
  const ExchangeCascadeResult* c = capped->cascade(0, 1);
  REQUIRE(c != nullptr);
  REQUIRE(c->ambiguous);
  CHECK(c->consensus_capped);
  CHECK(c->consensus_measured);
  CHECK(c->consensus_support_chosen == c->consensus_placement.weight);  // its own weight, no other vote
  CHECK(c->consensus_support_chosen <= m->consensus_support_chosen);
  CHECK(c->consensus_support_chosen < 40.0);
  const PairEvidence* e = capped->evidence(0, 1);
  REQUIRE(e != nullptr);
  CHECK(DecideRequest(*e, capped->params().decision).stop == PairStop::kAmbiguousUnconfirmed);
  auto plan = capped->Plan(ExchangeMode::kStageABC);
  REQUIRE(plan.ok());
  REQUIRE(plan->pairs.size() == 1);
  CHECK(plan->pairs[0].stop == PairStop::kAmbiguousUnconfirmed);
  CHECK(plan->pairs[0].alpha_keyframes.empty());
  CHECK(plan->pairs[0].no_selection_reason.find(std::to_string(cells) + " cells below threshold > " +
                                                std::to_string(cells - 1) + " (--consensus-max-cells)") !=
        std::string::npos);
}

TEST_CASE("Merge server does not widen a refused pair whose robots merged pairs already join") {
  MergeServerParams params = PaperStageA(100);
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(3, 100, params);
  MergeServer& server = *server_owner;
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
    r.stop = PairStop::kNone;
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

TEST_CASE("Exchange planner: RequestsFor asks each robot once for its pairs' keyframes whose scans are not held") {
  MergeServerParams params;
  params.cascade.policy.assumed_points_per_scan = 50;  // a keyframe with no reported count: 12 + 6 x 50 bytes
  auto db = KeyframeDatabase::Create(3, 20, KeyframeRecordKind::kUnit40);
  REQUIRE(db.ok());
  MergeServerStats stats;
  std::mt19937 rng(13);
  const auto batch = [&rng](int robot, std::size_t n, std::uint32_t points) {
    std::vector<std::array<float, kKeyframeDescriptorDim>> d;
    std::vector<Eigen::Vector3d> p;
    for (std::size_t k = 0; k < n; ++k) {
      d.push_back(RandomDescriptor(&rng));
      p.emplace_back(static_cast<double>(k), 0.0, 0.0);
    }
    return MakeBatch(robot, 0, d, p, points);
  };
  // Robot 0: keyframes 0..5 of 100 points; robot 1: 0..2 of 200 points; robot 2: 0..1 with no count.
  REQUIRE(db->OnKeyframeBatch(batch(0, 6, 100), &stats).ok());
  REQUIRE(db->OnKeyframeBatch(batch(1, 3, 200), &stats).ok());
  REQUIRE(db->OnKeyframeBatch(batch(2, 2, 0), &stats).ok());
  auto inbox = ScanInbox::Create(3, ScanInboxLimits{});
  REQUIRE(inbox.ok());
  for (const ScanChunk& c : ChunksOf(0, 5, EncodeForTest(LatticePoints(10)))) {
    REQUIRE(inbox->OnScanChunk(c, &stats, [] {}).ok());
  }
  REQUIRE(inbox->has_scan(0, 5));

  const auto pair = [](int alpha, int beta, std::vector<std::uint32_t> a, std::vector<std::uint32_t> b) {
    PairSelection s;
    s.alpha = alpha;
    s.beta = beta;
    s.alpha_keyframes = std::move(a);
    s.beta_keyframes = std::move(b);
    return s;
  };
  // Robot 0 in two pairs (keyframe 3 in both, 5 held), robot 2's keyframe 7 beyond what it sent, robot 5 not a
  // robot of this server.
  const std::vector<PairSelection> selections = {pair(0, 1, {1, 3, 5}, {2}), pair(0, 2, {3, 4}, {0, 7}),
                                                 pair(1, 5, {0}, {1})};
  const ExchangePlanner planner(params);
  const ExchangePlan plan = planner.RequestsFor(Span<const PairSelection>(selections), 10, *db, *inbox);
  CHECK(plan.pairs.empty());
  REQUIRE(plan.requests.size() == 3);
  CHECK(plan.requests[0].robot_id == 0);
  CHECK(plan.requests[0].request_id == 10);
  CHECK(plan.requests[0].keyframes == std::vector<std::uint32_t>{1, 3, 4});
  CHECK(plan.requests[1].robot_id == 1);
  CHECK(plan.requests[1].request_id == 11);
  CHECK(plan.requests[1].keyframes == std::vector<std::uint32_t>{0, 2});
  CHECK(plan.requests[2].robot_id == 2);
  CHECK(plan.requests[2].request_id == 12);
  CHECK(plan.requests[2].keyframes == std::vector<std::uint32_t>{0, 7});
  // 3 x (12 + 600) + 2 x (12 + 1200) + 2 x (12 + 300)
  CHECK(plan.predicted_scan_bytes == 3 * 612 + 2 * 1212 + 2 * 312);

  const ExchangePlan none = planner.RequestsFor(Span<const PairSelection>(), 1, *db, *inbox);
  CHECK(none.requests.empty());
  CHECK(none.predicted_scan_bytes == 0);

  // AdoptSelections replaces the selection of the pairs it has, matched by robot pair.
  std::vector<PairSelection> current = selections;
  const std::vector<PairSelection> adopted = {pair(0, 2, {9}, {8}), pair(1, 2, {6}, {6})};
  AdoptSelections(Span<const PairSelection>(adopted), &current);
  REQUIRE(current.size() == 3);
  CHECK(current[0].alpha_keyframes == std::vector<std::uint32_t>{1, 3, 5});
  CHECK(current[1].alpha_keyframes == std::vector<std::uint32_t>{9});
  CHECK(current[1].beta_keyframes == std::vector<std::uint32_t>{8});
  CHECK(current[2].beta == 5);
  CHECK(current[2].alpha_keyframes == std::vector<std::uint32_t>{0});
}
