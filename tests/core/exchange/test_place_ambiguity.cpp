// SPDX-License-Identifier: BSD-3-Clause
// Place ambiguity of a stage A cluster (core/exchange/place_ambiguity.hpp) on descriptors built so that the answer
// is known: orthonormal basis vectors are distinct places, an exact copy 30 m further along a robot's path is the
// same-looking place seen twice, and the other robot's view of a place is that basis vector tilted by 0.14 (its
// cross distance), so the copy (distance 0) is closer than the other robot.
#include <doctest/doctest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/descriptor/solid.hpp"
#include "core/exchange/exchange_cascade.hpp"
#include "core/exchange/place_ambiguity.hpp"

namespace commerge {
namespace {

constexpr std::size_t kPlaceDim = 120;

// Alpha: 60 keyframes 1 m apart along x; keyframe i looks like place i, except keyframes 40..49, which look like
// places 10..19 again (30 m further on). Beta: 20 keyframes 1 m apart; keyframe j sees alpha's place 10 + j
// (j < 10) or 20 + j (j >= 10), tilted towards a basis vector of its own.
struct TwoRobots {
  std::vector<float> da, db;
  std::vector<Eigen::Vector3d> pa, pb;
  TwoRobots() : da(60 * kPlaceDim, 0.0f), db(20 * kPlaceDim, 0.0f) {
    for (std::size_t i = 0; i < 60; ++i) {
      da[i * kPlaceDim + (i >= 40 && i < 50 ? i - 30 : i)] = 1.0f;
      pa.emplace_back(static_cast<double>(i), 0.0, 0.0);
    }
    const double norm = std::sqrt(0.99 * 0.99 + 0.14 * 0.14);
    for (std::size_t j = 0; j < 20; ++j) {
      const std::size_t place = j < 10 ? 10 + j : 20 + j;
      db[j * kPlaceDim + place] = static_cast<float>(0.99 / norm);
      db[j * kPlaceDim + 60 + j] = static_cast<float>(0.14 / norm);
      pb.emplace_back(static_cast<double>(j), 0.0, 0.0);
    }
  }
  DescriptorSetView A() const { return {Span<const float>(da), kPlaceDim, {}}; }
  DescriptorSetView B() const { return {Span<const float>(db), kPlaceDim, {}}; }
};

// TwoRobots where only the repeated place is shared: beta's keyframes 10..19 get basis vectors of their own, so
// beta's 0..9 match alpha's 10..19 and, as closely, the look-alike 40..49.
struct RepeatedPlaceOnly : TwoRobots {
  RepeatedPlaceOnly() {
    for (std::size_t j = 10; j < 20; ++j) {
      for (std::size_t k = 0; k < kPlaceDim; ++k) db[j * kPlaceDim + k] = 0.0f;
      db[j * kPlaceDim + 80 + j] = 1.0f;
    }
  }
  CascadeRobotInput Alpha() const { return {A(), Span<const Eigen::Vector3d>(pa), {}}; }
  CascadeRobotInput Beta() const { return {B(), Span<const Eigen::Vector3d>(pb), {}}; }
};

// The paper's stage A on a small cluster (10 x 10 cells), no padding of the policy.
ExchangeCascadeParams SmallClusterParams() {
  ExchangeCascadeParams params;
  params.stage_a.tau_inter = 0.2;
  params.stage_a.tau_area = 100;
  params.policy.min_scans_per_robot = 0;
  params.policy.min_points_per_robot = 0;
  return params;
}

std::vector<SequentialLoopCell> TenLoops(std::size_t alpha_first, std::size_t beta_first) {
  std::vector<SequentialLoopCell> out;
  for (std::size_t k = 0; k < 10; ++k) out.push_back({alpha_first + k, beta_first + k, 0.1f});
  return out;
}

TEST_CASE("Place ambiguity: a place its robot saw twice, far apart, is ambiguous, a distinct one is not") {
  const TwoRobots r;
  const Span<const Eigen::Vector3d> pa(r.pa), pb(r.pb);
  // Alpha's places 10..19 repeat at 40..49, 30 m away: every one of the cluster's alpha keyframes is ambiguous.
  // Beta's own map spans 19 m, so nothing of it is "far".
  const std::vector<SequentialLoopCell> repeated = TenLoops(10, 0);
  auto amb = MeasurePlaceAmbiguity(r.A(), pa, r.B(), pb, Span<const SequentialLoopCell>(repeated), 20.0);
  REQUIRE(amb.ok());
  CHECK(amb->alpha_keyframes == 10);
  CHECK(amb->alpha_ambiguous == 10);
  CHECK(amb->beta_keyframes == 10);
  CHECK(amb->beta_ambiguous == 0);
  CHECK(amb->max_fraction() == 1.0);
  // The copies are 30 m away: with "far" beyond 35 m they are the same neighbourhood, nothing is ambiguous.
  amb = MeasurePlaceAmbiguity(r.A(), pa, r.B(), pb, Span<const SequentialLoopCell>(repeated), 35.0);
  REQUIRE(amb.ok());
  CHECK(amb->alpha_ambiguous == 0);
  CHECK(amb->max_fraction() == 0.0);
  // Places 30..39 occur once in alpha's map: not ambiguous.
  const std::vector<SequentialLoopCell> distinct = TenLoops(30, 10);
  amb = MeasurePlaceAmbiguity(r.A(), pa, r.B(), pb, Span<const SequentialLoopCell>(distinct), 20.0);
  REQUIRE(amb.ok());
  CHECK(amb->alpha_keyframes == 10);
  CHECK(amb->alpha_ambiguous == 0);
  CHECK(amb->beta_ambiguous == 0);
  // Half of each: 5 of 10 alpha keyframes ambiguous.
  std::vector<SequentialLoopCell> half = TenLoops(15, 5);
  half.resize(5);
  for (const SequentialLoopCell& c : TenLoops(30, 10)) {
    if (half.size() < 10) half.push_back(c);
  }
  amb = MeasurePlaceAmbiguity(r.A(), pa, r.B(), pb, Span<const SequentialLoopCell>(half), 20.0);
  REQUIRE(amb.ok());
  CHECK(amb->alpha_fraction() == doctest::Approx(0.5));
  // An invalid keyframe is neither counted nor a neighbour.
  std::vector<std::uint8_t> valid_a(60, 1);
  for (std::size_t i = 40; i < 50; ++i) valid_a[i] = 0;  // the copies
  const DescriptorSetView a_without_copies{Span<const float>(r.da), kPlaceDim, Span<const std::uint8_t>(valid_a)};
  amb = MeasurePlaceAmbiguity(a_without_copies, pa, r.B(), pb, Span<const SequentialLoopCell>(repeated), 20.0);
  REQUIRE(amb.ok());
  CHECK(amb->alpha_ambiguous == 0);
}

TEST_CASE("Place ambiguity: wrong sizes, a bad distance and a loop outside the sets are errors naming them") {
  const TwoRobots r;
  const Span<const Eigen::Vector3d> pa(r.pa), pb(r.pb);
  const std::vector<SequentialLoopCell> loops = TenLoops(10, 0);
  const Span<const SequentialLoopCell> l(loops);
  auto bad = MeasurePlaceAmbiguity(r.A(), pb, r.B(), pb, l, 20.0);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("positions") != std::string::npos);
  bad = MeasurePlaceAmbiguity(r.A(), pa, r.B(), pb, l, std::numeric_limits<double>::quiet_NaN());
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("far_m") != std::string::npos);
  const std::vector<SequentialLoopCell> outside = {{5, 20, 0.1f}};
  bad = MeasurePlaceAmbiguity(r.A(), pa, r.B(), pb, Span<const SequentialLoopCell>(outside), 20.0);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("outside") != std::string::npos);
}

