// SPDX-License-Identifier: BSD-3-Clause
// LP relaxation bound of the maximum edge-weighted clique (core/solvers/clique_lp_bound) and its use in
// SolveMaxClique: on seeded random graphs of <= 12 vertices the bound is at least the brute-force optimum, the
// colour rows never loosen it, the basic model's bound is at least GLPK's MIP optimum of the same model (which is
// the brute-force optimum), the search returns the same clique with and without it, and a node limit reports an
// upper bound between the optimum and the colouring-only bound. Also: subsets with gains, the size limit, an
// engine without duals, input validation, and small DIMACS instances of ../shared/data/graphs.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/common/tsv_table.hpp"
#include "core/solvers/clique_lp_bound.hpp"
#include "core/solvers/lp_relaxation.hpp"
#include "core/solvers/max_clique.hpp"
#include "tests/support/graph_data.hpp"
#include "tests/support/small_clique_graph.hpp"
#include "tests/support/test_data.hpp"

namespace commerge {
namespace clique_lp_test {
namespace {

inline std::size_t Ix(int i) { return static_cast<std::size_t>(i); }

// Edge-weighted graphs of the max clique tests (tests/support/small_clique_graph.hpp); their vertex weights are
// ignored here: the edge objective and the LP count edge weights only.
using SmallGraph = test::SmallCliqueGraph;
SmallGraph MakeRandom(std::mt19937& rng, int n, double density, bool integer_weights) {
  return test::MakeRandomCliqueGraph(rng, n, density, integer_weights);
}
CliqueGraph Build(const SmallGraph& s) { return test::BuildCliqueGraph(s); }

// Maximum over cliques K contained in `allowed` (bit mask) of sum_{v in K} gain[v] + sum_{uv in K} w_uv (the empty
// clique counts 0), by enumerating every subset.
double BruteForce(const SmallGraph& g, unsigned allowed, const std::vector<double>& gain) {
  const std::size_t subsets = std::size_t{1} << g.n;
  std::vector<char> clique(subsets, 0);
  std::vector<double> value(subsets, 0.0);
  clique[0] = 1;
  double best = 0.0;
  for (std::size_t mask = 1; mask < subsets; ++mask) {
    if ((static_cast<unsigned>(mask) & ~allowed) != 0U) continue;
    const int low = __builtin_ctz(static_cast<unsigned>(mask));
    const std::size_t rest = mask & (mask - 1);
    if (clique[rest] == 0 || (static_cast<unsigned>(rest) & ~g.adj[Ix(low)]) != 0U) continue;
    clique[mask] = 1;
    double e = value[rest] + (gain.empty() ? 0.0 : gain[Ix(low)]);
    for (unsigned r = static_cast<unsigned>(rest); r != 0U; r &= r - 1) e += g.Ew(low, __builtin_ctz(r));
    value[mask] = e;
    best = std::max(best, e);
  }
  return best;
}

double BruteForce(const SmallGraph& g) { return BruteForce(g, (g.n == 32 ? 0U : (1U << g.n)) - 1U, {}); }

std::vector<int> AllVertices(int n) {
  std::vector<int> v(Ix(n));
  for (int i = 0; i < n; ++i) v[Ix(i)] = i;
  return v;
}

CliqueLpBoundResult Bound(const CliqueGraph& g, bool colour_rows, bool non_edge_rows = true) {
  CliqueLpBoundParams p;
  p.colour_rows = colour_rows;
  p.non_edge_rows = non_edge_rows;
  Result<CliqueLpBoundResult> r = ComputeCliqueLpBound(g, p);
  REQUIRE(r.ok());
  return *r;
}

// Bound >= value, with the tolerance of the float weights' sums.
bool AtLeast(double bound, double value) { return bound >= value - 1e-9 * (1.0 + std::fabs(value)); }

CliqueSearchParams Params(bool lp, std::int64_t max_nodes = 100'000'000) {
  CliqueSearchParams p;
  p.objective = CliqueObjective::kEdgeWeight;
  p.time_limit_s = 1000.0;
  p.max_nodes = max_nodes;
  p.lp_bound = lp;
  p.lp_after_nodes = 0;  // at the root: the tests check the bound itself
  return p;
}

void CheckBoundsOnRandomGraphs(std::uint32_t seed, int graphs, bool integer_weights) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> size(1, 12);
  std::uniform_real_distribution<double> dens(0.1, 0.95);
  int tighter = 0;
  for (int t = 0; t < graphs; ++t) {
    const int n = size(rng);
    const double density = dens(rng);
    const SmallGraph s = MakeRandom(rng, n, density, integer_weights);
    const CliqueGraph g = Build(s);
    const double opt = BruteForce(s);
    CAPTURE(t);
    CAPTURE(n);
    CAPTURE(opt);
    const CliqueLpBoundResult strong = Bound(g, true);
    const CliqueLpBoundResult plain = Bound(g, false);
    const CliqueLpBoundResult bare = Bound(g, false, false);
    for (const CliqueLpBoundResult* r : {&strong, &plain, &bare}) {
      REQUIRE((r->status == CliqueLpStatus::kOptimal || r->status == CliqueLpStatus::kTrivial));
      CHECK(AtLeast(r->upper_bound, opt));
      if (r->status == CliqueLpStatus::kOptimal) {
        CHECK(r->certified);
        CHECK(r->simplex_solves == 1);
        CHECK(r->integer_rounded == integer_weights);
        // The certificate is close to the LP optimum GLPK reports (and rounding down stays within 1 of it).
        CHECK(r->upper_bound <= r->lp_objective + 1e-6 * (1.0 + std::fabs(r->lp_objective)));
        CHECK(r->upper_bound >= r->lp_objective - (integer_weights ? 1.0 : 1e-6 * (1.0 + std::fabs(r->lp_objective))));
      }
    }
    // Strengthening never loosens; without any clique row the LP takes every positive edge.
    CHECK(strong.lp_objective <= plain.lp_objective + 1e-7 * (1.0 + plain.lp_objective));
    CHECK(strong.upper_bound <= plain.upper_bound + 1e-7 * (1.0 + plain.upper_bound));
    double total = 0.0;
    for (int u = 0; u < n; ++u) {
      for (int v = u + 1; v < n; ++v) total += s.Ew(u, v);
    }
    if (bare.status == CliqueLpStatus::kOptimal) CHECK(bare.lp_objective == doctest::Approx(total).epsilon(1e-9));
    if (strong.upper_bound < plain.upper_bound - 1e-6) ++tighter;
  }
  CHECK(tighter > 0);  // the colour rows do cut on some graphs
}

TEST_CASE("Clique LP bound is at least the brute-force optimum and at most the LP without colour rows, integer weights") {
  CheckBoundsOnRandomGraphs(11U, 300, true);
}

TEST_CASE("Clique LP bound is at least the brute-force optimum and at most the LP without colour rows, real weights") {
  CheckBoundsOnRandomGraphs(12U, 300, false);
}

TEST_CASE("Clique LP bound of the basic model is at least GLPK's MIP optimum of the same model, the brute-force optimum") {
  std::mt19937 rng(13U);
  std::uniform_int_distribution<int> size(2, 12);
  std::uniform_real_distribution<double> dens(0.2, 0.9);
  for (int t = 0; t < 120; ++t) {
    const int n = size(rng);
    const double density = dens(rng);
    const SmallGraph s = MakeRandom(rng, n, density, t % 2 == 0);
    const CliqueGraph g = Build(s);
    const double opt = BruteForce(s);
    CAPTURE(t);
    for (const bool colour_rows : {false, true}) {
      CAPTURE(colour_rows);
      CliqueLpBoundParams p;
      p.colour_rows = colour_rows;
      Result<CliqueLpModel> model = BuildCliqueLpModel(g, AllVertices(n), {}, nullptr, p);
      REQUIRE(model.ok());
      REQUIRE_FALSE(model->too_large);
      CHECK(static_cast<int>(model->lp.rows.size()) == model->rows);
      CHECK(static_cast<int>(model->lp.objective.size()) == model->columns);
      std::vector<bool> is_integer(model->lp.objective.size(), false);
      for (int j = 0; j < model->num_vertex_columns; ++j) is_integer[Ix(j)] = true;
      Result<MipSolution> mip = SolveMipWithGlpk(model->lp, is_integer);
      REQUIRE(mip.ok());
      REQUIRE(mip->status == MipStatus::kOptimal);
      const double mip_opt = -mip->objective;
      CHECK(mip_opt == doctest::Approx(opt).epsilon(1e-6));
      const CliqueLpBoundResult lp = Bound(g, colour_rows);
      CHECK(AtLeast(lp.upper_bound, mip_opt));
      if (lp.status == CliqueLpStatus::kOptimal) CHECK(lp.lp_objective >= mip_opt - 1e-6 * (1.0 + mip_opt));
    }
  }
}

TEST_CASE("Clique LP bound of a vertex subset with gains is at least the brute-force optimum of that subset") {
  std::mt19937 rng(14U);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int t = 0; t < 150; ++t) {
    const int n = 3 + t % 10;
    const SmallGraph s = MakeRandom(rng, n, 0.3 + 0.5 * unit(rng), t % 3 == 0);
    const CliqueGraph g = Build(s);
    std::vector<int> subset;
    std::vector<double> gain_of(Ix(n), 0.0);
    std::vector<double> gains;
    unsigned mask = 0U;
    for (int v = n - 1; v >= 0; --v) {  // descending order: the model must not depend on sorted input
      if (unit(rng) < 0.7) {
        subset.push_back(v);
        mask |= 1U << v;
        gain_of[Ix(v)] = unit(rng) < 0.5 ? 0.0 : static_cast<double>(static_cast<float>(3.0 * unit(rng)));
        gains.push_back(gain_of[Ix(v)]);
      }
    }
    const double opt = BruteForce(s, mask, gain_of);
    CAPTURE(t);
    GlpkSimplexSolver glpk;
    for (const bool colour_rows : {false, true}) {
      CliqueLpBoundParams p;
      p.colour_rows = colour_rows;
      Result<CliqueLpBoundResult> r = ComputeCliqueLpBound(g, subset, gains, nullptr, &glpk, p);
      REQUIRE(r.ok());
      CHECK(AtLeast(r->upper_bound, opt));
      CHECK(r->upper_bound < std::numeric_limits<double>::infinity());
    }
  }
}

TEST_CASE("Greedy clique colouring covers the subset once with independent classes") {
  std::mt19937 rng(15U);
  for (int t = 0; t < 50; ++t) {
    const SmallGraph s = MakeRandom(rng, 12, 0.05 + 0.018 * t, true);
    const CliqueGraph g = Build(s);
    const std::vector<int> subset = {0, 2, 3, 5, 7, 8, 11, 3, -1, 40};  // a repeat and two strangers are ignored
    const CliqueColouring c = GreedyCliqueColouring(g, subset);
    CHECK(c.vertices.size() == 7);
    std::vector<int> seen = c.vertices;
    std::sort(seen.begin(), seen.end());
    CHECK(seen == std::vector<int>{0, 2, 3, 5, 7, 8, 11});
    for (int k = 0; k < c.num_classes(); ++k) {
      CHECK(c.class_start[Ix(k)] < c.class_start[Ix(k) + 1]);
      for (int a = c.class_start[Ix(k)]; a < c.class_start[Ix(k) + 1]; ++a) {
        for (int b = a + 1; b < c.class_start[Ix(k) + 1]; ++b) CHECK_FALSE(g.HasEdge(c.vertices[Ix(a)], c.vertices[Ix(b)]));
      }
    }
  }
}

TEST_CASE("Max clique with the LP bound returns the same clique as without it and as brute force") {
  std::mt19937 rng(16U);
  std::uniform_int_distribution<int> size(1, 12);
  std::uniform_real_distribution<double> dens(0.1, 0.95);
  int proved_at_root = 0;
  for (int t = 0; t < 600; ++t) {
    const int n = size(rng);
    const double density = dens(rng);
    const SmallGraph s = MakeRandom(rng, n, density, t % 2 == 0);
    const CliqueGraph g = Build(s);
    const double opt = BruteForce(s);
    CAPTURE(t);
    Result<CliqueSearchResult> on = SolveMaxClique(g, Params(true));
    Result<CliqueSearchResult> off = SolveMaxClique(g, Params(false));
    REQUIRE((on.ok() && off.ok()));
    CHECK(on->status == CliqueSearchStatus::kOptimal);
    CHECK(on->clique == off->clique);
    CHECK(on->objective == off->objective);
    CHECK(on->objective == doctest::Approx(opt).epsilon(1e-9));
    CHECK(on->upper_bound == on->objective);
    CHECK(on->nodes <= off->nodes);
    CHECK((on->lp_status == CliqueLpStatus::kOptimal || on->lp_status == CliqueLpStatus::kTrivial));
    CHECK(on->lp_solves == (on->lp_status == CliqueLpStatus::kOptimal ? 1 : 0));
    CHECK(AtLeast(on->lp_bound, opt));
    CHECK(off->lp_status == CliqueLpStatus::kNotRun);
    CHECK(std::isnan(off->lp_bound));
    CHECK(off->lp_solves == 0);
    if (on->nodes == 1 && off->nodes > 1) ++proved_at_root;
    // Under node limits the clique is still the same (the LP only cuts branches that cannot beat the incumbent)
    // and the bound lies between the optimum and the colouring-only bound.
    for (const std::int64_t limit : {1, 2, 5}) {
      CAPTURE(limit);
      Result<CliqueSearchResult> lon = SolveMaxClique(g, Params(true, limit));
      Result<CliqueSearchResult> loff = SolveMaxClique(g, Params(false, limit));
      REQUIRE((lon.ok() && loff.ok()));
      CHECK(lon->clique == loff->clique);
      CHECK(lon->objective == loff->objective);
      CHECK(AtLeast(lon->upper_bound, opt));
      CHECK(lon->upper_bound <= loff->upper_bound);
      CHECK(lon->nodes <= loff->nodes);
      if (loff->status == CliqueSearchStatus::kOptimal) CHECK(lon->status == CliqueSearchStatus::kOptimal);
    }
  }
  CHECK(proved_at_root > 0);
}

// G(n, p) with integer edge weights in 1..200.
CliqueGraph RandomCliqueGraph(int n, double p, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> w(1, 200);
  Result<CliqueGraph> g = CliqueGraph::Create(n, true);
  REQUIRE(g.ok());
  for (int u = 0; u < n; ++u) {
    for (int v = u + 1; v < n; ++v) {
      if (unit(rng) < p) REQUIRE(g->AddEdge(u, v, static_cast<double>(w(rng))).ok());
    }
  }
  return std::move(*g);
}

TEST_CASE("Max clique node limit of 1 with the LP bound reports a bound between the optimum and the colouring bound") {
  const std::pair<int, double> shapes[] = {{90, 0.3}, {90, 0.6}, {60, 0.8}};
  for (const auto& shape : shapes) {
    const int n = shape.first;
    const double density = shape.second;
    CAPTURE(n);
    CAPTURE(density);
    const CliqueGraph g = RandomCliqueGraph(n, density, 21U);
    Result<CliqueSearchResult> full = SolveMaxClique(g, Params(false));
    REQUIRE(full.ok());
    REQUIRE(full->status == CliqueSearchStatus::kOptimal);
    Result<CliqueSearchResult> full_lp = SolveMaxClique(g, Params(true));
    REQUIRE(full_lp.ok());
    CHECK(full_lp->status == CliqueSearchStatus::kOptimal);
    CHECK(full_lp->clique == full->clique);
    CHECK(full_lp->objective == full->objective);
    CHECK(full_lp->nodes <= full->nodes);
    Result<CliqueSearchResult> on = SolveMaxClique(g, Params(true, 1));
    Result<CliqueSearchResult> off = SolveMaxClique(g, Params(false, 1));
    REQUIRE((on.ok() && off.ok()));
    CHECK(on->status == CliqueSearchStatus::kLimitReached);
    CHECK(off->status == CliqueSearchStatus::kLimitReached);
    CHECK(on->nodes == 1);
    CHECK(on->clique == off->clique);
    CHECK(on->lp_status == CliqueLpStatus::kOptimal);
    CHECK(on->lp_solves == 1);
    CHECK(on->upper_bound >= full->objective);
    CHECK(on->upper_bound <= off->upper_bound);
    CHECK(on->upper_bound == std::min(on->lp_bound, off->upper_bound));
    CHECK(on->upper_bound < off->upper_bound);  // on these graphs the LP is the tighter bound
  }
}

TEST_CASE("Max clique solves the LP once lp_after_nodes nodes are expanded, and not when the search ends earlier") {
  const CliqueGraph g = RandomCliqueGraph(90, 0.6, 21U);
  Result<CliqueSearchResult> off = SolveMaxClique(g, Params(false));
  REQUIRE(off.ok());
  REQUIRE(off->nodes > 200);
  CliqueSearchParams p = Params(true);
  p.lp_after_nodes = 100;
  Result<CliqueSearchResult> late = SolveMaxClique(g, p);
  REQUIRE(late.ok());
  CHECK(late->lp_status == CliqueLpStatus::kOptimal);
  CHECK(late->lp_solves == 1);
  CHECK(late->clique == off->clique);
  CHECK(late->nodes <= off->nodes);
  CHECK(late->lp_bound >= off->objective);
  // Stopped at a node limit before lp_after_nodes: the LP is solved then, as the certificate of the gap, which
  // it tightens (never below the optimum, never above the colouring bound alone); the clique is the same.
  p.max_nodes = 50;
  p.lp_after_nodes = 1'000'000;
  Result<CliqueSearchResult> early = SolveMaxClique(g, p);
  Result<CliqueSearchResult> early_off = SolveMaxClique(g, Params(false, 50));
  REQUIRE((early.ok() && early_off.ok()));
  REQUIRE(early_off->status == CliqueSearchStatus::kLimitReached);
  CHECK(early->lp_status == CliqueLpStatus::kOptimal);
  CHECK(early->lp_solves == 1);
  CHECK(early->clique == early_off->clique);
  CHECK(early->upper_bound <= early_off->upper_bound);
  CHECK(early->upper_bound < early_off->upper_bound);  // this graph: the LP is below the colouring bound
  CHECK(early->upper_bound >= off->objective - 1e-9);
  // Finished before lp_after_nodes: no LP.
  p = Params(true);
  p.lp_after_nodes = off->nodes + 1;
  Result<CliqueSearchResult> never = SolveMaxClique(g, p);
  REQUIRE(never.ok());
  CHECK(never->lp_status == CliqueLpStatus::kNotRun);
  CHECK(never->nodes == off->nodes);
  CHECK(std::isnan(never->lp_bound));
  // The default waits for 1 000 000 nodes.
  CHECK(CliqueSearchParams{}.lp_after_nodes == 1'000'000);
  Result<CliqueSearchResult> by_default = SolveMaxClique(g, CliqueSearchParams{});
  REQUIRE(by_default.ok());
  CHECK(by_default->lp_status == CliqueLpStatus::kNotRun);
  CHECK(by_default->clique == off->clique);
}

TEST_CASE("Clique LP bound refuses a model above max_nonzeros and the search goes on without it") {
  const CliqueGraph g = RandomCliqueGraph(40, 0.5, 22U);
  const CliqueLpBoundResult full = Bound(g, true);
  REQUIRE(full.status == CliqueLpStatus::kOptimal);
  CHECK(full.nonzeros > 100);
  CliqueLpBoundParams p;
  p.max_nonzeros = full.nonzeros - 1;
  Result<CliqueLpBoundResult> r = ComputeCliqueLpBound(g, p);
  REQUIRE(r.ok());
  CHECK(r->status == CliqueLpStatus::kTooLarge);
  CHECK(r->simplex_solves == 0);
  CHECK(r->upper_bound == std::numeric_limits<double>::infinity());
  CHECK(r->nonzeros == full.nonzeros);
  CHECK(r->rows == full.rows);
  CHECK(r->columns == full.columns);
  p.max_nonzeros = full.nonzeros;
  r = ComputeCliqueLpBound(g, p);
  REQUIRE(r.ok());
  CHECK(r->status == CliqueLpStatus::kOptimal);

  Result<CliqueSearchResult> off = SolveMaxClique(g, Params(false));
  CliqueSearchParams sp = Params(true);
  sp.lp_max_nonzeros = 0;
  Result<CliqueSearchResult> none = SolveMaxClique(g, sp);
  REQUIRE((off.ok() && none.ok()));
  CHECK(none->lp_status == CliqueLpStatus::kTooLarge);
  CHECK(std::isnan(none->lp_bound));
  CHECK(none->lp_solves == 0);
  CHECK(none->clique == off->clique);
  CHECK(none->nodes == off->nodes);
  // A budget between the two models: the search retries without the non-edge rows.
  CliqueLpBoundParams bare;
  bare.non_edge_rows = false;
  Result<CliqueLpBoundResult> smaller = ComputeCliqueLpBound(g, bare);
  REQUIRE(smaller.ok());
  REQUIRE(smaller->nonzeros < full.nonzeros);
  sp.lp_max_nonzeros = smaller->nonzeros + 2 * g.num_vertices() * g.num_vertices();  // room for other colourings
  sp.lp_max_nonzeros = std::min(sp.lp_max_nonzeros, full.nonzeros - 1);
  Result<CliqueSearchResult> retried = SolveMaxClique(g, sp);
  REQUIRE(retried.ok());
  CHECK(retried->clique == off->clique);
  CHECK(retried->lp_solves <= 1);
}

TEST_CASE("Clique LP bound is 0 without a positive edge and the engine is not called") {
  Result<CliqueGraph> g = CliqueGraph::Create(6, true);
  REQUIRE(g.ok());
  REQUIRE(g->AddEdge(0, 1, 0.0).ok());
  REQUIRE(g->AddEdge(2, 3, 0.0).ok());
  const CliqueLpBoundResult r = Bound(*g, true);
  CHECK(r.status == CliqueLpStatus::kTrivial);
  CHECK(r.upper_bound == 0.0);
  CHECK(r.simplex_solves == 0);
  CHECK(r.columns == 0);
  Result<CliqueGraph> empty = CliqueGraph::Create(0, true);
  REQUIRE(empty.ok());
  CHECK(Bound(*empty, true).status == CliqueLpStatus::kTrivial);
  Result<CliqueSearchResult> s = SolveMaxClique(*g, Params(true));
  REQUIRE(s.ok());
  CHECK(s->objective == 0.0);
  CHECK(s->lp_bound == 0.0);
  CHECK(s->nodes == 1);
}

// An engine without duals: the bound falls back to the primal optimum plus a relative margin.
class NoDualsSolver final : public LpSolver {
 public:
  Result<LpSolution> Minimize(const LinearProgram& lp) override {
    Result<LpSolution> r = glpk_.Minimize(lp);
    if (r.ok()) r->row_duals.clear();
    return r;
  }

