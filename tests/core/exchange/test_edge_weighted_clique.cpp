// SPDX-License-Identifier: BSD-3-Clause
// Stage C: kappa and xi against the paper's formulas, the compatibility graph against a brute-force pair scan,
// the loop-set options, the max_loops cap, the clique selection against brute force over all loop subsets, and
// outlier loops that are excluded by positional consistency.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Geometry>

#include "core/exchange/edge_weighted_clique.hpp"

namespace commerge {
namespace {

using Positions = std::vector<Eigen::Vector3d>;

Positions RandomPositions(std::mt19937& rng, int n, double extent_m) {
  std::uniform_real_distribution<double> u(-extent_m, extent_m);
  Positions p;
  for (int i = 0; i < n; ++i) p.emplace_back(u(rng), u(rng), 0.1 * u(rng));
  return p;
}

std::vector<SequentialLoopCell> RandomLoops(std::mt19937& rng, int count, int n_alpha, int n_beta) {
  std::uniform_int_distribution<int> ia(0, n_alpha - 1), ib(0, n_beta - 1);
  std::uniform_real_distribution<float> d(0.0f, 0.1f);
  std::vector<SequentialLoopCell> loops;
  for (int k = 0; k < count; ++k) {
    loops.push_back({static_cast<std::size_t>(ia(rng)), static_cast<std::size_t>(ib(rng)), d(rng)});
  }
  std::sort(loops.begin(), loops.end(), [](const SequentialLoopCell& a, const SequentialLoopCell& b) {
    return a.alpha_index != b.alpha_index ? a.alpha_index < b.alpha_index : a.beta_index < b.beta_index;
  });
  loops.erase(std::unique(loops.begin(), loops.end(),
                          [](const SequentialLoopCell& a, const SequentialLoopCell& b) {
                            return a.alpha_index == b.alpha_index && a.beta_index == b.beta_index;
                          }),
              loops.end());
  return loops;
}

// Paper eqs. pos_consist and comp_score, written out independently.
double KappaRef(const Positions& pa, const Positions& pb, const SequentialLoopCell& x, const SequentialLoopCell& y) {
  const Eigen::Vector3d da = pa[x.alpha_index] - pa[y.alpha_index];
  const Eigen::Vector3d db = pb[x.beta_index] - pb[y.beta_index];
  return std::fabs(std::sqrt(da.dot(da)) - std::sqrt(db.dot(db)));
}

TEST_CASE("Stage C: kappa and xi follow the paper and kappa ignores each robot's frame") {
  const Eigen::Vector3d a1(0, 0, 0), a2(3, 4, 0), b1(10, 10, 1), b2(10, 10, 7);
  CHECK(PositionalConsistency(a1, a2, b1, b2) == doctest::Approx(1.0).epsilon(1e-15));  // |5 - 6|
  CHECK(CompatibilityScore(0.05, 2.0, 0.08) == doctest::Approx(std::exp(-0.008)).epsilon(1e-15));
  CHECK(CompatibilityScore(0.0, 100.0, 0.1) == 1.0);

  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    Positions pa = RandomPositions(rng, 2, 50.0), pb = RandomPositions(rng, 2, 50.0);
    const double kappa = PositionalConsistency(pa[0], pa[1], pb[0], pb[1]);
    // Re-express beta's positions in another map frame: kappa must not change.
    const Eigen::Isometry3d T_other_beta =
        Eigen::Translation3d(5.0 * trial, -3.0, 1.0) *
        Eigen::AngleAxisd(0.1 * trial, Eigen::Vector3d(0.3, -0.2, 1.0).normalized());
    const double moved = PositionalConsistency(pa[0], pa[1], T_other_beta * pb[0], T_other_beta * pb[1]);
    CHECK(moved == doctest::Approx(kappa).epsilon(1e-9));
  }
}

TEST_CASE("Stage C: the compatibility graph equals a brute-force scan of all loop pairs") {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 100; ++trial) {
    const Positions pa = RandomPositions(rng, 30, 20.0), pb = RandomPositions(rng, 25, 20.0);
    const auto loops = RandomLoops(rng, 40, 30, 25);
    const double tau = 1.0 + 0.1 * (trial % 60);
    auto g = BuildCompatibilityGraph(loops, pa, pb, tau);
    REQUIRE(g.ok());
    std::size_t edges = 0;
    for (std::size_t x = 0; x < loops.size(); ++x) {
      for (std::size_t y = 0; y < loops.size(); ++y) {
        if (x == y) continue;
        const double kappa = KappaRef(pa, pb, loops[x], loops[y]);
        const bool edge = kappa < tau;
        const int u = static_cast<int>(x), v = static_cast<int>(y);
        REQUIRE(g->HasEdge(u, v) == edge);
        if (edge) {
          const double xi = std::exp(-static_cast<double>(loops[x].distance) * kappa *
                                     static_cast<double>(loops[y].distance));
          CHECK(g->edge_weight(u, v) == doctest::Approx(xi).epsilon(1e-6));  // stored as float
          if (x < y) ++edges;
        } else {
          CHECK(g->edge_weight(u, v) == 0.0);
        }
      }
    }
    CHECK(g->num_edges() == edges);
  }
}

