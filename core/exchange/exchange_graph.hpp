// SPDX-License-Identifier: BSD-3-Clause
// commerge stage B: the N-robot exchange graph. Vertices are scans (keyframes); robot r owns the contiguous block
// of vertex ids [robot_begin(r), robot_begin(r) + robot_size(r)); an edge is a candidate inter-robot loop closure
// and always joins scans of two different robots. With two robots the graph is bipartite (the paper's exchange
// graph); with N > 2 robots it is N-partite and in general not bipartite (odd cycles through three robots).
// Vertex weights are not part of the graph: they are a parameter of the cover (BalancedCoverParams).
#pragma once

#include <string>
#include <vector>

#include "core/common/status.hpp"
#include "core/solvers/bipartite_matching.hpp"
#include "core/solvers/dimacs_graph.hpp"

namespace commerge {

/// An undirected candidate loop between global vertex ids `u` and `v` of two different robots.
struct ExchangeEdge {
  int u = 0;
  int v = 0;
};

class ExchangeGraph {
 public:
  ExchangeGraph() = default;

  /// Builds the graph. `robot_vertex_counts[r]` >= 0 is the number of scans of robot r (a robot may have none;
  /// zero robots give an empty graph). InvalidArgument when a count is negative, the total exceeds 2^30, an edge
  /// index is out of range, or an edge joins two scans of the same robot (including self-loops). Duplicate edges
  /// are allowed (the adjacency lists hold each neighbour once).
  static Result<ExchangeGraph> Create(std::vector<int> robot_vertex_counts, std::vector<ExchangeEdge> edges);

  /// The two-robot exchange graph of a bipartite graph: robot 0 = left vertices (ids 0..L-1), robot 1 = right
  /// vertices (ids L..L+R-1).
  static Result<ExchangeGraph> FromBipartite(const BipartiteGraph& graph);

  /// The exchange graph of a parsed DIMACS file whose robots are given by its "c bipartite" / "c robots" comment
  /// (DimacsGraph::block_sizes). InvalidArgument naming `source_name` when the file has no robot blocks or an
  /// edge joins two scans of one robot. The file's vertex weights stay in the DimacsGraph.
  static Result<ExchangeGraph> FromDimacs(const DimacsGraph& dimacs, const std::string& source_name);

  int robot_count() const noexcept { return static_cast<int>(robot_sizes_.size()); }
  int vertex_count() const noexcept { return vertex_count_; }
  int robot_begin(int r) const noexcept { return robot_begins_[static_cast<std::size_t>(r)]; }
  int robot_size(int r) const noexcept { return robot_sizes_[static_cast<std::size_t>(r)]; }
  /// Robot owning vertex v (0 <= v < vertex_count()).
  int robot_of(int v) const noexcept { return robot_of_[static_cast<std::size_t>(v)]; }
  /// The edges as given (duplicates kept).
  const std::vector<ExchangeEdge>& edges() const noexcept { return edges_; }
  /// Sorted, duplicate-free neighbours of each vertex.
  const std::vector<std::vector<int>>& adjacency() const noexcept { return adjacency_; }

 private:
  int vertex_count_ = 0;
  std::vector<int> robot_begins_;
  std::vector<int> robot_sizes_;
  std::vector<int> robot_of_;
  std::vector<ExchangeEdge> edges_;
  std::vector<std::vector<int>> adjacency_;
};

/// Size of a maximum-cardinality matching of the exchange graph (N_MM of the paper). When the graph is bipartite
/// (always for two robots; for N robots when it has no odd cycle) this is Hopcroft-Karp on a 2-colouring, else
/// Edmonds' blossom algorithm for general graphs. Never fails on a graph built by Create().
int MaximumMatchingSize(const ExchangeGraph& graph);

}  // namespace commerge
