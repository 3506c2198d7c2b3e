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
  const int st = glp_get_status(p);
  if (st == GLP_OPT) {
    sol.status = LpStatus::kOptimal;
    sol.objective = glp_get_obj_val(p);
    sol.values.resize(static_cast<std::size_t>(n));
    for (int j = 0; j < n; ++j) sol.values[static_cast<std::size_t>(j)] = glp_get_col_prim(p, j + 1);
    const int m = static_cast<int>(lp.rows.size());
    sol.row_duals.resize(static_cast<std::size_t>(m));
    for (int i = 0; i < m; ++i) sol.row_duals[static_cast<std::size_t>(i)] = glp_get_row_dual(p, i + 1);
  } else if (st == GLP_NOFEAS) {
    sol.status = LpStatus::kInfeasible;
  } else if (st == GLP_UNBND) {
    sol.status = LpStatus::kUnbounded;
  } else {
    return Status(StatusCode::kInternal, "LP: glp_simplex ended with status " + std::to_string(st));
  }
  return sol;
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

}  // namespace commerge