// Brute force of eq. mewc: the maximum of sum xi over all subsets that are cliques of the mask.
double BruteForceStageC(const std::vector<SequentialLoopCell>& loops, const Positions& pa, const Positions& pb,
                        double tau) {
  const std::size_t n = loops.size();
  double best = 0.0;
  for (unsigned mask = 1; mask < (1U << n); ++mask) {
    double sum = 0.0;
    bool clique = true;
    for (std::size_t x = 0; x < n && clique; ++x) {
      if (!(mask >> x & 1U)) continue;
      for (std::size_t y = x + 1; y < n; ++y) {
        if (!(mask >> y & 1U)) continue;
        const double kappa = KappaRef(pa, pb, loops[x], loops[y]);
        if (!(kappa < tau)) {
          clique = false;
          break;
        }
        sum += std::exp(-static_cast<double>(loops[x].distance) * kappa * static_cast<double>(loops[y].distance));
      }
    }
    if (clique) best = std::max(best, sum);
  }
  return best;
}

TEST_CASE("Stage C: the selected loops are the maximum edge-weighted clique of the mask (brute force)") {
  std::mt19937 rng(23);
  int with_pairs = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const Positions pa = RandomPositions(rng, 12, 10.0), pb = RandomPositions(rng, 12, 10.0);
    const auto l_seq = RandomLoops(rng, 1 + trial % 12, 12, 12);
    std::vector<int> all(12);
    for (int i = 0; i < 12; ++i) all[static_cast<std::size_t>(i)] = i;
    StageCParams params;
    params.tau_con_m = 2.0 + 0.05 * (trial % 40);
    auto r = RunStageC(l_seq, all, all, pa, pb, params);
    REQUIRE(r.ok());
    REQUIRE(r->candidate_loops.size() == l_seq.size());
    REQUIRE_FALSE(r->selected_loops.empty());
    CHECK(r->clique.status == CliqueSearchStatus::kOptimal);
    // Independent recomputation of f_K of the selection, and its clique property.
    double f = 0.0;
    for (std::size_t x = 0; x < r->selected_loops.size(); ++x) {
      for (std::size_t y = x + 1; y < r->selected_loops.size(); ++y) {
        const double kappa = KappaRef(pa, pb, r->selected_loops[x], r->selected_loops[y]);
        REQUIRE(kappa < params.tau_con_m);
        f += std::exp(-static_cast<double>(r->selected_loops[x].distance) * kappa *
                      static_cast<double>(r->selected_loops[y].distance));
      }
    }
    const double best = BruteForceStageC(l_seq, pa, pb, params.tau_con_m);
    CHECK(f == doctest::Approx(best).epsilon(1e-5));
    CHECK(r->clique.objective == doctest::Approx(best).epsilon(1e-5));
    if (r->compatible_pairs > 0) ++with_pairs;
    if (r->compatible_pairs == 0) {
      // No compatible pair: the single most similar loop.
      REQUIRE(r->selected_loops.size() == 1);
      for (const auto& l : l_seq) CHECK(r->selected_loops[0].distance <= l.distance);
    }
  }
  CHECK(with_pairs > 200);
}

