// SPDX-License-Identifier: BSD-3-Clause
// GLPK simplex behind the LP interface: known optima, infeasible/unbounded programs, validation, duplicate terms.
#include <doctest/doctest.h>

#include <cmath>
#include <vector>

#include "core/solvers/lp_relaxation.hpp"

namespace commerge {
namespace {

TEST_CASE("GLPK simplex solves a small LP to its known optimum") {
  // min -x - 2y  s.t. x + y <= 4, x + 3y <= 6, 0 <= x, y <= 10  -> x = 3, y = 1, obj = -5
  LinearProgram lp;
  lp.objective = {-1.0, -2.0};
  lp.variable_lower = {0.0, 0.0};
  lp.variable_upper = {10.0, 10.0};
  lp.rows.push_back(LpRow{{{0, 1.0}, {1, 1.0}}, -kLpInfinity, 4.0});
  lp.rows.push_back(LpRow{{{0, 1.0}, {1, 3.0}}, -kLpInfinity, 6.0});
  GlpkSimplexSolver solver;
  Result<LpSolution> s = solver.Minimize(lp);
  REQUIRE(s.ok());
  REQUIRE(s->status == LpStatus::kOptimal);
  CHECK(s->objective == doctest::Approx(-5.0));
  CHECK(s->values[0] == doctest::Approx(3.0));
  CHECK(s->values[1] == doctest::Approx(1.0));
}

TEST_CASE("LP relaxation of a triangle vertex cover is half-integral") {
  LinearProgram lp;
  lp.objective = {1.0, 1.0, 1.0};
  lp.variable_lower = {0.0, 0.0, 0.0};
  lp.variable_upper = {1.0, 1.0, 1.0};
  lp.rows.push_back(LpRow{{{0, 1.0}, {1, 1.0}}, 1.0, kLpInfinity});
  lp.rows.push_back(LpRow{{{1, 1.0}, {2, 1.0}}, 1.0, kLpInfinity});
  lp.rows.push_back(LpRow{{{0, 1.0}, {2, 1.0}}, 1.0, kLpInfinity});
  GlpkSimplexSolver solver;
  Result<LpSolution> s = solver.Minimize(lp);
  REQUIRE(s.ok());
  REQUIRE(s->status == LpStatus::kOptimal);
  CHECK(s->objective == doctest::Approx(1.5));
}

TEST_CASE("GLPK simplex reports infeasible and unbounded programs as results") {
  GlpkSimplexSolver solver;
  LinearProgram infeasible;
  infeasible.objective = {1.0};
  infeasible.variable_lower = {0.0};
  infeasible.variable_upper = {1.0};
  infeasible.rows.push_back(LpRow{{{0, 1.0}}, 2.0, kLpInfinity});
  Result<LpSolution> s = solver.Minimize(infeasible);
  REQUIRE(s.ok());
  CHECK(s->status == LpStatus::kInfeasible);

  LinearProgram unbounded;
  unbounded.objective = {-1.0};
  unbounded.variable_lower = {0.0};
  unbounded.variable_upper = {kLpInfinity};
  s = solver.Minimize(unbounded);
  REQUIRE(s.ok());
  CHECK(s->status == LpStatus::kUnbounded);

  LinearProgram empty;
  s = solver.Minimize(empty);
  REQUIRE(s.ok());
  CHECK(s->status == LpStatus::kOptimal);
  empty.rows.push_back(LpRow{{}, 1.0, kLpInfinity});
  s = solver.Minimize(empty);
  REQUIRE(s.ok());
  CHECK(s->status == LpStatus::kInfeasible);
}

TEST_CASE("LP validation rejects malformed programs and duplicate terms are merged") {
  GlpkSimplexSolver solver;
  LinearProgram lp;
  lp.objective = {1.0};
  lp.variable_lower = {0.0};
  lp.variable_upper = {1.0, 2.0};
  CHECK(solver.Minimize(lp).status().code() == StatusCode::kInvalidArgument);
  lp.variable_upper = {-1.0};
  CHECK(solver.Minimize(lp).status().code() == StatusCode::kInvalidArgument);
  lp.variable_upper = {1.0};
  lp.rows.push_back(LpRow{{{1, 1.0}}, 0.0, 1.0});
  CHECK(solver.Minimize(lp).status().code() == StatusCode::kInvalidArgument);
  lp.rows[0] = LpRow{{{0, 1.0}}, 2.0, 1.0};
  CHECK(solver.Minimize(lp).status().code() == StatusCode::kInvalidArgument);
  lp.rows[0] = LpRow{{{0, static_cast<double>(NAN)}}, 0.0, 1.0};
  CHECK(solver.Minimize(lp).status().code() == StatusCode::kInvalidArgument);
  // 0.5 x + 0.5 x >= 0.75 -> x >= 0.75
  lp.rows[0] = LpRow{{{0, 0.5}, {0, 0.5}}, 0.75, kLpInfinity};
  Result<LpSolution> s = solver.Minimize(lp);
  REQUIRE(s.ok());
  REQUIRE(s->status == LpStatus::kOptimal);
  CHECK(s->objective == doctest::Approx(0.75));
}

}  // namespace
}  // namespace commerge
