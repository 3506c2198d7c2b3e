// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/edge_weighted_clique.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <string>

namespace commerge {
namespace {

bool Contains(Span<const int> sorted, std::size_t index) {
  return std::binary_search(sorted.begin(), sorted.end(), static_cast<int>(index));
}

}  // namespace

const char* StageCLoopSetName(StageCLoopSet set) noexcept {
  switch (set) {
    case StageCLoopSet::kBothEndpointsSelected: return "both-endpoints-selected";
    case StageCLoopSet::kAnyEndpointSelected: return "any-endpoint-selected";
    case StageCLoopSet::kBothEndpointsElseAny: return "both-endpoints-else-any";
  }
  return "unknown";
}

namespace {

// Keeps the `cap` loops of smallest descriptor distance (ties: L_seq order), in L_seq order.
void KeepNearest(std::size_t cap, std::vector<SequentialLoopCell>* loops) {
  if (loops->size() <= cap) return;
  std::vector<std::size_t> order(loops->size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t x, std::size_t y) { return (*loops)[x].distance < (*loops)[y].distance; });
  order.resize(cap);
  std::sort(order.begin(), order.end());
  std::vector<SequentialLoopCell> kept;
  kept.reserve(cap);
  for (std::size_t i : order) kept.push_back((*loops)[i]);
  loops->swap(kept);
}

}  // namespace

Status ValidateStageCParams(const StageCParams& params) {
  if (!std::isfinite(params.tau_con_m) || params.tau_con_m <= 0.0) {
    return InvalidArgument("stage C: tau_con_m must be > 0 and finite, got " + std::to_string(params.tau_con_m));
  }
  if (params.max_loops < 1 || params.max_loops > kMaxEdgeWeightedCliqueVertices) {
    return InvalidArgument("stage C: max_loops must be in 1.." + std::to_string(kMaxEdgeWeightedCliqueVertices) +
                           ", got " + std::to_string(params.max_loops));
  }
  if (!(params.time_limit_s > 0.0) || !std::isfinite(params.time_limit_s)) {
    return InvalidArgument("stage C: time_limit_s must be > 0 and finite");
  }
  if (params.max_nodes < 1) return InvalidArgument("stage C: max_nodes must be >= 1");
  if (params.fallback_max_loops < 1) {
    return InvalidArgument("stage C: fallback_max_loops must be >= 1, got " + std::to_string(params.fallback_max_loops));
  }
  return Status::Ok();
}

double PositionalConsistency(const Eigen::Vector3d& alpha_c1, const Eigen::Vector3d& alpha_c2,
                             const Eigen::Vector3d& beta_q1, const Eigen::Vector3d& beta_q2) noexcept {
  return std::abs((alpha_c1 - alpha_c2).norm() - (beta_q1 - beta_q2).norm());
}

double CompatibilityScore(double w1, double kappa, double w2) noexcept { return std::exp(-w1 * kappa * w2); }

Result<CliqueGraph> BuildCompatibilityGraph(Span<const SequentialLoopCell> loops,
                                            Span<const Eigen::Vector3d> alpha_positions_m,
                                            Span<const Eigen::Vector3d> beta_positions_m, double tau_con_m) {
  if (loops.size() > static_cast<std::size_t>(kMaxEdgeWeightedCliqueVertices)) {
    return InvalidArgument("compatibility graph: " + std::to_string(loops.size()) + " loops exceed the limit of " +
                           std::to_string(kMaxEdgeWeightedCliqueVertices));
  }
  for (std::size_t i = 0; i < loops.size(); ++i) {
    const SequentialLoopCell& l = loops[i];
    if (l.alpha_index >= alpha_positions_m.size() || l.beta_index >= beta_positions_m.size()) {
      return InvalidArgument("compatibility graph: loop " + std::to_string(i) + " (" + std::to_string(l.alpha_index) +
                             ", " + std::to_string(l.beta_index) + ") has no pose (alpha has " +
                             std::to_string(alpha_positions_m.size()) + ", beta " +
                             std::to_string(beta_positions_m.size()) + " positions)");
    }
    if (!alpha_positions_m[l.alpha_index].allFinite() || !beta_positions_m[l.beta_index].allFinite() ||
        !std::isfinite(l.distance) || l.distance < 0.0f) {
      return InvalidArgument("compatibility graph: loop " + std::to_string(i) +
                             " has a non-finite position or descriptor distance");
    }
  }
  const int n = static_cast<int>(loops.size());
  auto graph = CliqueGraph::Create(n, /*with_edge_weights=*/true);
  if (!graph.ok()) return graph.status();
  for (int a = 0; a < n; ++a) {
    const SequentialLoopCell& la = loops[static_cast<std::size_t>(a)];
    const Eigen::Vector3d& pa_alpha = alpha_positions_m[la.alpha_index];
    const Eigen::Vector3d& pa_beta = beta_positions_m[la.beta_index];
    for (int b = a + 1; b < n; ++b) {
      const SequentialLoopCell& lb = loops[static_cast<std::size_t>(b)];
      const double kappa = PositionalConsistency(pa_alpha, alpha_positions_m[lb.alpha_index], pa_beta,
                                                 beta_positions_m[lb.beta_index]);
      if (!(kappa < tau_con_m)) continue;
      const double xi = CompatibilityScore(static_cast<double>(la.distance), kappa, static_cast<double>(lb.distance));
      Status s = graph->AddEdge(a, b, xi);
      if (!s.ok()) return s;
    }
  }
  return graph;
}

