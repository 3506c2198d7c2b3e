// SPDX-License-Identifier: BSD-3-Clause
// commerge: maximum clique by our own branch-and-bound over a dense bitset graph, for three objectives:
// cardinality (DIMACS max clique), vertex weights (MWC) and edge weights (MEWC, stage C of the cascade:
// paper "Maximum Edge-Weighted Clique Selection"). Upper bounds come from greedy colourings (a colour class
// is an independent set, so a clique takes at most one vertex of it); the search keeps the best clique found
// so far, honours a node and a wall-clock limit, and reports optimal or the proven gap.
// Edge weights also get an LP bound over the whole graph (CliqueSearchParams::lp_bound, clique_lp_bound.hpp): GLPK's
// simplex on a relaxation strengthened by the root colour classes, solved once when the search has not finished
// after lp_after_nodes nodes (0: at the root). Why: the colouring bound of MEWC counts, per class, the heaviest
// edges towards every earlier class and stays far above the optimum on dense graphs, so a search stopped by a limit
// reported a loose gap; the LP bound is lower (18-41 % below the root colouring bound on random graphs, equal to
// the optimum on hamming6-2 and c-fat200-1), though mostly still well above the optimum. It caps the root's branch bounds (the search ends as soon as the incumbent reaches
// it) and the reported upper_bound. Pruning only what cannot beat the incumbent strictly, it never changes the
// clique found, only the proof.
#pragma once

#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>

#include "core/common/status.hpp"
#include "core/solvers/clique_lp_bound.hpp"

namespace commerge {

/// Largest graph accepted: the adjacency bitsets take n^2 / 8 bytes (32 MiB at the limit).
inline constexpr int kMaxCliqueVertices = 16384;
/// Largest graph with edge weights: a dense float matrix of n^2 x 4 bytes (64 MiB at the limit).
inline constexpr int kMaxEdgeWeightedCliqueVertices = 4096;

/// Undirected simple graph for the clique search: dense bitset adjacency, vertex weights (default 1) and,
/// when created with edge weights, a dense symmetric weight matrix (non-edges weigh 0).
class CliqueGraph {
 public:
  CliqueGraph() = default;
  /// InvalidArgument when num_vertices < 0, > kMaxCliqueVertices, or > kMaxEdgeWeightedCliqueVertices with
  /// edge weights. ResourceExhausted when the allocation fails.
  static Result<CliqueGraph> Create(int num_vertices, bool with_edge_weights);

  /// Adds {u, v} (idempotent; a repeated edge overwrites its weight). InvalidArgument for u == v, an index out
  /// of range, or (with edge weights) a weight that is negative, not finite or above the float range (weights are
  /// stored as float). `weight` is ignored (not checked) without edge weights.
  Status AddEdge(int u, int v, double weight = 1.0);
  /// InvalidArgument for an index out of range or a negative / non-finite weight.
  Status SetVertexWeight(int v, double weight);

  int num_vertices() const noexcept { return n_; }
  std::size_t num_edges() const noexcept { return num_edges_; }
  bool has_edge_weights() const noexcept { return edge_weighted_; }
  /// False for u == v and for indices out of range.
  bool HasEdge(int u, int v) const noexcept;
  double vertex_weight(int v) const noexcept { return vertex_weight_[static_cast<std::size_t>(v)]; }
  /// Weight of edge {u, v}: 0 for a non-edge (or indices out of range), 1 for an edge of a graph without edge
  /// weights; edge weights are stored as float.
  double edge_weight(int u, int v) const noexcept;
  /// Bytes held by this graph (bitsets, weights).
  std::size_t MemoryBytes() const noexcept;

  // Raw access for the search: row v of the adjacency, words_per_row() 64-bit words.
  std::size_t words_per_row() const noexcept { return words_; }
  const std::uint64_t* adjacency_row(int v) const noexcept { return adjacency_.data() + static_cast<std::size_t>(v) * words_; }
  const float* edge_weight_row(int v) const noexcept { return edge_weight_.data() + static_cast<std::size_t>(v) * static_cast<std::size_t>(n_); }

