// SPDX-License-Identifier: BSD-3-Clause
// commerge stage B: balanced vertex cover (BVC) of the two-robot exchange graph (paper, "Balanced Vertex Cover in
// Exchange Graph"). Minimise the number of transmitted scans such that every candidate loop edge has a selected
// endpoint and each robot contributes at least ceil(N_MM / 2^H(p)) scans, where N_MM is the maximum matching size
// and H(p) the base-2 Shannon entropy of the participation vector p. Solved exactly by our own branch-and-bound:
// König and LP-relaxation (GLPK simplex) lower bounds, greedy/repair incumbents, node and time limits.
#pragma once

#include <cstdint>
#include <vector>

#include "core/common/status.hpp"
#include "core/solvers/bipartite_matching.hpp"
#include "core/solvers/lp_relaxation.hpp"

namespace commerge {

struct BalancedCoverParams {
  /// Participation ratios {p_left_robot, p_right_robot}: non-negative, summing to 1 (±1e-9). Empty = uniform {1/2, 1/2}.
  std::vector<double> participation;
  /// When >= 0, replaces ceil(N_MM / 2^H(p)) as the minimum number of selected scans per robot.
  int min_share_per_robot_override = -1;
  /// Branch-and-bound node limit (nodes whose bounds were evaluated). Must be >= 1.
  std::int64_t max_nodes = 200000;
  /// Wall-clock limit of the branch-and-bound in seconds (steady clock). Must be > 0.
  double time_limit_s = 5.0;
};

enum class BalancedCoverStatus {
  kOptimal,              ///< selection proven optimal (objective == lower_bound)
  kFeasibleWithGap,      ///< a limit was hit; selection feasible, optimum in [lower_bound, objective]
  kInfeasible,           ///< no cover meets the per-robot share (only possible with an override share)
  kLimitWithoutSolution, ///< a limit was hit before any feasible selection was found
  kNoCandidates,         ///< the graph has no edge: nothing needs to be sent (empty selection)
};

/// Name of a status ("optimal", ...).
const char* BalancedCoverStatusName(BalancedCoverStatus status) noexcept;

struct BalancedCoverResult {
  BalancedCoverStatus status = BalancedCoverStatus::kNoCandidates;
  std::vector<int> selected_left;   ///< sorted scan (vertex) indices of the left robot to transmit
  std::vector<int> selected_right;  ///< sorted scan (vertex) indices of the right robot to transmit
  int objective_scans = 0;          ///< selected_left.size() + selected_right.size() (0 without a solution)
  int lower_bound_scans = 0;        ///< proven lower bound on the optimum
  int max_matching_size = 0;        ///< N_MM, also the unbalanced minimum cover size (König)
  int min_share_per_robot = 0;      ///< the per-robot share used in the balance rows
  std::int64_t nodes_explored = 0;  ///< branch-and-bound nodes whose bounds were evaluated
  std::int64_t lp_solves = 0;       ///< LP relaxations solved
};

/// Per-robot share ceil(n_mm / 2^H(p)) (with a 1e-9 tolerance against round-off, so uniform p over two robots
/// gives exactly ceil(n_mm / 2)). InvalidArgument for a bad p or negative n_mm.
Result<int> BalancedShare(int max_matching_size, const std::vector<double>& participation);

/// Solves the BVC on `graph` (left = robot alpha's scans, right = robot beta's scans). Isolated vertices are
/// never selected and do not count towards a share. `lp_solver` = nullptr uses a GlpkSimplexSolver.
/// Errors (InvalidArgument) only for bad params; limits and infeasibility are reported in the status.
Result<BalancedCoverResult> SolveBalancedVertexCover(const BipartiteGraph& graph, const BalancedCoverParams& params,
                                                     LpSolver* lp_solver = nullptr);

}  // namespace commerge