Result<StageCResult> RunStageC(Span<const SequentialLoopCell> l_seq, Span<const int> alpha_selected,
                               Span<const int> beta_selected, Span<const Eigen::Vector3d> alpha_positions_m,
                               Span<const Eigen::Vector3d> beta_positions_m, const StageCParams& params) {
  if (Status s = ValidateStageCParams(params); !s.ok()) return s;
  if (!std::is_sorted(alpha_selected.begin(), alpha_selected.end()) ||
      !std::is_sorted(beta_selected.begin(), beta_selected.end())) {
    return InvalidArgument("stage C: the selected keyframe lists must be sorted");
  }
  StageCResult result;
  std::vector<SequentialLoopCell> in_set;
  const auto collect = [&](bool both) {
    for (const SequentialLoopCell& l : l_seq) {
      const bool a = Contains(alpha_selected, l.alpha_index);
      const bool b = Contains(beta_selected, l.beta_index);
      if (both ? (a && b) : (a || b)) in_set.push_back(l);
    }
  };
  const bool any_only = params.loop_set == StageCLoopSet::kAnyEndpointSelected;
  collect(!any_only);
  std::size_t cap = static_cast<std::size_t>(params.max_loops);
  if (in_set.empty() && params.loop_set == StageCLoopSet::kBothEndpointsElseAny) {
    collect(false);
    result.any_endpoint_fallback = !in_set.empty();
    cap = std::min(cap, static_cast<std::size_t>(params.fallback_max_loops));
  }
  result.loops_in_set = in_set.size();
  if (in_set.empty()) {
    result.no_candidate_reason = l_seq.empty() ? "stage A found no loops"
                                 : any_only    ? "no loop of stage A has an endpoint selected by stage B"
                                 : params.loop_set == StageCLoopSet::kBothEndpointsSelected
                                     ? "no loop of stage A has both endpoints selected by stage B"
                                     : "no loop of stage A has both endpoints, or an endpoint, selected by stage B";
    return result;
  }
  if (in_set.size() > cap) {
    result.loops_dropped = in_set.size() - cap;
    KeepNearest(cap, &in_set);
  }
  auto graph = BuildCompatibilityGraph(in_set, alpha_positions_m, beta_positions_m, params.tau_con_m);
  if (!graph.ok()) return graph.status();
  result.compatible_pairs = graph->num_edges();
  CliqueSearchParams clique_params;
  clique_params.objective = CliqueObjective::kEdgeWeight;
  clique_params.time_limit_s = params.time_limit_s;
  clique_params.max_nodes = params.max_nodes;
  auto clique = SolveMaxClique(*graph, clique_params);
  if (!clique.ok()) return clique.status();
  result.clique = std::move(*clique);
  if (result.compatible_pairs == 0) {
    // No two loops are compatible: every single loop is an optimal clique (f_K = 0). Take the most similar one
    // (smallest descriptor distance, first in L_seq order on ties) rather than an arbitrary vertex.
    std::size_t best = 0;
    for (std::size_t i = 1; i < in_set.size(); ++i) {
      if (in_set[i].distance < in_set[best].distance) best = i;
    }
    result.clique.clique.assign(1, static_cast<int>(best));
  }
  for (int v : result.clique.clique) result.selected_loops.push_back(in_set[static_cast<std::size_t>(v)]);
  result.candidate_loops = std::move(in_set);
  return result;
}

}  // namespace commerge