 private:
  int n_ = 0;
  std::size_t words_ = 0;
  std::size_t num_edges_ = 0;
  bool edge_weighted_ = false;
  std::vector<std::uint64_t> adjacency_;
  std::vector<double> vertex_weight_;
  std::vector<float> edge_weight_;
};

enum class CliqueObjective {
  kCardinality,   ///< number of vertices (weights ignored)
  kVertexWeight,  ///< sum of the clique's vertex weights
  kEdgeWeight,    ///< sum of the weights of the clique's edges (needs a graph with edge weights)
};

struct CliqueSearchParams {
  CliqueObjective objective = CliqueObjective::kEdgeWeight;
  /// Wall-clock limit (steady clock) in seconds, > 0. The best clique found so far is returned at the limit.
  double time_limit_s = 5.0;
  /// Limit on branch-and-bound nodes, >= 1.
  std::int64_t max_nodes = 100'000'000;
  /// kEdgeWeight only: solve the LP relaxation of clique_lp_bound.hpp once (whole graph, the root's colour
  /// classes) and use it as an upper bound on the optimum (ignored for the other objectives). Its time counts
  /// against time_limit_s (it is not started past the deadline, but a solve is not interrupted); the clique found
  /// is the same with or without it.
  bool lp_bound = true;
  /// The LP is solved once the search has expanded this many nodes without finishing (>= 0; 0 or 1: at the root,
  /// before the first branch), or when a node limit stops the search earlier (the certificate of the gap it
  /// reports). A search that finishes earlier never pays for it. Why not at
  /// the root: one solve takes 3 ms-4 s on the 28-500-vertex DIMACS graphs (GLPK's primal simplex on a degenerate
  /// LP) where most searches end in under 15 ms, and the LP bound, though below the root colouring bound, is rarely
  /// close enough to the optimum to end a search (profiling/bench_max_clique.cpp; core/README.md, stage C). Why
  /// 1 000 000: at 100 000 the LP ran on johnson16-2-4 (316 647 nodes, 0.11 s) and made it 1.2 s, for no gain.
  std::int64_t lp_after_nodes = 1'000'000;
  /// Coefficient budget of that LP (>= 0). Above it the LP is retried without the non-edge rows, and skipped
  /// (lp_status kTooLarge) when still above.
  std::int64_t lp_max_nonzeros = kDefaultCliqueLpMaxNonzeros;
};

enum class CliqueSearchStatus {
  kOptimal,       ///< the clique is proven optimal (upper_bound == objective; within 1e-9 relative when the LP
                  ///< bound is what proves it)
  kLimitReached,  ///< a limit stopped the search: best clique so far, optimum in [objective, upper_bound]
  kEmptyGraph,    ///< no vertex: empty clique
};

const char* CliqueSearchStatusName(CliqueSearchStatus status) noexcept;

struct CliqueSearchResult {
  CliqueSearchStatus status = CliqueSearchStatus::kEmptyGraph;
  std::vector<int> clique;        ///< sorted vertex indices; never empty for a non-empty graph
  double objective = 0.0;         ///< value of `clique` under the requested objective
  double upper_bound = 0.0;       ///< proven upper bound on the optimum
  std::int64_t nodes = 0;         ///< branch-and-bound nodes expanded
  /// LP bound on the optimum (kEdgeWeight with lp_bound, computed after lp_after_nodes nodes); NaN when not
  /// computed (see lp_status: kNotRun also when the search ended or stopped before lp_after_nodes).
  double lp_bound = std::numeric_limits<double>::quiet_NaN();
  CliqueLpStatus lp_status = CliqueLpStatus::kNotRun;
  int lp_solves = 0;  ///< LP engine calls (simplex solves)
  /// Relative gap (upper_bound - objective) / max(upper_bound, 1e-12); 0 when optimal.
  double gap() const noexcept;
};

/// Maximum clique under params.objective. Ties between optimal cliques are broken deterministically (the same
/// graph gives the same clique). With kEdgeWeight and no edge of positive weight, the result is a single vertex
/// (objective 0). Errors: InvalidArgument for bad params (time_limit_s not > 0, max_nodes < 1, lp_after_nodes or
/// lp_max_nonzeros < 0)
/// or kEdgeWeight on a graph without edge weights; ResourceExhausted when the search buffers cannot be allocated.
/// An LP engine failure is not an error: the search goes on without the LP bound (lp_status kFailed). The search
/// works on a renumbered copy of the adjacency (n^2 / 8 bytes) plus per-depth candidate bitsets and lists; the root
/// LP (kEdgeWeight) on at most lp_max_nonzeros coefficients, freed before the search.
Result<CliqueSearchResult> SolveMaxClique(const CliqueGraph& graph, const CliqueSearchParams& params);

}  // namespace commerge