TEST_CASE("Cascade: a cluster whose place repeats in a robot's own map is flagged ambiguous above the fraction") {
  const RepeatedPlaceOnly r;
  const CascadeRobotInput a = r.Alpha(), b = r.Beta();
  ExchangeCascadeParams params = SmallClusterParams();  // cells at 0.14 <= tau_inter

  auto res = RunExchangeCascade(a, b, params);  // off (the paper): not measured
  REQUIRE(res.ok());
  CHECK(res->outcome == CascadeOutcome::kPolicy);
  CHECK_FALSE(res->ambiguity_measured);
  CHECK_FALSE(res->ambiguous);

  params.max_ambiguous_fraction = 0.75;  // every alpha keyframe of the cluster is ambiguous: flagged, still a policy
  res = RunExchangeCascade(a, b, params);
  REQUIRE(res.ok());
  CHECK(res->outcome == CascadeOutcome::kPolicy);
  REQUIRE(res->ambiguity_measured);
  CHECK(res->ambiguity.alpha_fraction() == 1.0);
  CHECK(res->ambiguous);
  CHECK(res->ambiguity_reason.find("10 of 10 of robot alpha's keyframes") != std::string::npos);

  params.ambiguity_far_m = 35.0;  // the copies are 30 m away: the same neighbourhood, not ambiguous
  res = RunExchangeCascade(a, b, params);
  REQUIRE(res.ok());
  CHECK(res->ambiguity.max_fraction() == 0.0);
  CHECK_FALSE(res->ambiguous);

  params.ambiguity_far_m = 20.0;
  params.max_ambiguous_fraction = 1.0 - 1e-9;  // measured; a fraction of 1 is above it
  res = RunExchangeCascade(a, b, params);
  REQUIRE(res.ok());
  CHECK(res->ambiguous);

  params.max_ambiguous_fraction = 1.5;
  auto bad = RunExchangeCascade(a, b, params);
  REQUIRE_FALSE(bad.ok());
  CHECK(bad.status().message().find("max_ambiguous_fraction") != std::string::npos);
}

