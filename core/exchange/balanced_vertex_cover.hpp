// SPDX-License-Identifier: BSD-3-Clause
// commerge stage B: balanced vertex cover (BVC) of the exchange graph (paper, "Balanced Vertex Cover in Exchange
// Graph", eqs. mwvc, mvc and balanced). Choose the scans to transmit so that every candidate loop edge has a selected
// endpoint, the total transmission cost is minimal, and each robot contributes at least a minimum share of scans.
//
// Model (our definitions, where the paper leaves room):
//  * Objective: total vertex weight. Default unit weights (the paper's MVC, "vertex count as a robust proxy");
//    optional per-scan weights w_x (finite, > 0) give the paper's MWVC objective.
//  * Candidates: only scans with at least one candidate loop (non-isolated vertices) can be selected or count
//    towards a share. Isolated scans are never selected.
//  * Share: a COUNT of scans, also with weights: share = ceil(N_MM / 2^H(p)) (1e-9 round-off tolerance), with
//    H(p) the base-2 entropy of the participation vector p over all N robots (default uniform 1/N). Every robot
//    with at least one candidate gets this share; a robot without candidates gets none. A robot with fewer
//    candidates than the share must send ALL its candidates (its share is clamped to its candidate count) - the
//    formula would otherwise make the problem infeasible for small robots, which the paper never intends. With
//    two robots the clamp never applies (N_MM <= the candidates of either side). An explicit
//    min_share_per_robot_override is applied literally (no clamp): kInfeasible when a robot has fewer candidates.
//  * N_MM: the size of a maximum matching of the exchange graph. For two robots (bipartite) it equals the
//    unweighted minimum vertex cover size (König), the paper's "tight lower bound" N_vertex = N_MM. For N > 2
//    the graph is not bipartite and we keep the literal definition - the maximum matching of the general graph
//    (Edmonds' blossom algorithm) - rather than the minimum cover size: it is polynomial and exact (it never
//    depends on a solver limit), it is still a lower bound on the number of scans any cover sends
//    (nu <= tau <= 2 nu), it coincides with the two-robot definition whenever the graph is bipartite, and it
//    does not depend on the weights, like the share itself.
//
// Solver: our own best-first branch-and-bound (exact; optimality within 1e-9 relative for non-integer weights).
//  * Bound of a node = the LP relaxation with the balance rows, computed without a general LP engine by
//    Dantzig-Wolfe column generation: the pricing problem is a weighted vertex cover with Lagrangian costs
//    w_x - lambda_robot, solved exactly by max-flow/min-cut (core/solvers/min_cut.hpp) on the bipartite graph (or
//    on the bipartite double cover of non-bipartite components, which yields the half-integral vertex-cover LP).
//    The master LP (convexity + one row per robot short of its share) is GLPK's primal simplex on a problem kept
//    between solves and nodes (core/solvers GlpkColumnLp: a new column enters non-basic, a child node starts
//    from its parent's support columns in the basis), or our dense simplex (MasterLpEngine::kDense), or a
//    caller-supplied LpSolver. Without a balance row a bipartite node is solved exactly by a single min-cut, so the unbalanced
//    weighted cover (share 0) costs one max-flow. The pricing multipliers are smoothed towards the best ones so
//    far (Wentges stabilisation), starting from the parent's. One network is built per solve (rebuilt at the
//    root without the vertices its fixings remove); nodes only change capacities, and every max-flow is
//    warm-started from the previous one (or from the parent's flow when the search jumps). The LP support of a
//    node seeds its children.
//  * Reduced-cost fixing: the max-flow is an LP dual, so a vertex whose forced inclusion (or exclusion) provably
//    cannot beat the incumbent is fixed and the node re-bounded. The root's fixings hold for the whole search.
//  * Branching on the fractional vertex whose two branches both promise a large cost increase (estimated from
//    the LP point; pseudo-random among ties); nodes are explored best bound first, newest first among equal
//    bounds (a dive).
//  * Incumbents: the rounded LP point of every node (and every root pricing that raised the bound), repaired to
//    meet the shares (greedy swaps), pruned of redundant scans and improved by (1, k)-swaps.
#pragma once

#include <cstdint>
#include <vector>

#include "core/common/status.hpp"
#include "core/exchange/exchange_graph.hpp"
#include "core/solvers/bipartite_matching.hpp"
#include "core/solvers/lp_relaxation.hpp"