 private:
  GlpkSimplexSolver glpk_;
};

TEST_CASE("Clique LP bound without duals falls back to the primal optimum with a margin") {
  std::mt19937 rng(17U);
  NoDualsSolver engine;
  for (int t = 0; t < 40; ++t) {
    const SmallGraph s = MakeRandom(rng, 10, 0.6, t % 2 == 0);
    const CliqueGraph g = Build(s);
    Result<CliqueLpBoundResult> r = ComputeCliqueLpBound(g, AllVertices(10), {}, nullptr, &engine, {});
    REQUIRE(r.ok());
    if (r->status != CliqueLpStatus::kOptimal) continue;
    CHECK_FALSE(r->certified);
    CHECK_FALSE(r->integer_rounded);
    CHECK(r->upper_bound > r->lp_objective);
    CHECK(AtLeast(r->upper_bound, BruteForce(s)));
  }
}

TEST_CASE("Clique LP bound refuses graphs without edge weights and malformed subsets, gains and colourings") {
  Result<CliqueGraph> plain = CliqueGraph::Create(4, false);
  REQUIRE(plain.ok());
  REQUIRE(plain->AddEdge(0, 1).ok());
  CHECK(ComputeCliqueLpBound(*plain).status().code() == StatusCode::kInvalidArgument);
  CHECK(BuildCliqueLpModel(*plain, {0, 1}, {}, nullptr, {}).status().code() == StatusCode::kInvalidArgument);

  Result<CliqueGraph> g = CliqueGraph::Create(4, true);
  REQUIRE(g.ok());
  REQUIRE(g->AddEdge(0, 1, 2.0).ok());
  REQUIRE(g->AddEdge(1, 2, 3.0).ok());
  GlpkSimplexSolver glpk;
  auto code = [&](const std::vector<int>& vertices, const std::vector<double>& gains, const CliqueColouring* c,
                  const CliqueLpBoundParams& p) {
    return ComputeCliqueLpBound(*g, vertices, gains, c, &glpk, p).status().code();
  };
  CHECK(code({0, 1, 4}, {}, nullptr, {}) == StatusCode::kInvalidArgument);   // out of range
  CHECK(code({0, -1}, {}, nullptr, {}) == StatusCode::kInvalidArgument);     // out of range
  CHECK(code({0, 1, 0}, {}, nullptr, {}) == StatusCode::kInvalidArgument);   // repeated
  CHECK(code({0, 1}, {1.0}, nullptr, {}) == StatusCode::kInvalidArgument);   // gain count
  CHECK(code({0, 1}, {1.0, std::nan("")}, nullptr, {}) == StatusCode::kInvalidArgument);
  CliqueLpBoundParams negative;
  negative.max_nonzeros = -1;
  CHECK(code({0, 1}, {}, nullptr, negative) == StatusCode::kInvalidArgument);
  CliqueColouring not_independent;
  not_independent.vertices = {0, 1, 2};
  not_independent.class_start = {0, 2, 3};
  CHECK(code({0, 1, 2}, {}, &not_independent, {}) == StatusCode::kInvalidArgument);
  CliqueColouring outside;
  outside.vertices = {0, 2, 3};
  outside.class_start = {0, 3};
  CHECK(code({0, 2}, {}, &outside, {}) == StatusCode::kInvalidArgument);
  CliqueColouring twice;
  twice.vertices = {0, 2, 0};
  twice.class_start = {0, 2, 3};
  CHECK(code({0, 1, 2}, {}, &twice, {}) == StatusCode::kInvalidArgument);
  CliqueColouring bad_offsets;
  bad_offsets.vertices = {0, 2};
  bad_offsets.class_start = {0, 1};
  CHECK(code({0, 1, 2}, {}, &bad_offsets, {}) == StatusCode::kInvalidArgument);
  CHECK(ComputeCliqueLpBound(*g, {0, 1}, {}, nullptr, nullptr, {}).status().code() == StatusCode::kInvalidArgument);
  // A valid partial colouring (vertex 1 in no class) is accepted; colour rows off ignore the colouring.
  CliqueColouring partial;
  partial.vertices = {0, 2, 3};
  partial.class_start = {0, 3};
  CHECK(code({0, 1, 2, 3}, {}, &partial, {}) == StatusCode::kOk);
  CliqueLpBoundParams no_colour;
  no_colour.colour_rows = false;
  CHECK(code({0, 1, 2}, {}, &not_independent, no_colour) == StatusCode::kOk);
  Result<CliqueLpBoundResult> r = ComputeCliqueLpBound(*g, {0, 1, 2, 3}, {}, &partial, &glpk, {});
  REQUIRE(r.ok());
  CHECK(r->upper_bound == 3.0);  // {1, 2} (0 and 2 are non-adjacent: at most one of the two edges)

  CliqueSearchParams sp = Params(true);
  sp.lp_max_nonzeros = -1;
  CHECK(SolveMaxClique(*g, sp).status().code() == StatusCode::kInvalidArgument);
  sp = Params(true);
  sp.lp_after_nodes = -1;
  CHECK(SolveMaxClique(*g, sp).status().code() == StatusCode::kInvalidArgument);
  CHECK(std::string(CliqueLpStatusName(CliqueLpStatus::kTooLarge)) == "too large");
  CHECK(std::string(CliqueLpStatusName(CliqueLpStatus::kNotRun)) == "not run");
}

TEST_CASE("Clique LP bound on small DIMACS instances is at least mewc_optima.tsv and the search agrees") {
  CM_SHARED_DATA_OR_SKIP(tsv, "graphs/mewc_optima.tsv");
  const std::string dir = tsv.substr(0, tsv.find_last_of('/') + 1);
  std::map<std::string, TsvRow> rows;
  for (TsvRow& row : test::ReadTsvFile(tsv)) rows[row["name"]] = row;
  for (const char* instance : {"johnson8-2-4", "hamming6-4", "MANN_a9", "johnson8-4-4"}) {
    const std::string name = instance;
    CAPTURE(name);
    REQUIRE(rows.count(name) == 1);
    const double optimum = std::stod(rows[name].at("mewc_weight"));
    const CliqueGraph g = test::LoadDimacsCliqueGraph(dir + rows[name].at("file"), true);
    const CliqueLpBoundResult lp = Bound(g, true);
    REQUIRE(lp.status == CliqueLpStatus::kOptimal);
    CHECK(lp.upper_bound >= optimum);
    CHECK(lp.upper_bound <= Bound(g, false).upper_bound);
    Result<CliqueSearchResult> on = SolveMaxClique(g, Params(true));
    Result<CliqueSearchResult> off = SolveMaxClique(g, Params(false));
    REQUIRE((on.ok() && off.ok()));
    CHECK(on->objective == optimum);
    CHECK(on->clique == off->clique);
    CHECK(on->nodes <= off->nodes);
  }
}

}  // namespace
}  // namespace clique_lp_test
}  // namespace commerge
