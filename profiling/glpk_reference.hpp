// SPDX-License-Identifier: BSD-3-Clause
// GLPK's own MIP solver (glp_intopt, presolve and clique cuts on) on the same clique models our solver takes:
// the reference the benchmarks compare speed and optimum against.
//   MEWC: x_v binary, y_uv in [0, 1] for every edge with y_uv <= x_u and y_uv <= x_v, x_u + x_v <= 1 for every
//   non-edge, maximise sum w_uv y_uv (y may stay continuous: for binary x the best y is min(x_u, x_v), binary).
//   Cardinality: x_v binary, x_u + x_v <= 1 for non-edges, maximise sum x_v. Dense in the non-edges: for graphs
//   up to about a thousand vertices.
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

#include <glpk.h>

#include "core/solvers/max_clique.hpp"

namespace commerge::bench {

struct GlpkRun {
  double objective = 0.0;  ///< optimum, or the best integer objective at a timeout (0 without one)
  double ms = 0.0;         ///< glp_intopt alone (model building excluded)
  bool optimal = false;
  bool timeout = false;
  bool failed = false;
};

inline GlpkRun GlpkMaxClique(const CliqueGraph& g, CliqueObjective objective, double time_limit_s) {
  const int n = g.num_vertices();
  const bool edge = objective == CliqueObjective::kEdgeWeight;
  glp_term_out(GLP_OFF);
  glp_prob* p = glp_create_prob();
  glp_set_obj_dir(p, GLP_MAX);
  if (n > 0) glp_add_cols(p, n);
  for (int v = 0; v < n; ++v) {
    glp_set_col_kind(p, v + 1, GLP_BV);
    glp_set_obj_coef(p, v + 1, edge ? 0.0 : objective == CliqueObjective::kVertexWeight ? g.vertex_weight(v) : 1.0);
  }
  std::vector<int> ia(1, 0), ja(1, 0);
  std::vector<double> ar(1, 0.0), row_upper;
  int row = 0;
  auto add_row = [&](int a, double ca, int b, double cb, double upper) {  // ca x_a + cb x_b <= upper
    ++row;
    ia.push_back(row);
    ja.push_back(a);
    ar.push_back(ca);
    ia.push_back(row);
    ja.push_back(b);
    ar.push_back(cb);
    row_upper.push_back(upper);
  };
  for (int u = 0; u < n; ++u) {
    for (int v = u + 1; v < n; ++v) {
      if (!g.HasEdge(u, v)) {
        add_row(u + 1, 1.0, v + 1, 1.0, 1.0);
      } else if (edge) {
        const int col = glp_add_cols(p, 1);
        glp_set_col_kind(p, col, GLP_CV);
        glp_set_col_bnds(p, col, GLP_DB, 0.0, 1.0);
        glp_set_obj_coef(p, col, g.edge_weight(u, v));
        add_row(col, 1.0, u + 1, -1.0, 0.0);
        add_row(col, 1.0, v + 1, -1.0, 0.0);
      }
    }
  }
  if (row > 0) glp_add_rows(p, row);
  for (int r = 0; r < row; ++r) glp_set_row_bnds(p, r + 1, GLP_UP, 0.0, row_upper[static_cast<std::size_t>(r)]);
  glp_load_matrix(p, static_cast<int>(ia.size()) - 1, ia.data(), ja.data(), ar.data());
  glp_iocp parm;
  glp_init_iocp(&parm);
  parm.msg_lev = GLP_MSG_OFF;
  parm.presolve = GLP_ON;
  parm.clq_cuts = GLP_ON;
  parm.tm_lim = static_cast<int>(std::min(time_limit_s * 1e3, 2e9));
  GlpkRun out;
  const auto start = std::chrono::steady_clock::now();
  const int rc = glp_intopt(p, &parm);
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  const int st = glp_mip_status(p);
  if (rc == 0 && st == GLP_OPT) {
    out.optimal = true;
    out.objective = glp_mip_obj_val(p);
  } else if (rc == GLP_ETMLIM) {
    out.timeout = true;
    out.objective = st == GLP_FEAS ? glp_mip_obj_val(p) : 0.0;
  } else {
    out.failed = true;
  }
  glp_delete_prob(p);
  return out;
}

}  // namespace commerge::bench
