// SPDX-License-Identifier: BSD-3-Clause
// GlpkColumnLp (the GLPK problem kept between solves for column generation): every warm solve equals a cold
// solve of the same program by GlpkSimplexSolver, duals price every column non-negatively at the optimum, a warm
// sequence needs fewer simplex iterations than solving each step from scratch, a Reset keeps a usable basis,
// basis hints beyond the row count are balanced, and bad input is InvalidArgument.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/solvers/lp_relaxation.hpp"

namespace commerge {
namespace {

// A column-generation master like stage B's: row 0 is the convexity row (= 1), rows 1..m ask for at least rhs_i,
// columns are mixtures with cost and per-row counts. Column 0 meets every row, so the program is feasible.
struct Master {
  std::vector<LpRowBounds> rows;
  std::vector<double> cost;
  std::vector<std::vector<LpColumnEntry>> entries;
};

Master RandomMaster(std::mt19937& rng, int m, int columns) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Master ms;
  ms.rows.push_back({1.0, 1.0});
  for (int i = 0; i < m; ++i) ms.rows.push_back({1.0 + 4.0 * unit(rng), kLpInfinity});
  for (int k = 0; k < columns; ++k) {
    std::vector<LpColumnEntry> e{{0, 1.0}};
    double c = 0.0;
    for (int i = 1; i <= m; ++i) {
      const double a = k == 0 ? 6.0 : std::floor(7.0 * unit(rng)) * 0.5;  // half-integral counts like x2 / 2
      if (a != 0.0) e.push_back({i, a});
      c += a * (0.5 + unit(rng));
    }
    ms.cost.push_back(k == 0 ? c + 20.0 : c + unit(rng));
    ms.entries.push_back(std::move(e));
  }
  return ms;
}

LinearProgram AsProgram(const Master& ms, int columns) {
  LinearProgram lp;
  for (int k = 0; k < columns; ++k) {
    lp.objective.push_back(ms.cost[static_cast<std::size_t>(k)]);
    lp.variable_lower.push_back(0.0);
    lp.variable_upper.push_back(kLpInfinity);
  }
  for (const LpRowBounds& r : ms.rows) lp.rows.push_back(LpRow{{}, r.lower, r.upper});
  for (int k = 0; k < columns; ++k) {
    for (const LpColumnEntry& e : ms.entries[static_cast<std::size_t>(k)]) {
      lp.rows[static_cast<std::size_t>(e.row)].terms.push_back({k, e.coefficient});
    }
  }
  return lp;
}

// At an optimum of a minimisation with columns >= 0: every reduced cost c_k - y . a_k is >= 0, and the
// objective equals y . b over the rows' active bounds (strong duality; rows here are = 1 or >= rhs).
void CheckDuals(const Master& ms, int columns, const LpSolution& sol) {
  REQUIRE(sol.row_duals.size() == ms.rows.size());
  double dual_objective = 0.0;
  for (std::size_t i = 0; i < ms.rows.size(); ++i) dual_objective += sol.row_duals[i] * ms.rows[i].lower;
  CHECK(dual_objective == doctest::Approx(sol.objective).epsilon(1e-7));
  for (int k = 0; k < columns; ++k) {
    double reduced = ms.cost[static_cast<std::size_t>(k)];
    for (const LpColumnEntry& e : ms.entries[static_cast<std::size_t>(k)]) {
      reduced -= sol.row_duals[static_cast<std::size_t>(e.row)] * e.coefficient;
    }
    CHECK(reduced >= -1e-7);
  }
  for (std::size_t i = 1; i < ms.rows.size(); ++i) CHECK(sol.row_duals[i] >= -1e-9);  // ">=" rows
}

TEST_CASE("Column LP: every warm solve of a growing master equals a cold GLPK solve, with fewer iterations") {
  std::mt19937 rng(4242U);
  std::int64_t warm_iterations = 0;
  std::int64_t cold_iterations = 0;
  for (int trial = 0; trial < 30; ++trial) {
    const int m = 1 + trial % 5;
    const Master ms = RandomMaster(rng, m, 40);
    GlpkColumnLp warm;
    REQUIRE(warm.Reset(ms.rows).ok());
    GlpkSimplexSolver cold;
    for (int k = 0; k < 40; ++k) {
      REQUIRE(warm.AddColumn(ms.cost[static_cast<std::size_t>(k)], 0.0, kLpInfinity, ms.entries[static_cast<std::size_t>(k)]).ok());
      Result<LpSolution> w = warm.Solve();
      Result<LpSolution> c = cold.Minimize(AsProgram(ms, k + 1));
      REQUIRE(w.ok());
      REQUIRE(c.ok());
      REQUIRE(w->status == LpStatus::kOptimal);
      REQUIRE(c->status == LpStatus::kOptimal);
      CHECK(w->objective == doctest::Approx(c->objective).epsilon(1e-9));
      CheckDuals(ms, k + 1, *w);
      // The same step from scratch: a fresh problem with all k + 1 columns.
      GlpkColumnLp scratch;
      REQUIRE(scratch.Reset(ms.rows).ok());
      for (int j = 0; j <= k; ++j) {
        REQUIRE(scratch.AddColumn(ms.cost[static_cast<std::size_t>(j)], 0.0, kLpInfinity, ms.entries[static_cast<std::size_t>(j)]).ok());
      }
      Result<LpSolution> s = scratch.Solve();
      REQUIRE(s.ok());
      CHECK(s->objective == doctest::Approx(c->objective).epsilon(1e-9));
      cold_iterations += scratch.simplex_iterations();
    }
    CHECK(warm.solves() == 40);
    CHECK(warm.basis_rebuilds() == 0);
    CHECK(warm.columns() == 40);
    CHECK(warm.rows() == m + 1);
    warm_iterations += warm.simplex_iterations();
  }
  MESSAGE("simplex iterations: warm " << warm_iterations << ", each step from scratch " << cold_iterations);
  CHECK(warm_iterations > 0);
  CHECK(warm_iterations * 2 < cold_iterations);
}

TEST_CASE("Column LP: a Reset keeps the rows' basis, hinted support columns restart near the optimum") {
  std::mt19937 rng(77U);
  for (int trial = 0; trial < 20; ++trial) {
    const int m = 2 + trial % 3;
    Master ms = RandomMaster(rng, m, 30);
    GlpkColumnLp lp;
    REQUIRE(lp.Reset(ms.rows).ok());
    for (int k = 0; k < 30; ++k) REQUIRE(lp.AddColumn(ms.cost[static_cast<std::size_t>(k)], 0.0, kLpInfinity, ms.entries[static_cast<std::size_t>(k)]).ok());
    Result<LpSolution> first = lp.Solve();
    REQUIRE(first.ok());
    REQUIRE(first->status == LpStatus::kOptimal);
    // The child: the same rows with a slightly different right-hand side, column 0 and the parent's support
    // (hinted basic) first, then the other columns.
    Master child = ms;
    for (std::size_t i = 1; i < child.rows.size(); ++i) child.rows[i].lower *= 0.9;
    std::vector<int> order{0};
    for (int k = 1; k < 30; ++k) {
      if (first->values[static_cast<std::size_t>(k)] > 1e-9) order.push_back(k);
    }
    const std::size_t support = order.size();
    for (int k = 1; k < 30; ++k) {
      if (!(first->values[static_cast<std::size_t>(k)] > 1e-9)) order.push_back(k);
    }
    Master reordered = child;
    reordered.cost.clear();
    reordered.entries.clear();
    for (int k : order) {
      reordered.cost.push_back(child.cost[static_cast<std::size_t>(k)]);
      reordered.entries.push_back(child.entries[static_cast<std::size_t>(k)]);
    }
    REQUIRE(lp.Reset(reordered.rows).ok());
    CHECK(lp.columns() == 0);
    for (std::size_t j = 0; j < order.size(); ++j) {
      REQUIRE(lp.AddColumn(reordered.cost[j], 0.0, kLpInfinity, reordered.entries[j], j > 0 && j < support).ok());
    }
    const std::int64_t before = lp.simplex_iterations();
    Result<LpSolution> second = lp.Solve();
    REQUIRE(second.ok());
    REQUIRE(second->status == LpStatus::kOptimal);
    GlpkSimplexSolver cold;
    Result<LpSolution> ref = cold.Minimize(AsProgram(reordered, 30));
    REQUIRE(ref.ok());
    CHECK(second->objective == doctest::Approx(ref->objective).epsilon(1e-9));
    CheckDuals(reordered, 30, *second);
    CHECK(lp.simplex_iterations() - before <= 2 * (m + 1));
    // A different row count starts from the slack basis.
    Master other = RandomMaster(rng, m + 1, 10);
    REQUIRE(lp.Reset(other.rows).ok());
    for (int k = 0; k < 10; ++k) REQUIRE(lp.AddColumn(other.cost[static_cast<std::size_t>(k)], 0.0, kLpInfinity, other.entries[static_cast<std::size_t>(k)]).ok());
    Result<LpSolution> third = lp.Solve();
    Result<LpSolution> third_ref = cold.Minimize(AsProgram(other, 10));
    REQUIRE(third.ok());
    REQUIRE(third_ref.ok());
    CHECK(third->objective == doctest::Approx(third_ref->objective).epsilon(1e-9));
  }
}

TEST_CASE("Column LP: more hinted columns than rows, infeasible, unbounded and empty programs") {
  GlpkColumnLp lp;
  // min x0 + 2 x1 + 3 x2 s.t. x0 + x1 + x2 = 1 (one row), every column hinted basic: the basis is balanced.
  REQUIRE(lp.Reset({{1.0, 1.0}}).ok());
  for (int k = 0; k < 3; ++k) REQUIRE(lp.AddColumn(1.0 + k, 0.0, kLpInfinity, {{0, 1.0}}, true).ok());
  Result<LpSolution> s = lp.Solve();
  REQUIRE(s.ok());
  REQUIRE(s->status == LpStatus::kOptimal);
  CHECK(s->objective == doctest::Approx(1.0));
  CHECK(s->values[0] == doctest::Approx(1.0));
  CHECK(s->row_duals[0] == doctest::Approx(1.0));

  REQUIRE(lp.Reset({{2.0, kLpInfinity}}).ok());
  REQUIRE(lp.AddColumn(1.0, 0.0, 1.0, {{0, 1.0}}).ok());
  s = lp.Solve();
  REQUIRE(s.ok());
  CHECK(s->status == LpStatus::kInfeasible);

  REQUIRE(lp.Reset({{0.0, kLpInfinity}}).ok());
  REQUIRE(lp.AddColumn(-1.0, 0.0, kLpInfinity, {{0, 1.0}}).ok());
  s = lp.Solve();
  REQUIRE(s.ok());
  CHECK(s->status == LpStatus::kUnbounded);

  REQUIRE(lp.Reset({{-1.0, 1.0}}).ok());
  s = lp.Solve();  // no column: feasible iff every row admits 0
  REQUIRE(s.ok());
  CHECK(s->status == LpStatus::kOptimal);
  REQUIRE(lp.Reset({{1.0, 2.0}}).ok());
  s = lp.Solve();
  REQUIRE(s.ok());
  CHECK(s->status == LpStatus::kInfeasible);
}

TEST_CASE("Column LP: bad rows and columns are InvalidArgument and leave the problem usable") {
  GlpkColumnLp lp;
  CHECK(lp.Reset({{2.0, 1.0}}).code() == StatusCode::kInvalidArgument);
  CHECK(lp.Reset({{static_cast<double>(NAN), 1.0}}).code() == StatusCode::kInvalidArgument);
  CHECK(lp.Reset({{kLpInfinity, kLpInfinity}}).code() == StatusCode::kInvalidArgument);
  REQUIRE(lp.Reset({{1.0, kLpInfinity}, {0.0, 4.0}}).ok());
  CHECK(lp.AddColumn(static_cast<double>(NAN), 0.0, 1.0, {{0, 1.0}}).code() == StatusCode::kInvalidArgument);
  CHECK(lp.AddColumn(1.0, 1.0, 0.0, {{0, 1.0}}).code() == StatusCode::kInvalidArgument);
  CHECK(lp.AddColumn(1.0, 0.0, 1.0, {{2, 1.0}}).code() == StatusCode::kInvalidArgument);
  CHECK(lp.AddColumn(1.0, 0.0, 1.0, {{-1, 1.0}}).code() == StatusCode::kInvalidArgument);
  CHECK(lp.AddColumn(1.0, 0.0, 1.0, {{0, 1.0}, {0, 2.0}}).code() == StatusCode::kInvalidArgument);
  CHECK(lp.AddColumn(1.0, 0.0, 1.0, {{1, static_cast<double>(INFINITY)}}).code() == StatusCode::kInvalidArgument);
  CHECK(lp.columns() == 0);
  // min x s.t. x >= 1, 0 <= 2x <= 4
  REQUIRE(lp.AddColumn(1.0, 0.0, kLpInfinity, {{0, 1.0}, {1, 2.0}}).ok());
  Result<LpSolution> s = lp.Solve();
  REQUIRE(s.ok());
  REQUIRE(s->status == LpStatus::kOptimal);
  CHECK(s->objective == doctest::Approx(1.0));
}

}  // namespace
}  // namespace commerge
