// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/balanced_cover_milp.hpp"

#include <cmath>
#include <cstddef>
#include <string>
#include <utility>

namespace commerge {

Result<LinearProgram> BalancedCoverMilp(const ExchangeGraph& graph, const std::vector<double>& vertex_weights,
                                        const std::vector<int>& shares) {
  const auto n = static_cast<std::size_t>(graph.vertex_count());
  if (!vertex_weights.empty() && vertex_weights.size() != n) {
    return InvalidArgument("balanced cover MILP: " + std::to_string(vertex_weights.size()) + " weights for " +
                           std::to_string(n) + " scans");
  }
  if (shares.size() != static_cast<std::size_t>(graph.robot_count())) {
    return InvalidArgument("balanced cover MILP: " + std::to_string(shares.size()) + " shares for " +
                           std::to_string(graph.robot_count()) + " robots");
  }
  std::vector<int> variable_of(n, -1);
  LinearProgram lp;
  for (std::size_t v = 0; v < n; ++v) {
    if (graph.adjacency()[v].empty()) continue;  // isolated scans are never sent
    const double w = vertex_weights.empty() ? 1.0 : vertex_weights[v];
    if (!std::isfinite(w) || w <= 0.0) {
      return InvalidArgument("balanced cover MILP: weight of scan " + std::to_string(v) + " is not finite and > 0");
    }
    variable_of[v] = static_cast<int>(lp.objective.size());
    lp.objective.push_back(w);
  }
  lp.variable_lower.assign(lp.objective.size(), 0.0);
  lp.variable_upper.assign(lp.objective.size(), 1.0);
  for (const ExchangeEdge& e : graph.edges()) {
    lp.rows.push_back(LpRow{{{variable_of[static_cast<std::size_t>(e.u)], 1.0},
                             {variable_of[static_cast<std::size_t>(e.v)], 1.0}},
                            1.0,
                            kLpInfinity});
  }
  for (int r = 0; r < graph.robot_count(); ++r) {
    const int share = shares[static_cast<std::size_t>(r)];
    if (share < 0) {
      return InvalidArgument("balanced cover MILP: robot " + std::to_string(r) + " has a negative share");
    }
    if (share == 0) continue;
    LpRow row;
    for (int v = graph.robot_begin(r); v < graph.robot_begin(r) + graph.robot_size(r); ++v) {
      const int x = variable_of[static_cast<std::size_t>(v)];
      if (x >= 0) row.terms.push_back({x, 1.0});
    }
    row.lower = share;
    row.upper = kLpInfinity;
    lp.rows.push_back(std::move(row));
  }
  return lp;
}

}  // namespace commerge