TEST_CASE("Stage C: loop sets - both endpoints (default) vs the paper's literal any-endpoint set") {
  std::mt19937 rng(5);
  const Positions pa = RandomPositions(rng, 20, 10.0), pb = RandomPositions(rng, 20, 10.0);
  const auto l_seq = RandomLoops(rng, 60, 20, 20);
  const std::vector<int> alpha_sel = {1, 3, 5, 7, 9, 11, 13, 15, 17, 19};
  const std::vector<int> beta_sel = {0, 2, 4, 6, 8, 10};
  std::size_t both = 0, any = 0;
  for (const auto& l : l_seq) {
    const bool a = std::binary_search(alpha_sel.begin(), alpha_sel.end(), static_cast<int>(l.alpha_index));
    const bool b = std::binary_search(beta_sel.begin(), beta_sel.end(), static_cast<int>(l.beta_index));
    both += a && b;
    any += a || b;
  }
  StageCParams params;
  params.loop_set = StageCLoopSet::kBothEndpointsSelected;
  auto r_both = RunStageC(l_seq, alpha_sel, beta_sel, pa, pb, params);
  REQUIRE(r_both.ok());
  CHECK(r_both->loops_in_set == both);
  for (const auto& l : r_both->candidate_loops) {
    CHECK(std::binary_search(alpha_sel.begin(), alpha_sel.end(), static_cast<int>(l.alpha_index)));
    CHECK(std::binary_search(beta_sel.begin(), beta_sel.end(), static_cast<int>(l.beta_index)));
  }
  params.loop_set = StageCLoopSet::kAnyEndpointSelected;
  auto r_any = RunStageC(l_seq, alpha_sel, beta_sel, pa, pb, params);
  REQUIRE(r_any.ok());
  CHECK(r_any->loops_in_set == any);
  CHECK(any > both);

  // Nothing selected on one side: no loop has both endpoints selected.
  params.loop_set = StageCLoopSet::kBothEndpointsSelected;
  auto r_none = RunStageC(l_seq, alpha_sel, std::vector<int>{}, pa, pb, params);
  REQUIRE(r_none.ok());
  CHECK(r_none->selected_loops.empty());
  CHECK(r_none->no_candidate_reason.find("both endpoints") != std::string::npos);
  // The default falls back to the any-endpoint set then: the loops whose alpha keyframe is selected.
  params.loop_set = StageCLoopSet::kBothEndpointsElseAny;
  CHECK(StageCParams{}.loop_set == StageCLoopSet::kBothEndpointsElseAny);
  auto r_fallback = RunStageC(l_seq, alpha_sel, std::vector<int>{}, pa, pb, params);
  REQUIRE(r_fallback.ok());
  std::size_t alpha_side = 0;
  for (const auto& l : l_seq) {
    alpha_side += std::binary_search(alpha_sel.begin(), alpha_sel.end(), static_cast<int>(l.alpha_index)) ? 1 : 0;
  }
  CHECK(r_fallback->any_endpoint_fallback);
  CHECK(r_fallback->loops_in_set == alpha_side);
  CHECK_FALSE(r_fallback->selected_loops.empty());
  // ... bounded: the fallback_max_loops of them with the smallest descriptor distance.
  REQUIRE(alpha_side > static_cast<std::size_t>(params.fallback_max_loops));
  REQUIRE(r_fallback->candidate_loops.size() == static_cast<std::size_t>(params.fallback_max_loops));
  std::vector<float> side_distances;
  for (const auto& l : l_seq) {
    if (std::binary_search(alpha_sel.begin(), alpha_sel.end(), static_cast<int>(l.alpha_index))) {
      side_distances.push_back(l.distance);
    }
  }
  std::sort(side_distances.begin(), side_distances.end());
  for (const auto& l : r_fallback->candidate_loops) {
    CHECK(l.distance <= side_distances[static_cast<std::size_t>(params.fallback_max_loops) - 1]);
  }
  StageCParams no_fallback = params;
  no_fallback.fallback_max_loops = 0;
  CHECK_FALSE(ValidateStageCParams(no_fallback).ok());
  // With loops of both endpoints available it is the both-endpoint set.
  auto r_default = RunStageC(l_seq, alpha_sel, beta_sel, pa, pb, params);
  REQUIRE(r_default.ok());
  CHECK_FALSE(r_default->any_endpoint_fallback);
  CHECK(r_default->loops_in_set == both);
  auto r_empty = RunStageC(std::vector<SequentialLoopCell>{}, alpha_sel, beta_sel, pa, pb, params);
  REQUIRE(r_empty.ok());
  CHECK(r_empty->no_candidate_reason == "stage A found no loops");
}

