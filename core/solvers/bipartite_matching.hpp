// SPDX-License-Identifier: BSD-3-Clause
// commerge: maximum-cardinality bipartite matching (Hopcroft-Karp) and the minimum vertex cover that König's
// theorem derives from it. Used by stage B (balanced vertex cover of the exchange graph) as a lower bound.
#pragma once

#include <cstddef>
#include <vector>

#include "core/common/status.hpp"

namespace commerge {

/// An undirected edge between left vertex `left` (0..left_count-1) and right vertex `right` (0..right_count-1).
struct BipartiteEdge {
  int left = 0;
  int right = 0;
};

/// A bipartite graph with validated vertex indices. Duplicate edges are allowed (they change nothing).
class BipartiteGraph {
 public:
  BipartiteGraph() = default;

  /// Builds the graph; InvalidArgument when a count is negative or an edge index is out of range.
  static Result<BipartiteGraph> Create(int left_count, int right_count, std::vector<BipartiteEdge> edges);

  int left_count() const noexcept { return left_count_; }
  int right_count() const noexcept { return right_count_; }
  const std::vector<BipartiteEdge>& edges() const noexcept { return edges_; }
  /// For each left vertex, its right neighbours (in edge order, duplicates kept).
  const std::vector<std::vector<int>>& left_adjacency() const noexcept { return left_adjacency_; }
  /// For each right vertex, its left neighbours (in edge order, duplicates kept).
  const std::vector<std::vector<int>>& right_adjacency() const noexcept { return right_adjacency_; }

 private:
  int left_count_ = 0;
  int right_count_ = 0;
  std::vector<BipartiteEdge> edges_;
  std::vector<std::vector<int>> left_adjacency_;
  std::vector<std::vector<int>> right_adjacency_;
};

/// Checkerboard grid graph, a benchmark family of known structure: the cells of a rows x cols grid, black cells
/// ((r + c) even) on the left and white cells on the right, each side numbered row-major; one edge per pair of
/// 4-neighbours, listed by black cell in row-major order (up, down, left, right). InvalidArgument unless
/// rows, cols >= 1 and rows * cols <= 2^24.
Result<BipartiteGraph> MakeCheckerboardGridGraph(int rows, int cols);

/// A matching: mate_of_left[i] is the right vertex matched to left i (or -1), mate_of_right likewise.
struct Matching {
  std::vector<int> mate_of_left;
  std::vector<int> mate_of_right;
  int size = 0;  ///< number of matched pairs
};

/// A vertex cover: sorted left and right vertex indices.
struct VertexCover {
  std::vector<int> left;
  std::vector<int> right;
  std::size_t size() const noexcept { return left.size() + right.size(); }
};

/// Maximum-cardinality matching by Hopcroft-Karp, O(E sqrt(V)). Never fails on a graph built by Create().
Result<Matching> HopcroftKarp(const BipartiteGraph& graph);

/// Minimum vertex cover from a maximum matching (König): Z = vertices reachable from unmatched left vertices
/// by alternating paths; cover = (left \ Z) ∪ (right ∩ Z). InvalidArgument when `matching` does not fit the graph,
/// is inconsistent, uses a non-edge, or is not maximum (then the construction does not yield a cover).
Result<VertexCover> KonigVertexCover(const BipartiteGraph& graph, const Matching& matching);

}  // namespace commerge
