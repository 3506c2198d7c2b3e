// SPDX-License-Identifier: BSD-3-Clause
// commerge: maximum clique by our own branch-and-bound over a dense bitset graph, for three objectives:
// cardinality (DIMACS max clique), vertex weights (MWC) and edge weights (MEWC, stage C of the cascade:
// paper "Maximum Edge-Weighted Clique Selection"). Upper bounds come from greedy colourings (a colour class
// is an independent set, so a clique takes at most one vertex of it); the search keeps the best clique found
// so far, honours a node and a wall-clock limit, and reports optimal or the proven gap.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/status.hpp"

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
};

enum class CliqueSearchStatus {
  kOptimal,       ///< the clique is proven optimal (upper_bound == objective)
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
  /// Relative gap (upper_bound - objective) / max(upper_bound, 1e-12); 0 when optimal.
  double gap() const noexcept;
};

/// Maximum clique under params.objective. Ties between optimal cliques are broken deterministically (the same
/// graph gives the same clique). With kEdgeWeight and no edge of positive weight, the result is a single vertex
/// (objective 0). Errors: InvalidArgument for bad params (time_limit_s not > 0, max_nodes < 1) or kEdgeWeight on a
/// graph without edge weights; ResourceExhausted when the search buffers cannot be allocated. The search works on
/// a renumbered copy of the adjacency (n^2 / 8 bytes) plus per-depth candidate bitsets and lists.
Result<CliqueSearchResult> SolveMaxClique(const CliqueGraph& graph, const CliqueSearchParams& params);

}  // namespace commerge