TEST_CASE("Cascade: the support of an ambiguous cluster that no other cluster confirms is its own weight") {
  // Two 10 x 10 clusters that place beta 30 m apart: neither confirms the other, so each has the support of its
  // own weight, min(10 rows, 10 columns) = 10 keyframes. The cascade measures and flags; whether such a pair is
  // requested is the server's decision (core/agent/pair_decision.hpp, tests/core/agent/test_pair_decision.cpp).
  const RepeatedPlaceOnly r;
  const CascadeRobotInput a = r.Alpha(), b = r.Beta();
  ExchangeCascadeParams params = SmallClusterParams();
  params.max_ambiguous_fraction = 0.75;
  params.consensus_max_cells = 1000;
  auto res = RunExchangeCascade(a, b, params);
  REQUIRE(res.ok());
  REQUIRE(res->consensus_measured);
  CHECK(res->consensus_support_chosen == 10.0);
  CHECK(res->ambiguous);
  CHECK(res->ambiguity_reason.find("10 of 10 of robot alpha's keyframes") != std::string::npos);
  CHECK(res->outcome == CascadeOutcome::kPolicy);

  params.max_ambiguous_fraction = 1.0;  // not measured, so not ambiguous
  res = RunExchangeCascade(a, b, params);
  REQUIRE(res.ok());
  CHECK_FALSE(res->ambiguous);
  CHECK(res->outcome == CascadeOutcome::kPolicy);

  params.max_ambiguous_fraction = 0.75;
  params.consensus_max_cells = 0;  // no consensus, no support measured
  res = RunExchangeCascade(a, b, params);
  REQUIRE(res.ok());
  CHECK(res->ambiguous);
  CHECK_FALSE(res->consensus_measured);
  CHECK(res->outcome == CascadeOutcome::kPolicy);
}

}  // namespace
}  // namespace commerge

