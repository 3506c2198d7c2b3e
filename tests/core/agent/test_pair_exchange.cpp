// SPDX-License-Identifier: BSD-3-Clause
// What a merge round asks of a pair (core/agent/pair_exchange.hpp), case by case against the rule written out
// here, and its two measures (how far a verified overlap moved, how far a selection is from the places tried)
// against brute-force definitions on random poses.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/agent/pair_exchange.hpp"
#include "core/geometry/angles.hpp"

using namespace commerge;

namespace {

// Keyframe k of robot alpha at (k, 0, 0) and of robot beta at (k, 10, 0), k = 0..n-1, all known.
struct Poses {
  std::vector<Eigen::Isometry3d> alpha, beta;
  std::vector<std::uint8_t> known_alpha, known_beta;
  explicit Poses(int n) {
    for (int k = 0; k < n; ++k) {
      Eigen::Isometry3d a = Eigen::Isometry3d::Identity(), b = Eigen::Isometry3d::Identity();
      a.translation() = Eigen::Vector3d(k, 0.0, 0.0);
      b.translation() = Eigen::Vector3d(k, 10.0, 0.0);
      alpha.push_back(a);
      beta.push_back(b);
    }
    known_alpha.assign(static_cast<std::size_t>(n), 1);
    known_beta.assign(static_cast<std::size_t>(n), 1);
  }
  RobotPoses A() const { return RobotPoses{Span<const Eigen::Isometry3d>(alpha), Span<const std::uint8_t>(known_alpha)}; }
  RobotPoses B() const { return RobotPoses{Span<const Eigen::Isometry3d>(beta), Span<const std::uint8_t>(known_beta)}; }
};

std::vector<std::uint32_t> Range(std::uint32_t first, std::uint32_t count) {
  std::vector<std::uint32_t> v;
  for (std::uint32_t i = 0; i < count; ++i) v.push_back(first + i);
  return v;
}

PairSelection Selection(std::uint32_t first, std::uint32_t count) {
  PairSelection s;
  s.alpha = 0;
  s.beta = 1;
  s.alpha_keyframes = Range(first, count);
  s.beta_keyframes = Range(first, count);
  return s;
}

// A history whose pair was registered (verified when `verified`) at keyframes first..first+count-1 with the
// poses as they are in `poses`.
PairHistory History(const Poses& poses, std::uint32_t first, std::uint32_t count, bool verified,
                    MeasurementVerdict verdict = MeasurementVerdict::kAccepted) {
  PairHistory h;
  h.alpha = 0;
  h.beta = 1;
  h.alpha_session = h.beta_session = 1;
  PairRegion region = MakePairRegion(Selection(first, count), poses.A(), poses.B(), 1);
  h.tried.push_back(region);
  if (verified) {
    VerifiedRegion v;
    v.result.alpha = 0;
    v.result.beta = 1;
    v.result.attempted = true;
    v.result.registration.verdict = RegistrationVerdict::kSuccess;
    v.result.stop = PairStop::kNone;
    v.region = region;
    v.verdict = verdict;
    h.verified.push_back(v);
  } else {
    h.refused_round = 1;
    h.refused_reason = "too_few_points";
  }
  return h;
}

PairExchangeDecision Decide(const PairSelection& plan, const PairHistory* history, const Poses& poses,
                            bool placed = true, bool restarted = false, PairExchangeParams params = {}) {
  PairExchangeInput in;
  in.plan = &plan;
  in.history = history;
  in.restarted = restarted;
  in.alpha_placed = true;
  in.beta_placed = placed;
  in.alpha = poses.A();
  in.beta = poses.B();
  return DecidePairExchange(in, params);
}

}  // namespace

TEST_CASE("Pair exchange: pairs without a verified registration are registered while a robot is not placed") {
  const Poses poses(400);
  const PairSelection plan = Selection(10, 12);
  // Nothing known, robot 1 not placed: full priority.
  PairExchangeDecision d = Decide(plan, nullptr, poses, /*placed=*/false);
  CHECK(d.reason == PairExchangeReason::kRobotNotPlaced);
  CHECK(RegistersPair(d.reason));
  CHECK(d.selection.alpha_keyframes == plan.alpha_keyframes);
  CHECK(d.why.find("robot 1") != std::string::npos);
  // Refused before at the same place: still registered, the robot is not placed.
  const PairHistory refused = History(poses, 10, 12, /*verified=*/false);
  CHECK(Decide(plan, &refused, poses, /*placed=*/false).reason == PairExchangeReason::kRobotNotPlaced);
  // A restart voids what was known: registered whatever the placement says.
  CHECK(Decide(plan, nullptr, poses, /*placed=*/true, /*restarted=*/true).reason == PairExchangeReason::kRobotRestarted);
  // Both placed through other pairs, never tried: once.
  d = Decide(plan, nullptr, poses);
  CHECK(d.reason == PairExchangeReason::kFirstAttempt);
  CHECK(RegistersPair(d.reason));
  // The rule off: every pair every round.
  PairExchangeParams off;
  off.enabled = false;
  const PairHistory verified = History(poses, 10, 12, true);
  CHECK(Decide(plan, &verified, poses, true, false, off).reason == PairExchangeReason::kEveryRound);
  // Nothing selected and no verified registration, both placed: nothing to do.
  PairSelection empty;
  empty.alpha = 0;
  empty.beta = 1;
  empty.no_selection_reason = "stage A: no cluster";
  d = Decide(empty, nullptr, poses);
  CHECK(d.reason == PairExchangeReason::kNothingNew);
  CHECK_FALSE(RegistersPair(d.reason));
  CHECK(d.why.find("stage A: no cluster") != std::string::npos);
}

