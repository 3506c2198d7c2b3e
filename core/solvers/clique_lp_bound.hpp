// SPDX-License-Identifier: BSD-3-Clause
// commerge: an upper bound on the maximum edge-weighted clique (MEWC, stage C) from a linear-programming
// relaxation solved by GLPK's simplex (through `LpSolver`). Our branch and bound (max_clique.hpp) bounds by greedy
// colourings only; this LP bounds the whole graph at once, so it can prove a greedy incumbent optimal at the root
// and it caps the gap reported when a node or time limit stops the search.
//
// Model over a vertex subset V' (K is a clique of V'; the objective is what SolveMaxClique's kEdgeWeight counts,
// the edge weights of K, vertex weights ignored, plus an optional linear gain g_v per vertex for sub-problems):
//   maximise   sum_v g_v x_v + sum_{uv in E+} w_uv y_uv        E+ = edges of V' with w_uv > 0
//   s.t.       sum_{v in S, uv in E+} y_uv <= x_u               (vertex u, colour class S holding a positive
//                                                                neighbour of u: a clique containing u takes at
//                                                                most one vertex of the independent set S; a
//                                                                neighbour in no class is a class of its own,
//                                                                y_uv <= x_u: the basic model, without colour rows)
//              sum_{v in S} x_v <= 1                            (colour class S with >= 2 vertices)
//              x_u + sum_{v in S, v !~ u} x_v <= 1              (vertex u, class S after u's own holding
//                                                                non-neighbours of u: they and u are independent)
//              x_u + x_v <= 1                                   (u, v non-adjacent, both in no class: the basic
//                                                                model's clique rows)
//              0 <= x, y <= 1
// Every clique K (x = indicator of K, y_uv = x_u x_v) is feasible, so the LP optimum bounds the MEWC optimum.
// Vertices without a positive edge and without gain get no column (they cannot add to the objective).
// The colour classes are the caller's (SolveMaxClique passes its root colouring) or a greedy colouring.
//
// Validity under floating point: the bound is not GLPK's primal objective (accurate only to its tolerances,
// 1e-7) but a dual certificate: for any multipliers mu >= 0 of the <= rows A z <= b and the box 0 <= z <= 1,
//   c^T z <= b^T mu + sum_j max(0, c_j - (A^T mu)_j)   for every feasible z,
// whatever the accuracy of mu. We take mu = -(GLPK's row duals of the minimisation), clipped at 0, and add a
// safety margin for the rounding of that sum: 2 (rows + columns + 8) * DBL_EPSILON * (sum of the absolute values
// of every term), about 1e-11 of the bound for a 10 000-column model. When all weights and gains are integers
// (and the bound is below 2^52), the optimum is an integer and the bound is rounded down. An engine that gives
// no duals falls back to its primal objective plus a relative margin of 1e-6 (then `certified` is false).
//
// Size: the model is counted before anything is allocated; above `max_nonzeros` matrix coefficients it is not
// built and the result says kTooLarge (upper_bound = +inf). GLPK allocates internally (roughly 100 bytes per
// coefficient) and its primal simplex is slow on this degenerate LP, faster in the rows than in the coefficients:
// measured with a greedy colouring (loaded 2-core machine), hamming6-4 3 200 coefficients 0.1 s, johnson8-4-4
// 5 900 0.35 s, c-fat200-1 23 600 0.6 s, c-fat200-2 29 200 4.6 s, keller4 31 500 7.4 s, brock200_2 39 200 55 s
// (solving the dual LP instead was no faster). The default budget, 20 000, keeps a solve to about a second; the
// solve cannot be interrupted, so this budget is also the bound on how far it can overrun a caller's time limit.
#pragma once

#include <cstdint>
#include <limits>
#include <vector>

#include "core/common/status.hpp"
#include "core/solvers/lp_relaxation.hpp"