namespace commerge {
namespace {

// The definition, keyframe by keyframe with SolidDistance (MeasurePlaceAmbiguity computes the unit-L2 distances
// from cached squared norms and must give the same counts).
PlaceAmbiguity NaiveAmbiguity(const DescriptorSetView& a, const std::vector<Eigen::Vector3d>& pa,
                              const DescriptorSetView& b, const std::vector<Eigen::Vector3d>& pb,
                              const std::vector<SequentialLoopCell>& l_seq, double far_m) {
  const auto row = [](const DescriptorSetView& s, std::size_t k) { return s.values.subspan(k * s.dim, s.dim); };
  const auto valid = [](const DescriptorSetView& s, std::size_t k) { return s.valid.empty() || s.valid[k] != 0; };
  PlaceAmbiguity out;
  for (const bool alpha_side : {true, false}) {
    const DescriptorSetView& own = alpha_side ? a : b;
    const std::vector<Eigen::Vector3d>& pos = alpha_side ? pa : pb;
    std::vector<double> cross(own.count(), std::numeric_limits<double>::infinity());
    std::vector<bool> seen(own.count(), false);
    for (const SequentialLoopCell& c : l_seq) {
      if (!valid(a, c.alpha_index) || !valid(b, c.beta_index)) continue;
      const std::size_t k = alpha_side ? c.alpha_index : c.beta_index;
      seen[k] = true;
      cross[k] = std::min(cross[k], SolidDistance(row(a, c.alpha_index), row(b, c.beta_index)));
    }
    for (std::size_t k = 0; k < own.count(); ++k) {
      if (!seen[k]) continue;
      bool ambiguous = false;
      for (std::size_t o = 0; o < own.count() && !ambiguous; ++o) {
        if (!valid(own, o) || (pos[o] - pos[k]).squaredNorm() <= far_m * far_m) continue;
        ambiguous = SolidDistance(row(own, k), row(own, o)) <= cross[k];
      }
      (alpha_side ? out.alpha_keyframes : out.beta_keyframes) += 1;
      (alpha_side ? out.alpha_ambiguous : out.beta_ambiguous) += ambiguous ? 1 : 0;
    }
  }
  return out;
}

}  // namespace

TEST_CASE("Place ambiguity equals the definition with SolidDistance on random sets with copies, zero and bad rows") {
  std::mt19937 rng(77);
  std::normal_distribution<float> g(0.0f, 1.0f);
  for (int trial = 0; trial < 20; ++trial) {
    const std::size_t n = 40 + static_cast<std::size_t>(trial), m = 30, dim = 1 + static_cast<std::size_t>(trial) % 12;
    std::vector<float> da(n * dim), db(m * dim);
    for (float& v : da) v = g(rng);
    for (float& v : db) v = g(rng);
    // Copies (self distance equal to a cross distance, or 0), a zero row, a non-finite row, a huge row.
    for (std::size_t i = 0; i < dim; ++i) {
      da[5 * dim + i] = da[25 * dim + i];
      db[3 * dim + i] = da[25 * dim + i];
      da[7 * dim + i] = 0.0f;
      da[9 * dim + i] = 1e30f;
    }
    da[8 * dim] = std::numeric_limits<float>::quiet_NaN();
    std::vector<std::uint8_t> va(n, 1);
    va[11] = 0;
    std::vector<Eigen::Vector3d> pa(n), pb(m);
    for (std::size_t i = 0; i < n; ++i) pa[i] = Eigen::Vector3d(static_cast<double>(i), 0.0, 0.0);
    for (std::size_t j = 0; j < m; ++j) pb[j] = Eigen::Vector3d(static_cast<double>(j), 1.0, 0.0);
    std::vector<SequentialLoopCell> l_seq;
    for (std::size_t q = 0; q < 25; ++q) l_seq.push_back({rng() % n, rng() % m, 0.1f});
    l_seq.push_back({25, 3, 0.0f});
    l_seq.push_back({7, 4, 0.0f});
    l_seq.push_back({8, 5, 0.0f});
    l_seq.push_back({9, 6, 0.0f});
    const DescriptorSetView a{Span<const float>(da), dim, Span<const std::uint8_t>(va)};
    const DescriptorSetView b{Span<const float>(db), dim, {}};
    for (const double far_m : {0.0, 3.0, 12.0}) {
      CAPTURE(trial);
      CAPTURE(far_m);
      const PlaceAmbiguity want = NaiveAmbiguity(a, pa, b, pb, l_seq, far_m);
      auto got = MeasurePlaceAmbiguity(a, Span<const Eigen::Vector3d>(pa), b, Span<const Eigen::Vector3d>(pb),
                                       Span<const SequentialLoopCell>(l_seq), far_m);
      REQUIRE(got.ok());
      CHECK(got->alpha_keyframes == want.alpha_keyframes);
      CHECK(got->alpha_ambiguous == want.alpha_ambiguous);
      CHECK(got->beta_keyframes == want.beta_keyframes);
      CHECK(got->beta_ambiguous == want.beta_ambiguous);
    }
  }
}

}  // namespace commerge