namespace commerge {

/// Engine of the master LP of stage B's column generation (the node bound).
enum class MasterLpEngine {
  kGlpk,   ///< GLPK's primal simplex on a problem kept between solves and nodes (GlpkColumnLp), warm-started
  kDense,  ///< our dense revised simplex over the few master rows (GLPK only when it fails numerically)
};

/// "glpk" or "dense".
const char* MasterLpEngineName(MasterLpEngine engine) noexcept;

struct BalancedCoverParams {
  /// Participation ratios, one per robot ({p_left, p_right} for the bipartite API): finite, >= 0, summing to 1
  /// (±1e-9). Empty = uniform.
  std::vector<double> participation;
  /// When >= 0, replaces ceil(N_MM / 2^H(p)) as the minimum number of selected scans of every robot that has a
  /// candidate (applied literally, see the header comment).
  int min_share_per_robot_override = -1;
  /// Branch-and-bound node limit (nodes whose bounds were evaluated). Must be >= 1. The limit that normally binds:
  /// it gives the same selection on every machine (core/agent/decisions/023-solver-node-limits.md).
  std::int64_t max_nodes = 20000;
  /// Wall-clock limit of the branch-and-bound in seconds (steady clock). Must be > 0. A safety cap: max_nodes
  /// binds first on any board (core/agent/decisions/023-solver-node-limits.md).
  double time_limit_s = 60.0;
  /// Per-scan transmission cost w_x. Empty = unit weights (the paper's default). Otherwise one finite weight > 0
  /// per vertex (summing to at most 1e100): left vertices then right vertices for the bipartite API, global
  /// vertex ids for the N-robot API.
  std::vector<double> vertex_weights;
  /// Engine of the master LPs (ignored when a caller-supplied LpSolver is passed;
  /// core/agent/decisions/021-stage-b-master-lp-engine.md).
  MasterLpEngine master_lp = MasterLpEngine::kGlpk;
};

enum class BalancedCoverStatus {
  kOptimal,              ///< selection proven optimal (objective == lower bound)
  kFeasibleWithGap,      ///< a limit was hit; selection feasible, optimum in [lower bound, objective]
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
  /// Proven lower bound on the optimum number of scans with unit weights. With vertex weights the bound is in
  /// lower_bound_weight; this field is then objective_scans when optimal and 0 otherwise.
  int lower_bound_scans = 0;
  double objective_weight = 0.0;    ///< total weight of the selection (== objective_scans with unit weights)
  double lower_bound_weight = 0.0;  ///< proven lower bound on the optimum total weight
  int max_matching_size = 0;        ///< N_MM, also the unbalanced minimum cover size (König)
  int min_share_per_robot = 0;      ///< the per-robot share used in the balance rows
  std::int64_t nodes_explored = 0;  ///< branch-and-bound nodes whose bounds were evaluated
  std::int64_t lp_solves = 0;       ///< master LPs of the column generation (+1 per node bounded by one min-cut)
  std::int64_t min_cut_solves = 0;  ///< max-flow/min-cut computations (pricing and exact leaves)
  std::int64_t simplex_iterations = 0;  ///< GLPK simplex iterations of the master LPs (kGlpk)
  std::int64_t lp_basis_rebuilds = 0;   ///< GLPK master solves not started from the kept basis (or failed: dense)
};

/// Per-robot share ceil(n_mm / 2^H(p)) (with a 1e-9 tolerance against round-off, so uniform p over two robots
/// gives exactly ceil(n_mm / 2)). An empty p means {1/2, 1/2}. InvalidArgument for a bad p or negative n_mm.
Result<int> BalancedShare(int max_matching_size, const std::vector<double>& participation);

/// Solves the BVC on `graph` (left = robot alpha's scans, right = robot beta's scans). Isolated vertices are
/// never selected and do not count towards a share. `lp_solver` = nullptr uses the built-in master simplex;
/// a supplied solver is used for the master LPs (its errors are returned).
/// Errors (InvalidArgument) only for bad params; limits and infeasibility are reported in the status.
Result<BalancedCoverResult> SolveBalancedVertexCover(const BipartiteGraph& graph, const BalancedCoverParams& params,
                                                     LpSolver* lp_solver = nullptr);

struct MultiRobotCoverResult {
  BalancedCoverStatus status = BalancedCoverStatus::kNoCandidates;
  std::vector<int> selected;               ///< sorted global vertex ids to transmit
  std::vector<int> selected_per_robot;     ///< number of selected scans of each robot
  int objective_scans = 0;                 ///< selected.size() (0 without a solution)
  double objective_weight = 0.0;           ///< total weight of the selection
  double lower_bound_weight = 0.0;         ///< proven lower bound on the optimum total weight
  int max_matching_size = 0;               ///< N_MM (maximum matching of the exchange graph)
  int min_share_per_robot = 0;             ///< ceil(N_MM / 2^H(p)) or the override
  std::vector<int> share_per_robot;        ///< share applied to each robot (0 without candidates, clamped)
  std::vector<int> candidates_per_robot;   ///< non-isolated scans of each robot
  std::int64_t nodes_explored = 0;         ///< branch-and-bound nodes whose bounds were evaluated
  std::int64_t lp_solves = 0;              ///< master LPs (+1 per node bounded by one min-cut)
  std::int64_t min_cut_solves = 0;         ///< max-flow/min-cut computations
  std::int64_t simplex_iterations = 0;     ///< GLPK simplex iterations of the master LPs (kGlpk)
  std::int64_t lp_basis_rebuilds = 0;      ///< GLPK master solves not started from the kept basis (or failed: dense)
};

/// Solves the BVC on an N-robot exchange graph (see the header comment for the model). `participation`, when
/// given, has one entry per robot. Errors (InvalidArgument) for bad params (p size or values, weights that are
/// not finite and > 0 or of the wrong count, limits); limits and infeasibility are reported in the status.
Result<MultiRobotCoverResult> SolveMultiRobotBalancedCover(const ExchangeGraph& graph,
                                                           const BalancedCoverParams& params,
                                                           LpSolver* lp_solver = nullptr);

}  // namespace commerge
