// SPDX-License-Identifier: BSD-3-Clause
// commerge: a tiny linear-programming interface (minimisation, sparse rows, box bounds) and a GLPK simplex
// implementation. Used for LP-relaxation bounds inside our own branch-and-bound solvers. Also GLPK's own
// branch-and-cut (glp_intopt) on the same model type, as the reference our exact solvers are tested and
// benchmarked against.
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <vector>

#include "core/common/status.hpp"

namespace commerge {

/// +infinity for bounds ("no bound").
constexpr double kLpInfinity = std::numeric_limits<double>::infinity();

/// One coefficient of a constraint row.
struct LpTerm {
  int variable = 0;
  double coefficient = 0.0;
};

/// lower <= sum(coefficient * x[variable]) <= upper; use ±kLpInfinity for a one-sided row.
struct LpRow {
  std::vector<LpTerm> terms;
  double lower = -kLpInfinity;
  double upper = kLpInfinity;
};

/// minimise objective·x  s.t. rows, variable_lower <= x <= variable_upper. All vectors of variables have the
/// same length (the number of variables).
struct LinearProgram {
  std::vector<double> objective;
  std::vector<double> variable_lower;
  std::vector<double> variable_upper;
  std::vector<LpRow> rows;
};

enum class LpStatus {
  kOptimal,     ///< `values` is an optimal basic solution
  kInfeasible,  ///< no x satisfies the rows and bounds
  kUnbounded,   ///< the objective decreases without limit
};

struct LpSolution {
  LpStatus status = LpStatus::kInfeasible;
  double objective = 0.0;      ///< valid when kOptimal
  std::vector<double> values;  ///< one per variable, valid when kOptimal
  /// One dual value (shadow price) per row, valid when kOptimal: d objective / d row bound, so >= 0 for an active
  /// ">=" row of a minimisation. Solvers that do not provide duals leave it empty.
  std::vector<double> row_duals;
};

/// Checks sizes, indices, finiteness of coefficients and lower <= upper; InvalidArgument otherwise.
Status ValidateLinearProgram(const LinearProgram& lp);

/// Interface so branch-and-bound code can be tested with any LP engine.
class LpSolver {
 public:
  virtual ~LpSolver() = default;
  /// Solves `lp`. Returns an error Status only for malformed input or an engine failure; infeasible and
  /// unbounded programs are results (LpSolution::status), not errors.
  virtual Result<LpSolution> Minimize(const LinearProgram& lp) = 0;
};

/// GLPK primal simplex (glp_simplex with presolve off). Silent: terminal output is switched off and
/// msg_lev = GLP_MSG_OFF. Not thread-safe across one instance; separate instances may run on separate threads.
class GlpkSimplexSolver final : public LpSolver {
 public:
  Result<LpSolution> Minimize(const LinearProgram& lp) override;
};

/// Bounds of one row of a GlpkColumnLp (lower <= row activity <= upper; ±kLpInfinity for a one-sided row).
struct LpRowBounds {
  double lower = -kLpInfinity;
  double upper = kLpInfinity;
};

/// One coefficient of a column: its row index (0-based) and value.
struct LpColumnEntry {
  int row = 0;
  double coefficient = 0.0;
};

/// A GLPK simplex problem kept alive between solves, for column generation inside a branch-and-bound: the rows
/// are set per node (Reset), columns are appended (AddColumn), and every Solve starts from the basis GLPK left
/// (primal simplex, presolve off). Within a node a new column enters as non-basic, so the previous optimum stays
/// a feasible basis and a re-solve takes a few pivots. Between nodes Reset keeps the rows' basis statuses when
/// the row count is unchanged, and columns added with `basic_hint` enter the basis: a child node that re-adds
/// its parent's LP support starts from (nearly) its parent's optimal basis. Before a solve the number of basic
/// variables is made equal to the row count (rows leave or enter the basis, in index order); a basis GLPK then
/// cannot factorise is replaced by its advanced (crash) basis and counted in basis_rebuilds().
/// Minimisation. Silent. Not thread-safe; separate instances may run on separate threads.
class GlpkColumnLp {
 public:
  GlpkColumnLp();
  ~GlpkColumnLp();
  GlpkColumnLp(const GlpkColumnLp&) = delete;
  GlpkColumnLp& operator=(const GlpkColumnLp&) = delete;

  /// Removes every column and sets the rows. InvalidArgument for NaN or empty bounds (lower > upper, lower =
  /// +inf, upper = -inf) or more than 100 000 rows.
  Status Reset(const std::vector<LpRowBounds>& rows);
  /// Appends a column (variable) with objective `cost` and bounds [lower, upper]. InvalidArgument for a
  /// non-finite cost or coefficient, bad bounds, a row out of range, a repeated row, or a 1 000 001st column.
  Status AddColumn(double cost, double lower, double upper, const std::vector<LpColumnEntry>& entries,
                   bool basic_hint = false);
  /// Solves from the kept basis. Internal when GLPK fails also from its crash basis.
  Result<LpSolution> Solve();

  int rows() const noexcept;
  int columns() const noexcept;
  std::int64_t solves() const noexcept { return solves_; }
  /// Solves whose kept basis could not be factorised (GLPK's crash basis was used instead).
  std::int64_t basis_rebuilds() const noexcept { return basis_rebuilds_; }
  /// Simplex iterations over all solves (GLPK's iteration count).
  std::int64_t simplex_iterations() const noexcept { return simplex_iterations_; }

 private:
  void BalanceBasis();
  struct Problem;  // the glp_prob (glpk.h stays out of this header)
  std::unique_ptr<Problem> problem_;
  std::int64_t solves_ = 0;
  std::int64_t basis_rebuilds_ = 0;
  std::int64_t simplex_iterations_ = 0;
};

enum class MipStatus {
  kOptimal,     ///< `values` is an optimal integer solution
  kFeasible,    ///< the time limit was hit; `values` is the best integer solution found (not proven optimal)
  kInfeasible,  ///< no integer solution exists (or the LP relaxation is infeasible)
  kNoSolution,  ///< the time limit was hit before any integer solution was found
  kUnbounded,   ///< the LP relaxation is unbounded
};

struct MipSolution {
  MipStatus status = MipStatus::kNoSolution;
  double objective = 0.0;      ///< valid for kOptimal and kFeasible
  std::vector<double> values;  ///< one per variable, valid for kOptimal and kFeasible
};

struct MipOptions {
  double time_limit_s = 60.0;  ///< glp_intopt tm_lim (> 0)
  bool presolve = true;        ///< glp_intopt's MIP presolver (then no separate glp_simplex call is needed)
};

/// Minimises `lp` with the variables flagged in `is_integer` (same length as the objective) restricted to
/// integers, by GLPK's glp_intopt with its default branching, backtracking and cut settings. Silent.
/// InvalidArgument for a malformed program or flag vector; Internal for an unexpected GLPK return code.
Result<MipSolution> SolveMipWithGlpk(const LinearProgram& lp, const std::vector<bool>& is_integer,
                                     const MipOptions& options = {});

}  // namespace commerge
