// SPDX-License-Identifier: BSD-3-Clause
#include "core/solvers/lp_relaxation.hpp"

#include <glpk.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>

namespace commerge {
namespace {

struct GlpProbDeleter {
  void operator()(glp_prob* p) const noexcept { glp_delete_prob(p); }
};

int BoundType(double lower, double upper) {
  const bool has_lower = std::isfinite(lower);
  const bool has_upper = std::isfinite(upper);
  if (has_lower && has_upper) return lower == upper ? GLP_FX : GLP_DB;
  if (has_lower) return GLP_LO;
  if (has_upper) return GLP_UP;
  return GLP_FR;
}

double Finite(double x) { return std::isfinite(x) ? x : 0.0; }

}  // namespace

Status ValidateLinearProgram(const LinearProgram& lp) {
  const std::size_t n = lp.objective.size();
  if (lp.variable_lower.size() != n || lp.variable_upper.size() != n) {
    return InvalidArgument("LP: " + std::to_string(n) + " objective coefficients but " +
                           std::to_string(lp.variable_lower.size()) + " lower and " +
                           std::to_string(lp.variable_upper.size()) + " upper bounds");
  }
  for (std::size_t j = 0; j < n; ++j) {
    if (!std::isfinite(lp.objective[j])) return InvalidArgument("LP: objective coefficient " + std::to_string(j) + " is not finite");
    if (std::isnan(lp.variable_lower[j]) || std::isnan(lp.variable_upper[j]) ||
        lp.variable_lower[j] > lp.variable_upper[j] || lp.variable_lower[j] == kLpInfinity ||
        lp.variable_upper[j] == -kLpInfinity) {
      return InvalidArgument("LP: bounds of variable " + std::to_string(j) + " are empty or NaN");
    }
  }
  for (std::size_t i = 0; i < lp.rows.size(); ++i) {
    const LpRow& r = lp.rows[i];
    if (std::isnan(r.lower) || std::isnan(r.upper) || r.lower > r.upper || r.lower == kLpInfinity ||
        r.upper == -kLpInfinity) {
      return InvalidArgument("LP: bounds of row " + std::to_string(i) + " are empty or NaN");
    }
    for (const LpTerm& t : r.terms) {
      if (t.variable < 0 || static_cast<std::size_t>(t.variable) >= n || !std::isfinite(t.coefficient)) {
        return InvalidArgument("LP: row " + std::to_string(i) + " has a bad term (variable " +
                               std::to_string(t.variable) + ")");
      }
    }
  }
  return Status::Ok();
}

namespace {

// Builds the GLPK problem of a validated program (columns 1..n, rows 1..m).
std::unique_ptr<glp_prob, GlpProbDeleter> BuildGlpkProblem(const LinearProgram& lp) {
  const int n = static_cast<int>(lp.objective.size());
  const int m = static_cast<int>(lp.rows.size());
  glp_term_out(GLP_OFF);
  std::unique_ptr<glp_prob, GlpProbDeleter> prob(glp_create_prob());
  glp_prob* p = prob.get();
  glp_set_obj_dir(p, GLP_MIN);
  if (n > 0) glp_add_cols(p, n);
  if (m > 0) glp_add_rows(p, m);
  for (int j = 0; j < n; ++j) {
    const auto sj = static_cast<std::size_t>(j);
    glp_set_obj_coef(p, j + 1, lp.objective[sj]);
    glp_set_col_bnds(p, j + 1, BoundType(lp.variable_lower[sj], lp.variable_upper[sj]), Finite(lp.variable_lower[sj]),
                     Finite(lp.variable_upper[sj]));
  }
  std::vector<int> ind(1);
  std::vector<double> val(1);
  for (int i = 0; i < m; ++i) {
    const LpRow& r = lp.rows[static_cast<std::size_t>(i)];
    glp_set_row_bnds(p, i + 1, BoundType(r.lower, r.upper), Finite(r.lower), Finite(r.upper));
    ind.resize(1);
    val.resize(1);
    // GLPK rejects duplicate column indices in a row: merge them.
    for (const LpTerm& t : r.terms) {
      bool seen = false;
      for (std::size_t k = 1; k < ind.size(); ++k) {
        if (ind[k] == t.variable + 1) {
          val[k] += t.coefficient;
          seen = true;
          break;
        }
      }
      if (!seen) {
        ind.push_back(t.variable + 1);
        val.push_back(t.coefficient);
      }
    }
    glp_set_mat_row(p, i + 1, static_cast<int>(ind.size()) - 1, ind.data(), val.data());
  }
  return prob;
}

// The solution glp_simplex left in `p`: primal values and row duals at an optimum, or the infeasible / unbounded
// verdict; Internal (named by `what`) for any other status.
Result<LpSolution> ReadSimplexSolution(glp_prob* p, const char* what) {
  LpSolution sol;
  const int st = glp_get_status(p);
  if (st == GLP_OPT) {
    const int n = glp_get_num_cols(p);
    const int m = glp_get_num_rows(p);
    sol.status = LpStatus::kOptimal;
    sol.objective = glp_get_obj_val(p);
    sol.values.resize(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) sol.values[static_cast<std::size_t>(j)] = glp_get_col_prim(p, j + 1);
    sol.row_duals.resize(static_cast<std::size_t>(m));
    for (int i = 0; i < m; ++i) sol.row_duals[static_cast<std::size_t>(i)] = glp_get_row_dual(p, i + 1);
  } else if (st == GLP_NOFEAS) {
    sol.status = LpStatus::kInfeasible;
  } else if (st == GLP_UNBND) {
    sol.status = LpStatus::kUnbounded;
  } else {
    return Status(StatusCode::kInternal, std::string(what) + ": glp_simplex ended with status " + std::to_string(st));
  }
  return sol;
}

}  // namespace

Result<LpSolution> GlpkSimplexSolver::Minimize(const LinearProgram& lp) {
  Status valid = ValidateLinearProgram(lp);
  if (!valid.ok()) return valid;
  const int n = static_cast<int>(lp.objective.size());
  std::unique_ptr<glp_prob, GlpProbDeleter> prob = BuildGlpkProblem(lp);
  glp_prob* p = prob.get();

  LpSolution sol;
  if (n == 0) {
    // No variables: feasible iff every row admits 0.
    for (const LpRow& r : lp.rows) {
      if (r.lower > 0.0 || r.upper < 0.0) return sol;  // kInfeasible
    }
    sol.status = LpStatus::kOptimal;
    return sol;
  }

  glp_smcp parm;
  glp_init_smcp(&parm);
  parm.msg_lev = GLP_MSG_OFF;
  parm.presolve = GLP_OFF;
  const int rc = glp_simplex(p, &parm);
  if (rc != 0) {
    return Status(StatusCode::kInternal, "LP: glp_simplex failed with code " + std::to_string(rc));
  }
  return ReadSimplexSolution(p, "LP");
}

Result<MipSolution> SolveMipWithGlpk(const LinearProgram& lp, const std::vector<bool>& is_integer,
                                     const MipOptions& options) {
  Status valid = ValidateLinearProgram(lp);
  if (!valid.ok()) return valid;
  const int n = static_cast<int>(lp.objective.size());
  if (is_integer.size() != lp.objective.size()) {
    return InvalidArgument("MIP: " + std::to_string(is_integer.size()) + " integer flags for " + std::to_string(n) +
                           " variables");
  }
  if (!(options.time_limit_s > 0.0)) return InvalidArgument("MIP: time_limit_s must be > 0");
  MipSolution sol;
  if (n == 0) {
    for (const LpRow& r : lp.rows) {
      if (r.lower > 0.0 || r.upper < 0.0) {
        sol.status = MipStatus::kInfeasible;
        return sol;
      }
    }
    sol.status = MipStatus::kOptimal;
    return sol;
  }
  std::unique_ptr<glp_prob, GlpProbDeleter> prob = BuildGlpkProblem(lp);
  glp_prob* p = prob.get();
  for (int j = 0; j < n; ++j) {
    if (is_integer[static_cast<std::size_t>(j)]) glp_set_col_kind(p, j + 1, GLP_IV);
  }
  glp_iocp parm;
  glp_init_iocp(&parm);
  parm.msg_lev = GLP_MSG_OFF;
  parm.presolve = options.presolve ? GLP_ON : GLP_OFF;
  const double limit_ms = std::min(options.time_limit_s * 1e3, 2.0e9);
  parm.tm_lim = std::max(1, static_cast<int>(limit_ms));
  if (!options.presolve) {
    glp_smcp lp_parm;
    glp_init_smcp(&lp_parm);
    lp_parm.msg_lev = GLP_MSG_OFF;
    const int lp_rc = glp_simplex(p, &lp_parm);
    if (lp_rc != 0) return Status(StatusCode::kInternal, "MIP: glp_simplex failed with code " + std::to_string(lp_rc));
    const int lp_st = glp_get_status(p);
    if (lp_st == GLP_NOFEAS) {
      sol.status = MipStatus::kInfeasible;
      return sol;
    }
    if (lp_st == GLP_UNBND) {
      sol.status = MipStatus::kUnbounded;
      return sol;
    }
  }
  const int rc = glp_intopt(p, &parm);
  const int st = glp_mip_status(p);
  if (rc == GLP_ENOPFS || rc == GLP_ENOFEAS || st == GLP_NOFEAS) {
    sol.status = MipStatus::kInfeasible;
    return sol;
  }
  if (rc == GLP_ENODFS) {
    sol.status = MipStatus::kUnbounded;
    return sol;
  }
  if (rc != 0 && rc != GLP_ETMLIM) {
    return Status(StatusCode::kInternal, "MIP: glp_intopt failed with code " + std::to_string(rc));
  }
  if (st == GLP_OPT && rc == 0) {
    sol.status = MipStatus::kOptimal;
  } else if (st == GLP_FEAS || st == GLP_OPT) {
    sol.status = MipStatus::kFeasible;
  } else {
    sol.status = MipStatus::kNoSolution;
    return sol;
  }
  sol.objective = glp_mip_obj_val(p);
  sol.values.resize(static_cast<std::size_t>(n));
  for (int j = 0; j < n; ++j) sol.values[static_cast<std::size_t>(j)] = glp_mip_col_val(p, j + 1);
  return sol;
}

// ---------------------------------------------------------------------------------------------------------------
// GlpkColumnLp

namespace {

constexpr int kMaxColumnLpRows = 100000;
constexpr int kMaxColumnLpColumns = 1000000;

bool ValidBounds(double lower, double upper) {
  return !std::isnan(lower) && !std::isnan(upper) && lower <= upper && lower != kLpInfinity && upper != -kLpInfinity;
}

// The non-basic status GLPK expects for a variable of bound type `type`.
int NonBasicStatus(int type) {
  switch (type) {
    case GLP_FR: return GLP_NF;
    case GLP_UP: return GLP_NU;
    case GLP_FX: return GLP_NS;
    default: return GLP_NL;  // GLP_LO, GLP_DB
  }
}

}  // namespace

struct GlpkColumnLp::Problem {
  Problem() : p(glp_create_prob()) {}
  ~Problem() { glp_delete_prob(p); }
  Problem(const Problem&) = delete;
  Problem& operator=(const Problem&) = delete;
  glp_prob* get() const noexcept { return p; }
  glp_prob* p;
  std::vector<int> ind;
  std::vector<double> val;
};

GlpkColumnLp::GlpkColumnLp() {
  glp_term_out(GLP_OFF);
  problem_ = std::make_unique<Problem>();
  glp_set_obj_dir(problem_->get(), GLP_MIN);
}

GlpkColumnLp::~GlpkColumnLp() = default;

int GlpkColumnLp::rows() const noexcept { return glp_get_num_rows(problem_->get()); }
int GlpkColumnLp::columns() const noexcept { return glp_get_num_cols(problem_->get()); }

Status GlpkColumnLp::Reset(const std::vector<LpRowBounds>& rows) {
  if (rows.size() > static_cast<std::size_t>(kMaxColumnLpRows)) {
    return InvalidArgument("column LP: " + std::to_string(rows.size()) + " rows (at most " +
                           std::to_string(kMaxColumnLpRows) + ")");
  }
  for (std::size_t i = 0; i < rows.size(); ++i) {
    if (!ValidBounds(rows[i].lower, rows[i].upper)) {
      return InvalidArgument("column LP: bounds of row " + std::to_string(i) + " are empty or NaN");
    }
  }
  glp_prob* p = problem_->get();
  const int n = glp_get_num_cols(p);
  if (n > 0) {
    std::vector<int> all(static_cast<std::size_t>(n) + 1);
    for (int j = 1; j <= n; ++j) all[static_cast<std::size_t>(j)] = j;
    glp_del_cols(p, n, all.data());
  }
  const int m = static_cast<int>(rows.size());
  if (glp_get_num_rows(p) != m) {
    // A different row set: start from the slack basis (every row basic).
    glp_erase_prob(p);
    glp_set_obj_dir(p, GLP_MIN);
    if (m > 0) glp_add_rows(p, m);
  }
  for (int i = 0; i < m; ++i) {
    const LpRowBounds& r = rows[static_cast<std::size_t>(i)];
    const int type = BoundType(r.lower, r.upper);
    glp_set_row_bnds(p, i + 1, type, Finite(r.lower), Finite(r.upper));
    if (glp_get_row_stat(p, i + 1) != GLP_BS) glp_set_row_stat(p, i + 1, NonBasicStatus(type));
  }
  return Status::Ok();
}

Status GlpkColumnLp::AddColumn(double cost, double lower, double upper, const std::vector<LpColumnEntry>& entries,
                               bool basic_hint) {
  glp_prob* p = problem_->get();
  const int m = glp_get_num_rows(p);
  const int n = glp_get_num_cols(p);
  if (n >= kMaxColumnLpColumns) {
    return InvalidArgument("column LP: more than " + std::to_string(kMaxColumnLpColumns) + " columns");
  }
  if (!std::isfinite(cost)) return InvalidArgument("column LP: column " + std::to_string(n) + " has a non-finite cost");
  if (!ValidBounds(lower, upper)) {
    return InvalidArgument("column LP: bounds of column " + std::to_string(n) + " are empty or NaN");
  }
  std::vector<int>& ind = problem_->ind;
  std::vector<double>& val = problem_->val;
  ind.assign(1, 0);
  val.assign(1, 0.0);
  for (const LpColumnEntry& e : entries) {
    if (e.row < 0 || e.row >= m || !std::isfinite(e.coefficient)) {
      return InvalidArgument("column LP: column " + std::to_string(n) + " has a bad entry (row " +
                             std::to_string(e.row) + ")");
    }
    if (std::find(ind.begin() + 1, ind.end(), e.row + 1) != ind.end()) {
      return InvalidArgument("column LP: column " + std::to_string(n) + " repeats row " + std::to_string(e.row));
    }
    ind.push_back(e.row + 1);
    val.push_back(e.coefficient);
  }
  const int j = glp_add_cols(p, 1);
  const int type = BoundType(lower, upper);
  glp_set_obj_coef(p, j, cost);
  glp_set_col_bnds(p, j, type, Finite(lower), Finite(upper));
  glp_set_mat_col(p, j, static_cast<int>(ind.size()) - 1, ind.data(), val.data());
  glp_set_col_stat(p, j, basic_hint ? GLP_BS : NonBasicStatus(type));
  return Status::Ok();
}

void GlpkColumnLp::BalanceBasis() {
  glp_prob* p = problem_->get();
  const int m = glp_get_num_rows(p);
  const int n = glp_get_num_cols(p);
  int basic = 0;
  for (int i = 1; i <= m; ++i) basic += glp_get_row_stat(p, i) == GLP_BS ? 1 : 0;
  for (int j = 1; j <= n; ++j) basic += glp_get_col_stat(p, j) == GLP_BS ? 1 : 0;
  // Too many basic variables: rows leave the basis (their slack at its bound); too few: rows enter it.
  for (int i = 1; i <= m && basic > m; ++i) {
    if (glp_get_row_stat(p, i) != GLP_BS) continue;
    glp_set_row_stat(p, i, NonBasicStatus(glp_get_row_type(p, i)));
    --basic;
  }
  for (int j = n; j >= 1 && basic > m; --j) {  // still too many (hints beyond the row count): newest columns leave
    if (glp_get_col_stat(p, j) != GLP_BS) continue;
    glp_set_col_stat(p, j, NonBasicStatus(glp_get_col_type(p, j)));
    --basic;
  }
  for (int i = 1; i <= m && basic < m; ++i) {
    if (glp_get_row_stat(p, i) == GLP_BS) continue;
    glp_set_row_stat(p, i, GLP_BS);
    ++basic;
  }
}

Result<LpSolution> GlpkColumnLp::Solve() {
  glp_prob* p = problem_->get();
  const int m = glp_get_num_rows(p);
  const int n = glp_get_num_cols(p);
  ++solves_;
  LpSolution sol;
  if (n == 0) {
    for (int i = 1; i <= m; ++i) {
      const int type = glp_get_row_type(p, i);
      const bool admits_zero = !((type == GLP_LO || type == GLP_DB || type == GLP_FX) && glp_get_row_lb(p, i) > 0.0) &&
                               !((type == GLP_UP || type == GLP_DB || type == GLP_FX) && glp_get_row_ub(p, i) < 0.0);
      if (!admits_zero) return sol;  // kInfeasible
    }
    sol.status = LpStatus::kOptimal;
    sol.row_duals.assign(static_cast<std::size_t>(m), 0.0);
    return sol;
  }
  BalanceBasis();
  glp_smcp parm;
  glp_init_smcp(&parm);
  parm.msg_lev = GLP_MSG_OFF;
  parm.presolve = GLP_OFF;
  const int it0 = glp_get_it_cnt(p);
  int rc = glp_simplex(p, &parm);
  if (rc == GLP_EBADB || rc == GLP_ESING || rc == GLP_ECOND) {
    ++basis_rebuilds_;
    glp_adv_basis(p, 0);
    rc = glp_simplex(p, &parm);
  }
  simplex_iterations_ += glp_get_it_cnt(p) - it0;
  if (rc != 0) return Status(StatusCode::kInternal, "column LP: glp_simplex failed with code " + std::to_string(rc));
  return ReadSimplexSolution(p, "column LP");
}

}  // namespace commerge