TEST_CASE("Stage C: consistent loops are kept and outlier loops are rejected") {
  // 15 true loops: beta observes the same places in another frame (rotated, shifted); 6 outliers pair random
  // places with descriptor distances as good as the true ones.
  std::mt19937 rng(99);
  const Positions pa = RandomPositions(rng, 40, 30.0);
  const Eigen::Isometry3d T_beta_alpha = Eigen::Translation3d(-12.0, 40.0, 0.5) *
                                         Eigen::AngleAxisd(2.1, Eigen::Vector3d::UnitZ());
  Positions pb;
  std::normal_distribution<double> noise(0.0, 0.2);
  for (const auto& p : pa) pb.push_back(T_beta_alpha * p + Eigen::Vector3d(noise(rng), noise(rng), 0.0));
  std::vector<SequentialLoopCell> l_seq;
  for (std::size_t i = 0; i < 15; ++i) l_seq.push_back({i, i, 0.03f + 0.001f * static_cast<float>(i)});
  for (std::size_t k = 0; k < 6; ++k) l_seq.push_back({20 + k, 39 - 3 * k, 0.02f});
  std::vector<int> all(40);
  for (int i = 0; i < 40; ++i) all[static_cast<std::size_t>(i)] = i;
  auto r = RunStageC(l_seq, all, all, pa, pb, StageCParams{});
  REQUIRE(r.ok());
  CHECK(r->clique.status == CliqueSearchStatus::kOptimal);
  CHECK(r->selected_loops.size() >= 14);
  for (const auto& l : r->selected_loops) CHECK(l.alpha_index == l.beta_index);
}

TEST_CASE("Stage C: max_loops keeps the most similar loops and counts the rest") {
  std::mt19937 rng(3);
  const Positions pa = RandomPositions(rng, 30, 5.0), pb = RandomPositions(rng, 30, 5.0);
  const auto l_seq = RandomLoops(rng, 50, 30, 30);
  std::vector<int> all(30);
  for (int i = 0; i < 30; ++i) all[static_cast<std::size_t>(i)] = i;
  StageCParams params;
  params.max_loops = 10;
  auto r = RunStageC(l_seq, all, all, pa, pb, params);
  REQUIRE(r.ok());
  CHECK(r->loops_in_set == l_seq.size());
  CHECK(r->candidate_loops.size() == 10);
  CHECK(r->loops_dropped == l_seq.size() - 10);
  std::vector<float> d;
  for (const auto& l : l_seq) d.push_back(l.distance);
  std::sort(d.begin(), d.end());
  for (const auto& l : r->candidate_loops) CHECK(l.distance <= d[9]);
}

TEST_CASE("Stage C: bad parameters and inputs are refused with a message") {
  const Positions pa(3, Eigen::Vector3d::Zero()), pb(3, Eigen::Vector3d::Zero());
  const std::vector<SequentialLoopCell> loops = {{0, 0, 0.01f}, {2, 1, 0.02f}};
  const std::vector<int> sel = {0, 1, 2};
  StageCParams p;
  p.tau_con_m = 0.0;
  CHECK_FALSE(RunStageC(loops, sel, sel, pa, pb, p).ok());
  p = StageCParams{};
  p.tau_con_m = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(RunStageC(loops, sel, sel, pa, pb, p).ok());
  p = StageCParams{};
  p.max_loops = 0;
  CHECK_FALSE(RunStageC(loops, sel, sel, pa, pb, p).ok());
  p = StageCParams{};
  const std::vector<int> unsorted = {2, 0};
  CHECK_FALSE(RunStageC(loops, unsorted, sel, pa, pb, p).ok());
  const Positions short_b(1, Eigen::Vector3d::Zero());
  auto r = RunStageC(loops, sel, sel, pa, short_b, p);
  REQUIRE_FALSE(r.ok());
  CHECK(r.status().message().find("has no pose") != std::string::npos);
  Positions nan_a = pa;
  nan_a[2].x() = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(RunStageC(loops, sel, sel, nan_a, pb, p).ok());
  std::vector<SequentialLoopCell> nan_d = loops;
  nan_d[1].distance = std::numeric_limits<float>::quiet_NaN();
  CHECK_FALSE(RunStageC(nan_d, sel, sel, pa, pb, p).ok());
}

}  // namespace
}  // namespace commerge
