// SPDX-License-Identifier: BSD-3-Clause
// Test helpers shared by the stage-B suites (tests/core/exchange and tests/core/exchange_heavy): GLPK's
// glp_intopt on the paper's model (BalancedCoverMilp) as the reference optimum, a check of a returned selection
// against the model, and loading of the shared exchange graphs (graphs/exchange_cslam_resource).
#pragma once

#include <doctest/doctest.h>

#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include "core/common/tsv_table.hpp"
#include "core/exchange/balanced_cover_milp.hpp"
#include "core/exchange/balanced_vertex_cover.hpp"
#include "core/exchange/exchange_graph.hpp"
#include "core/solvers/dimacs_graph.hpp"
#include "core/solvers/lp_relaxation.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::test {

struct GlpkCoverOutcome {
  MipStatus status = MipStatus::kNoSolution;
  double objective = 0.0;  ///< valid for kOptimal and kFeasible
  double seconds = 0.0;
  bool optimal() const { return status == MipStatus::kOptimal; }
};

/// glp_intopt on BalancedCoverMilp(g, w, shares) with a time limit.
inline GlpkCoverOutcome GlpkCoverOptimum(const ExchangeGraph& g, const std::vector<double>& w,
                                         const std::vector<int>& shares, double time_limit_s = 60.0) {
  Result<LinearProgram> lp = BalancedCoverMilp(g, w, shares);
  REQUIRE_MESSAGE(lp.ok(), lp.status().ToString());
  MipOptions options;
  options.time_limit_s = time_limit_s;
  const auto start = std::chrono::steady_clock::now();
  Result<MipSolution> s = SolveMipWithGlpk(*lp, std::vector<bool>(lp->objective.size(), true), options);
  REQUIRE_MESSAGE(s.ok(), s.status().ToString());
  return {s->status, s->objective, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()};
}

/// The selection is a cover of every edge, meets every robot's share and weighs what the result claims.
inline void CheckCoverSelection(const ExchangeGraph& g, const std::vector<double>& w, const MultiRobotCoverResult& r) {
  std::vector<char> in(static_cast<std::size_t>(g.vertex_count()), 0);
  std::vector<int> per_robot(static_cast<std::size_t>(g.robot_count()), 0);
  double total = 0.0;
  for (int v : r.selected) {
    in[static_cast<std::size_t>(v)] = 1;
    ++per_robot[static_cast<std::size_t>(g.robot_of(v))];
    total += w.empty() ? 1.0 : w[static_cast<std::size_t>(v)];
  }
  for (const ExchangeEdge& e : g.edges()) REQUIRE((in[static_cast<std::size_t>(e.u)] || in[static_cast<std::size_t>(e.v)]));
  for (int k = 0; k < g.robot_count(); ++k) {
    REQUIRE(per_robot[static_cast<std::size_t>(k)] >= r.share_per_robot[static_cast<std::size_t>(k)]);
  }
  REQUIRE(r.objective_weight == doctest::Approx(total));
}

struct LoadedExchangeGraph {
  ExchangeGraph graph;
  std::vector<double> weights;  ///< the file's vertex weights (empty without "n" lines)
};

inline LoadedExchangeGraph LoadExchangeGraph(const std::string& path, const std::string& name) {
  Result<DimacsGraph> d = ParseDimacsGraph(ReadTextFile(path), name);
  REQUIRE_MESSAGE(d.ok(), d.status().ToString());
  Result<ExchangeGraph> g = ExchangeGraph::FromDimacs(*d, name);
  REQUIRE_MESSAGE(g.ok(), g.status().ToString());
  return {std::move(*g), std::move(d->vertex_weights)};
}

/// Rows of exchange_graphs.tsv with an optimum: (name, opt_mwvc). The index also lists kitti00_radius_r30 with
/// "NA" everywhere (its edge file is absent from the snapshot, README); such rows are skipped.
inline std::vector<std::pair<std::string, double>> ReadExchangeGraphIndex(const std::string& tsv_path) {
  std::vector<std::pair<std::string, double>> rows;
  for (const TsvRow& row : ParseTsvTable(ReadTextFile(tsv_path))) {
    const auto name = row.find("name");
    const auto opt = row.find("opt_mwvc");
    REQUIRE_MESSAGE((name != row.end() && opt != row.end()), tsv_path << ": a row lacks name or opt_mwvc");
    if (opt->second == "NA") continue;
    rows.emplace_back(name->second, std::stod(opt->second));
  }
  return rows;
}

}  // namespace commerge::test
