// SPDX-License-Identifier: BSD-3-Clause
#include "core/solvers/lp_relaxation.hpp"

#include <glpk.h>

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

Result<LpSolution> GlpkSimplexSolver::Minimize(const LinearProgram& lp) {
  Status valid = ValidateLinearProgram(lp);
  if (!valid.ok()) return valid;
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
  } else if (st == GLP_NOFEAS) {
    sol.status = LpStatus::kInfeasible;
  } else if (st == GLP_UNBND) {
    sol.status = LpStatus::kUnbounded;
  } else {
    return Status(StatusCode::kInternal, "LP: glp_simplex ended with status " + std::to_string(st));
  }
  return sol;
}

}  // namespace commerge