namespace commerge {

class CliqueGraph;  // core/solvers/max_clique.hpp (which includes this header for CliqueLpStatus)

/// Default limit on the LP's matrix coefficients (nonzeros).
inline constexpr std::int64_t kDefaultCliqueLpMaxNonzeros = 20'000;

/// Colour classes (independent sets) of a vertex subset: the vertices of class c are
/// vertices[class_start[c] .. class_start[c + 1] - 1] (graph vertex ids). class_start has num_classes() + 1 entries.
struct CliqueColouring {
  std::vector<int> vertices;
  std::vector<int> class_start{0};
  int num_classes() const noexcept { return static_cast<int>(class_start.size()) - 1; }
};

/// Sequential greedy colouring of `vertices` (in decreasing degree inside the subset, ties by position): each vertex
/// joins the first class holding none of its neighbours. O(|vertices|^2) adjacency tests. Entries of `vertices`
/// outside the graph are ignored.
CliqueColouring GreedyCliqueColouring(const CliqueGraph& graph, const std::vector<int>& vertices);

struct CliqueLpBoundParams {
  /// Non-edge rows: x_u + sum of x over u's non-neighbours in a later class <= 1 per vertex u and class, and
  /// x_u + x_v <= 1 for non-adjacent u, v in no class (every non-adjacent pair without colour rows). Together with
  /// the class rows they imply x_u + x_v <= 1 for every non-adjacent pair, in about n x classes rows rather than
  /// one per pair (GLPK's simplex time grows with the rows: a row per pair took 37 s on c-fat500-1).
  bool non_edge_rows = true;
  /// Class rows, and neighbour rows per class instead of one row y_uv <= x_u per edge end, from the colour classes
  /// (the given colouring, or a greedy one when none). Off: the basic model.
  bool colour_rows = true;
  /// The model is refused (kTooLarge, nothing allocated) above this many matrix coefficients; >= 0.
  std::int64_t max_nonzeros = kDefaultCliqueLpMaxNonzeros;
};

enum class CliqueLpStatus {
  kNotRun,    ///< not computed (SolveMaxClique: not kEdgeWeight, LP off, or the search ended before lp_after_nodes)
  kOptimal,   ///< LP solved; upper_bound is valid (certified by the duals unless `certified` is false)
  kTrivial,   ///< no positive edge and no positive gain in the subset: upper_bound = 0 without an LP
  kTooLarge,  ///< the model exceeds max_nonzeros: not built, upper_bound = +inf
  kFailed,    ///< the LP engine failed (SolveMaxClique only: it then searches without the LP bound)
};

const char* CliqueLpStatusName(CliqueLpStatus status) noexcept;

struct CliqueLpBoundResult {
  CliqueLpStatus status = CliqueLpStatus::kNotRun;
  /// Upper bound on max over cliques K of the subset of sum_{v in K} g_v + sum_{uv in K} w_uv; +inf when not solved.
  double upper_bound = std::numeric_limits<double>::infinity();
  /// The LP optimum the engine reported (maximisation sense), before certification; 0 when kTrivial, NaN when not
  /// solved.
  double lp_objective = std::numeric_limits<double>::quiet_NaN();
  bool certified = false;        ///< upper_bound comes from the dual certificate (else primal + 1e-6 margin)
  bool integer_rounded = false;  ///< all weights were integers and upper_bound was rounded down
  int rows = 0;                  ///< LP rows (also counted, not built, when kTooLarge)
  int columns = 0;               ///< LP columns
  std::int64_t nonzeros = 0;     ///< matrix coefficients
  int colour_classes = 0;        ///< classes used for class and neighbour rows (0 without colour rows)
  int simplex_solves = 0;        ///< LP engine calls
};

/// The model above as a minimisation (objective negated) for any LP/MIP engine: columns 0..num_vertex_columns-1
/// are x (vertex_of_column gives the graph vertex), the others y. Used by ComputeCliqueLpBound and, with x
/// integer, by the tests as the exact MIP of the same model.
struct CliqueLpModel {
  LinearProgram lp;
  std::vector<int> vertex_of_column;  ///< graph vertex of x column j (j < num_vertex_columns)
  int num_vertex_columns = 0;
  std::int64_t nonzeros = 0;
  int colour_classes = 0;
  bool too_large = false;  ///< nonzeros > max_nonzeros: `lp` is empty (rows/columns below are the counts)
  int rows = 0;
  int columns = 0;
};

/// Builds the model for `vertices` (distinct graph vertices) with optional per-vertex gains (`vertex_gain`
/// empty = 0, else one finite value per entry of `vertices`) and optional colour classes (`colouring` null: a
/// greedy colouring when params.colour_rows). Errors: InvalidArgument for a graph without edge weights, a
/// vertex out of range or repeated, a gain vector of the wrong size or not finite, a colouring with a vertex
/// outside `vertices` or repeated, or a class that is not independent, or max_nonzeros < 0.
Result<CliqueLpModel> BuildCliqueLpModel(const CliqueGraph& graph, const std::vector<int>& vertices,
                                         const std::vector<double>& vertex_gain, const CliqueColouring* colouring,
                                         const CliqueLpBoundParams& params);

/// Upper bound on the maximum edge-weighted clique of `vertices` (plus gains) by the LP above, solved by
/// `solver`. Errors: those of BuildCliqueLpModel, the engine's errors, and Internal when the engine calls the LP
/// infeasible or unbounded (it is neither: z = 0 is feasible and the box bounds it).
Result<CliqueLpBoundResult> ComputeCliqueLpBound(const CliqueGraph& graph, const std::vector<int>& vertices,
                                                 const std::vector<double>& vertex_gain,
                                                 const CliqueColouring* colouring, LpSolver* solver,
                                                 const CliqueLpBoundParams& params = {});

/// Whole graph, no gains, greedy colouring, GLPK's simplex.
Result<CliqueLpBoundResult> ComputeCliqueLpBound(const CliqueGraph& graph, const CliqueLpBoundParams& params = {});

}  // namespace commerge