TEST_CASE("Pair exchange: a verified pair keeps its result until its overlap's poses move beyond the bound") {
  Poses poses(400);
  const PairHistory h = History(poses, 10, 12, true);
  const PairSelection plan = Selection(200, 15);  // the cascade now selects elsewhere: a strong pair ignores it
  PairExchangeDecision d = Decide(plan, &h, poses, /*placed=*/false);  // placement does not matter once verified
  CHECK(d.reason == PairExchangeReason::kUnchanged);
  CHECK_FALSE(RegistersPair(d.reason));
  CHECK(d.motion.max_translation_m == 0.0);
  CHECK(d.motion.keyframes == 24);

  // Beta's keyframe 15 (in the overlap) moves 0.4 m, then 0.6 m; a keyframe outside the overlap moves 30 m.
  poses.beta[300].translation().x() += 30.0;
  poses.beta[15].translation().y() += 0.4;
  d = Decide(plan, &h, poses);
  CHECK(d.reason == PairExchangeReason::kUnchanged);
  CHECK(d.motion.max_translation_m == doctest::Approx(0.4));
  poses.beta[15].translation().y() += 0.2;
  d = Decide(plan, &h, poses);
  CHECK(d.reason == PairExchangeReason::kPosesMoved);
  CHECK(RegistersPair(d.reason));
  CHECK(d.region == 0);
  CHECK(d.motion.max_translation_m == doctest::Approx(0.6));
  CHECK(d.selection.alpha_keyframes == Range(10, 12));  // the verified overlap, not the cascade's new place
  CHECK(d.selection.beta_keyframes == Range(10, 12));
  CHECK(d.why.find("0.60 m") != std::string::npos);

  // A turn of 1.5 deg of one alpha keyframe, without translation.
  Poses turned(400);
  turned.alpha[12].linear() = Eigen::AngleAxisd(1.5 * kDegToRad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  d = Decide(plan, &h, turned);
  CHECK(d.reason == PairExchangeReason::kPosesMoved);
  CHECK(d.motion.max_rotation_deg == doctest::Approx(1.5).epsilon(1e-6));
  PairExchangeParams loose;
  loose.moved_deg = 2.0;
  CHECK(Decide(plan, &h, turned, true, false, loose).reason == PairExchangeReason::kUnchanged);
}

TEST_CASE("Pair exchange: a new overlap far from the verified one is registered only for a bridge") {
  const Poses poses(400);
  const PairSelection far = Selection(200, 15);   // 190 m from keyframes 10..21
  const PairSelection near = Selection(40, 15);   // its median keyframe is 26 m from keyframe 21
  const PairHistory bridge = History(poses, 10, 12, true, MeasurementVerdict::kUnverified);
  PairExchangeDecision d = Decide(far, &bridge, poses);
  CHECK(d.reason == PairExchangeReason::kNewOverlap);
  CHECK(d.region == 1);  // a second region beside the verified one
  CHECK(d.selection.alpha_keyframes == far.alpha_keyframes);
  CHECK(d.overlap_distance_m == doctest::Approx(200.0 + 7.0 - 21.0));
  CHECK(Decide(near, &bridge, poses).reason == PairExchangeReason::kUnchanged);
  // A selection over both places: only its part away from the verified overlap is the second region.
  PairSelection both = Selection(15, 2);
  both.alpha_keyframes.insert(both.alpha_keyframes.end(), far.alpha_keyframes.begin(), far.alpha_keyframes.end());
  both.beta_keyframes = both.alpha_keyframes;
  d = Decide(both, &bridge, poses);
  CHECK(d.reason == PairExchangeReason::kNewOverlap);
  CHECK(d.selection.alpha_keyframes == far.alpha_keyframes);
  CHECK(d.selection.beta_keyframes == far.beta_keyframes);
  // A pair the frame solver checked (accepted on a cycle) needs no second region.
  const PairHistory strong = History(poses, 10, 12, true, MeasurementVerdict::kAccepted);
  CHECK(Decide(far, &strong, poses).reason == PairExchangeReason::kUnchanged);
  // A bridge with two regions already.
  PairHistory two = bridge;
  two.verified.push_back(two.verified[0]);
  CHECK(Decide(far, &two, poses).reason == PairExchangeReason::kUnchanged);
}

TEST_CASE("Pair exchange: a refused or rejected pair between placed robots is tried again only at a new place") {
  const Poses poses(400);
  const PairSelection same = Selection(12, 12), far = Selection(200, 15);
  PairHistory refused = History(poses, 10, 12, /*verified=*/false);
  PairExchangeDecision d = Decide(same, &refused, poses);
  CHECK(d.reason == PairExchangeReason::kNothingNew);
  CHECK(d.why.find("refused in round 1 (too_few_points)") != std::string::npos);
  d = Decide(far, &refused, poses);
  CHECK(d.reason == PairExchangeReason::kNewOverlap);
  CHECK(d.region == 0);
  // The frame solver rejected its verified transform (the round drops it; where it was stays tried).
  PairHistory rejected = refused;
  rejected.rejected_round = 3;
  d = Decide(far, &rejected, poses);
  CHECK(d.reason == PairExchangeReason::kVerificationFailed);
  CHECK(d.why.find("rejected its transform in round 3") != std::string::npos);
  CHECK(Decide(same, &rejected, poses).reason == PairExchangeReason::kNothingNew);
  // At most max_tried_regions places.
  PairExchangeParams two;
  two.max_tried_regions = 2;
  PairHistory twice = refused;
  twice.tried.push_back(MakePairRegion(Selection(100, 5), poses.A(), poses.B(), 2));
  CHECK(Decide(far, &twice, poses, true, false, two).reason == PairExchangeReason::kNothingNew);
  CHECK(Decide(far, &twice, poses).reason == PairExchangeReason::kNewOverlap);
}

TEST_CASE("Pair exchange: region motion and overlap distance match their definitions on random poses") {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-50.0, 50.0), angle(-0.3, 0.3);
  const auto random_pose = [&] {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = (Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    T.translation() = Eigen::Vector3d(u(rng), u(rng), u(rng) * 0.1);
    return T;
  };
  for (int trial = 0; trial < 20; ++trial) {
    Poses then(60), now(60);
    for (int k = 0; k < 60; ++k) {
      then.alpha[static_cast<std::size_t>(k)] = random_pose();
      then.beta[static_cast<std::size_t>(k)] = random_pose();
      now.alpha[static_cast<std::size_t>(k)] = trial % 2 ? random_pose() : then.alpha[static_cast<std::size_t>(k)];
      now.beta[static_cast<std::size_t>(k)] = random_pose();
    }
    now.known_beta[7] = 0;   // not known now: not compared
    then.known_beta[3] = 0;  // not known when registered: not compared either
    PairSelection sel;
    sel.alpha_keyframes = std::vector<std::uint32_t>({1, 5, 9, 20});
    sel.beta_keyframes = std::vector<std::uint32_t>({3, 7, 30});
    const PairRegion region = MakePairRegion(sel, then.A(), then.B(), 1);
    const RegionMotion m = MeasureRegionMotion(region, now.A(), now.B());
    double max_t = 0.0, max_r = 0.0;
    std::size_t compared = 0;
    const auto add = [&](const Eigen::Isometry3d& a, const Eigen::Isometry3d& b) {
      max_t = std::max(max_t, (a.translation() - b.translation()).norm());
      max_r = std::max(max_r, Eigen::AngleAxisd(a.linear().transpose() * b.linear()).angle() * kRadToDeg);
      ++compared;
    };
    for (std::uint32_t k : sel.alpha_keyframes) add(then.alpha[k], now.alpha[k]);
    for (std::uint32_t k : sel.beta_keyframes) {
      if (k != 7 && k != 3) add(then.beta[k], now.beta[k]);
    }
    CHECK(m.keyframes == compared);
    CHECK(m.max_translation_m == doctest::Approx(max_t).epsilon(1e-9));
    CHECK(m.max_rotation_deg == doctest::Approx(max_r).epsilon(1e-6));

    // Overlap distance: per side the median (upper median) nearest distance to the regions' keyframes.
    PairSelection next;
    next.alpha_keyframes = Range(40, 5);
    next.beta_keyframes = std::vector<std::uint32_t>({50, 51, 52, 7});  // 7 is not known now: left out
    const auto side = [](const std::vector<std::uint32_t>& ks, const std::vector<std::uint32_t>& others,
                         const std::vector<Eigen::Isometry3d>& poses, const std::vector<std::uint8_t>& known) {
      std::vector<double> d;
      for (std::uint32_t k : ks) {
        if (!known[k]) continue;
        double best = std::numeric_limits<double>::infinity();
        for (std::uint32_t o : others) {
          if (known[o]) best = std::min(best, (poses[k].translation() - poses[o].translation()).norm());
        }
        d.push_back(best);
      }
      std::sort(d.begin(), d.end());
      return d[d.size() / 2];
    };
    const double expected = std::min(side(next.alpha_keyframes, sel.alpha_keyframes, now.alpha, now.known_alpha),
                                     side(next.beta_keyframes, sel.beta_keyframes, now.beta, now.known_beta));
    CHECK(OverlapDistanceM(next, Span<const PairRegion>(&region, 1), now.A(), now.B()) ==
          doctest::Approx(expected).epsilon(1e-12));
  }
  // Nothing to compare with: infinitely far.
  const Poses poses(10);
  CHECK(std::isinf(OverlapDistanceM(Selection(0, 3), Span<const PairRegion>(), poses.A(), poses.B())));
}

TEST_CASE("Pair exchange: parameters outside their ranges are named") {
  CHECK(ValidatePairExchangeParams(PairExchangeParams{}).ok());
  PairExchangeParams p;
  p.moved_m = -1.0;
  CHECK(ValidatePairExchangeParams(p).message().find("moved_m") != std::string::npos);
  p = PairExchangeParams{};
  p.new_overlap_m = std::numeric_limits<double>::quiet_NaN();
  CHECK(ValidatePairExchangeParams(p).message().find("new_overlap_m") != std::string::npos);
  p = PairExchangeParams{};
  p.max_tried_regions = 0;
  CHECK(ValidatePairExchangeParams(p).message().find("max_tried_regions = 0") != std::string::npos);
  for (PairExchangeReason r : {PairExchangeReason::kEveryRound, PairExchangeReason::kRobotNotPlaced,
                               PairExchangeReason::kRobotRestarted, PairExchangeReason::kFirstAttempt,
                               PairExchangeReason::kPosesMoved, PairExchangeReason::kNewOverlap,
                               PairExchangeReason::kVerificationFailed, PairExchangeReason::kUnchanged,
                               PairExchangeReason::kNothingNew}) {
    CHECK(std::string(PairExchangeReasonName(r)) != "?");
  }
}

TEST_CASE("Pair exchange: second regions of bridges wait while a pair that may close a cycle is registered") {
  const auto decision = [](int alpha, int beta, PairExchangeReason reason, std::size_t region) {
    PairExchangeDecision d;
    d.alpha = alpha;
    d.beta = beta;
    d.reason = reason;
    d.region = region;
    d.selection = Selection(50, 4);
    return d;
  };
  // Robots 0, 1, 2: 0-2 and 1-2 verified bridges with a new overlap each, 0-1 tried for the first time.
  std::vector<PairExchangeDecision> round = {decision(0, 1, PairExchangeReason::kFirstAttempt, 0),
                                             decision(0, 2, PairExchangeReason::kNewOverlap, 1),
                                             decision(1, 2, PairExchangeReason::kNewOverlap, 1)};
  HoldSecondRegions(&round);
  CHECK(round[0].reason == PairExchangeReason::kFirstAttempt);
  for (std::size_t i : {1u, 2u}) {
    CHECK(round[i].reason == PairExchangeReason::kUnchanged);
    CHECK_FALSE(RegistersPair(round[i].reason));
    CHECK(round[i].selection.alpha_keyframes.empty());
    CHECK(round[i].why.find("waits") != std::string::npos);
  }
  // Without such a pair (0-1 nothing new) the second regions go; an unverified pair's new overlap (region 0) is
  // one that may close the cycle.
  for (PairExchangeReason other : {PairExchangeReason::kNothingNew, PairExchangeReason::kNewOverlap}) {
    std::vector<PairExchangeDecision> next = {decision(0, 1, other, 0), decision(0, 2, PairExchangeReason::kNewOverlap, 1)};
    HoldSecondRegions(&next);
    CHECK((next[1].reason == PairExchangeReason::kNewOverlap) == (other == PairExchangeReason::kNothingNew));
  }
  round[0].scans_requested = 12;
  round[0].scans_widened = 6;
  CHECK(ExchangeDecisionsText(Span<const PairExchangeDecision>(round)) ==
        "0-1 first_attempt 12+6; 0-2 unchanged 0; 1-2 unchanged 0");
}
