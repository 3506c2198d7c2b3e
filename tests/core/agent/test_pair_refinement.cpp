// SPDX-License-Identifier: BSD-3-Clause
// The final refinement's choice of scans (core/agent/pair_refinement.hpp) against a brute force written from its
// contract: beta's keyframes whose placed position lies within shared_path_m of one of alpha's are on the shared path;
// the anchor is the held one nearest the held keyframes' centroid; each further pick is the candidate farthest from
// every pick (ties to the lower keyframe), while that distance is at least min_spacing_m; with each pick alpha's
// nearest keyframe (ties to the lower).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "core/agent/pair_refinement.hpp"
#include "core/geometry/angles.hpp"

using namespace commerge;

namespace {

struct Robot {
  std::vector<Eigen::Isometry3d> T_map_sensor;
  std::vector<std::uint8_t> known;
  RobotPoses poses() const {
    return RobotPoses{Span<const Eigen::Isometry3d>(T_map_sensor), Span<const std::uint8_t>(known)};
  }
};

// A random walk of `n` keyframes about 1 m apart, turning slowly, in the plane at height 0.
Robot Walk(std::mt19937* rng, int n, const Eigen::Vector3d& start, double heading_rad) {
  std::normal_distribution<double> turn(0.0, 0.08), step(1.0, 0.05);
  Robot r;
  Eigen::Vector3d p = start;
  for (int k = 0; k < n; ++k) {
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.translation() = p;
    T.linear() = Eigen::AngleAxisd(heading_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    r.T_map_sensor.push_back(T);
    r.known.push_back(1);
    heading_rad += turn(*rng);
    p += step(*rng) * Eigen::Vector3d(std::cos(heading_rad), std::sin(heading_rad), 0.0);
  }
  return r;
}

// The contract above, by exhaustive search.
SpreadKeyframes BruteForce(const Robot& alpha, const Robot& beta, const Eigen::Isometry3d& T_alpha_beta,
                           const std::vector<std::uint32_t>& held_beta, const RefinementParams& params) {
  struct C {
    std::uint32_t beta, alpha;
    Eigen::Vector3d q;
    bool held;
  };
  std::vector<C> cs;
  for (std::uint32_t j = 0; j < beta.T_map_sensor.size(); ++j) {
    if (!beta.known[j]) continue;
    const Eigen::Vector3d q = T_alpha_beta * beta.T_map_sensor[j].translation();
    double best = std::numeric_limits<double>::infinity();
    std::uint32_t partner = 0;
    for (std::uint32_t i = 0; i < alpha.T_map_sensor.size(); ++i) {
      if (!alpha.known[i]) continue;
      const double d = (alpha.T_map_sensor[i].translation() - q).norm();
      if (d < best) {
        best = d;
        partner = i;
      }
    }
    if (best > params.shared_path_m) continue;
    cs.push_back({j, partner, q, std::find(held_beta.begin(), held_beta.end(), j) != held_beta.end()});
  }
  SpreadKeyframes out;
  if (cs.empty() || params.scans_per_robot == 0) return out;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  int n = 0;
  for (std::uint32_t j : held_beta) {
    if (j < beta.known.size() && beta.known[j]) {
      centre += T_alpha_beta * beta.T_map_sensor[j].translation();
      ++n;
    }
  }
  centre = n > 0 ? Eigen::Vector3d(centre / n) : cs.front().q;
  std::size_t anchor = 0;
  for (std::size_t c = 1; c < cs.size(); ++c) {
    const C& a = cs[c];
    const C& b = cs[anchor];
    if ((a.held && !b.held) || (a.held == b.held && (a.q - centre).squaredNorm() < (b.q - centre).squaredNorm())) {
      anchor = c;
    }
  }
  std::vector<std::size_t> picks = {anchor};
  for (std::size_t round = 0; round < params.scans_per_robot; ++round) {
    double best = -1.0;
    std::size_t far = 0;
    for (std::size_t c = 0; c < cs.size(); ++c) {
      double d = std::numeric_limits<double>::infinity();
      for (std::size_t p : picks) d = std::min(d, (cs[c].q - cs[p].q).norm());
      if (d > best) {
        best = d;
        far = c;
      }
    }
    if (best < params.min_spacing_m) break;
    picks.push_back(far);
  }
  for (std::size_t p : picks) {
    out.beta_keyframes.push_back(cs[p].beta);
    out.alpha_keyframes.push_back(cs[p].alpha);
    out.places.emplace_back(cs[p].alpha, cs[p].beta);
  }
  for (auto* v : {&out.alpha_keyframes, &out.beta_keyframes}) {
    std::sort(v->begin(), v->end());
    v->erase(std::unique(v->begin(), v->end()), v->end());
  }
  return out;
}

}  // namespace

TEST_CASE("Pair refinement: the spread scans are the brute force's on random walks that share part of a path") {
  for (std::uint32_t seed = 1; seed <= 12; ++seed) {
    CAPTURE(seed);
    std::mt19937 rng(seed);
    const Robot alpha = Walk(&rng, 300, Eigen::Vector3d::Zero(), 0.0);
    // Beta walks alpha's keyframes 80..229 again, 0.3 m aside, then goes its own way; its map frame is turned and
    // shifted against alpha's.
    Eigen::Isometry3d T_alpha_beta = Eigen::Isometry3d::Identity();
    T_alpha_beta.linear() = Eigen::AngleAxisd(0.7 * seed, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    T_alpha_beta.translation() = Eigen::Vector3d(40.0, -25.0, 1.0);
    Robot beta;
    for (int k = 80; k < 230; ++k) {
      Eigen::Isometry3d T = alpha.T_map_sensor[static_cast<std::size_t>(k)];
      T.translation() += Eigen::Vector3d(0.0, 0.3, 0.0);
      beta.T_map_sensor.push_back(T_alpha_beta.inverse() * T);
      beta.known.push_back(1);
    }
    const Robot away = Walk(&rng, 100, Eigen::Vector3d(500.0, 500.0, 0.0), 1.0);
    for (const Eigen::Isometry3d& T : away.T_map_sensor) {
      beta.T_map_sensor.push_back(T_alpha_beta.inverse() * T);
      beta.known.push_back(1);
    }
    beta.known[20] = 0;  // a keyframe whose pose has not arrived is never picked
    std::vector<std::uint32_t> held = {60, 61, 62, 63, 64};
    RefinementParams params;
    params.scans_per_robot = 1 + seed % 5;
    auto got = SpreadAlongSharedPath(alpha.poses(), beta.poses(), T_alpha_beta, Span<const std::uint32_t>(held), params);
    REQUIRE(got.ok());
    const SpreadKeyframes want = BruteForce(alpha, beta, T_alpha_beta, held, params);
    CHECK(got->beta_keyframes == want.beta_keyframes);
    CHECK(got->alpha_keyframes == want.alpha_keyframes);
    CHECK(got->places == want.places);  // pick order, the anchor first, each with alpha's nearest keyframe
    CHECK(got->beta_keyframes.size() == params.scans_per_robot + 1);
    CHECK(std::find(got->beta_keyframes.begin(), got->beta_keyframes.end(), 20u) == got->beta_keyframes.end());
    for (std::uint32_t j : got->beta_keyframes) {
      CHECK(j < 150);  // on the shared path, never the walk far away
    }
    // The picks are spread: at least min_spacing_m apart.
    for (std::size_t a = 0; a < got->beta_keyframes.size(); ++a) {
      for (std::size_t b = a + 1; b < got->beta_keyframes.size(); ++b) {
        const double d = (beta.T_map_sensor[got->beta_keyframes[a]].translation() -
                          beta.T_map_sensor[got->beta_keyframes[b]].translation()).norm();
        CHECK(d >= params.min_spacing_m);
      }
    }
  }
}

TEST_CASE("Pair refinement: a short shared path yields fewer picks, none without one, and off yields nothing") {
  std::mt19937 rng(5);
  const Robot alpha = Walk(&rng, 100, Eigen::Vector3d::Zero(), 0.0);
  Robot beta;
  for (int k = 40; k < 55; ++k) {  // 15 keyframes, about 14 m of shared path
    beta.T_map_sensor.push_back(alpha.T_map_sensor[static_cast<std::size_t>(k)]);
    beta.known.push_back(1);
  }
  const std::vector<std::uint32_t> held = {0, 1};
  RefinementParams params;
  params.scans_per_robot = 4;
  auto got = SpreadAlongSharedPath(alpha.poses(), beta.poses(), Eigen::Isometry3d::Identity(),
                                   Span<const std::uint32_t>(held), params);
  REQUIRE(got.ok());
  // The anchor (a held keyframe) and the far end of the 14 m: the next would be nearer than 10 m to one of them.
  CHECK(got->beta_keyframes == BruteForce(alpha, beta, Eigen::Isometry3d::Identity(), held, params).beta_keyframes);
  CHECK(got->beta_keyframes.size() == 2);
  CHECK(got->beta_keyframes.front() <= 1);

  Eigen::Isometry3d apart = Eigen::Isometry3d::Identity();
  apart.translation() = Eigen::Vector3d(0.0, 0.0, 50.0);
  auto none = SpreadAlongSharedPath(alpha.poses(), beta.poses(), apart, Span<const std::uint32_t>(held), params);
  REQUIRE(none.ok());
  CHECK(none->beta_keyframes.empty());
  CHECK(none->alpha_keyframes.empty());

  params.scans_per_robot = 0;
  auto off = SpreadAlongSharedPath(alpha.poses(), beta.poses(), Eigen::Isometry3d::Identity(),
                                   Span<const std::uint32_t>(held), params);
  REQUIRE(off.ok());
  CHECK(off->beta_keyframes.empty());
}

TEST_CASE("Pair refinement: bad parameters and a non-finite transform are errors naming the field") {
  std::mt19937 rng(2);
  const Robot r = Walk(&rng, 10, Eigen::Vector3d::Zero(), 0.0);
  const std::vector<std::uint32_t> held;
  RefinementParams params;
  params.scans_per_robot = 2;
  Eigen::Isometry3d bad = Eigen::Isometry3d::Identity();
  bad.translation().x() = std::numeric_limits<double>::quiet_NaN();
  auto nan = SpreadAlongSharedPath(r.poses(), r.poses(), bad, Span<const std::uint32_t>(held), params);
  CHECK_FALSE(nan.ok());
  struct Case {
    RefinementParams params;
    const char* field;
  };
  std::vector<Case> cases;
  for (int i = 0; i < 5; ++i) cases.push_back({params, ""});
  cases[0].params.scans_per_robot = 65;
  cases[0].field = "scans_per_robot";
  cases[1].params.shared_path_m = 0.0;
  cases[1].field = "shared_path_m";
  cases[2].params.min_spacing_m = std::numeric_limits<double>::infinity();
  cases[2].field = "min_spacing_m";
  cases[3].params.max_correction_m = -1.0;
  cases[3].field = "max_correction_m";
  cases[4].params.max_correction_deg = std::numeric_limits<double>::quiet_NaN();
  cases[4].field = "max_correction_deg";
  for (const Case& c : cases) {
    CAPTURE(c.field);
    const Status s = ValidateRefinementParams(c.params);
    CHECK_FALSE(s.ok());
    CHECK(s.message().find(c.field) != std::string::npos);
    CHECK_FALSE(SpreadAlongSharedPath(r.poses(), r.poses(), Eigen::Isometry3d::Identity(),
                                      Span<const std::uint32_t>(held), c.params).ok());
  }
  CHECK(ValidateRefinementParams(params).ok());
}
