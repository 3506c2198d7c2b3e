// SPDX-License-Identifier: BSD-3-Clause
// commerge: minimum-weight vertex cover of a bipartite graph with real vertex weights, by max-flow / min-cut.
// Network: source -> left vertex (capacity = its weight), left -> right along every edge (infinite), right vertex
// -> sink (capacity = its weight). A minimum s-t cut is a minimum-weight cover: the left vertices not reachable
// from the source in the residual network plus the right vertices that are. Used by stage B for exact weighted
// covers and for Lagrangian bounds (the network is built once and solved for many weight vectors, each solve
// starting from the previous flow). Maximum flow: augmenting paths searched locally from each left vertex with
// spare capacity (cheap when few capacities changed), then Dinic when many long paths remain.
#pragma once

#include <cstdint>
#include <utility>
#include <vector>

#include "core/common/status.hpp"

namespace commerge {

class BipartiteCoverFlow {
 public:
  /// (Re)builds the network for `left_count` + `right_count` vertices and `edges` (left index, right index);
  /// vertex ids of Solve() are left i -> i, right j -> left_count + j. Reuses the allocated memory.
  /// InvalidArgument on a negative count or an edge index out of range (the object is then empty).
  Status Assign(int left_count, int right_count, const std::vector<std::pair<int, int>>& edges);

  /// Minimum-weight cover for `weights` (left_count + right_count entries, finite and >= 0). Returns the
  /// maximum-flow value, a lower bound on every cover's weight that equals the returned cover's weight up to
  /// floating-point round-off; `in_cover` receives one 0/1 flag per vertex. InvalidArgument on bad weights.
  /// `start_flow` (optional, one value per edge in Assign() order, e.g. EdgeFlows() of an earlier solve with other
  /// weights) warm-starts the maximum flow: it is first reduced edge by edge until it fits the new capacities.
  /// Any start gives the same optimum value; a good one saves most of the augmenting work.
  Result<double> Solve(const std::vector<double>& weights, std::vector<char>* in_cover,
                       const std::vector<double>* start_flow = nullptr);

  /// Like Solve(), but starts from the current flow of this network (the result of the previous Solve() or
  /// Resolve()), reduced where the new capacities are smaller: cheap when the weights change little, e.g. the
  /// Lagrangian costs of successive column-generation steps. Same as Solve() when there is no previous flow.
  Result<double> Resolve(const std::vector<double>& weights, std::vector<char>* in_cover);

  /// After a successful Solve() or Resolve(): the flow on each edge, in Assign() order.
  void EdgeFlows(std::vector<double>* flows) const;

  /// After a successful Solve() or Resolve(): the residual capacity of vertex v's terminal arc (source -> v for a left vertex,
  /// v -> sink for a right one), i.e. its weight minus the flow through it. For a vertex outside the returned
  /// cover this is its LP reduced cost: any cover containing v weighs at least the flow value plus this amount.
  double TerminalResidual(int v) const;

  int left_count() const noexcept { return left_count_; }
  int right_count() const noexcept { return right_count_; }
  /// Dinic phases (blocking-flow rounds) of the last Solve() or Resolve(): a work measure (0 when the local
  /// augmenting-path searches sufficed).
  std::int64_t last_phases() const noexcept { return last_phases_; }

 private:
  void Send(int arc, double f);  // pushes f along `arc` (and returns it on the reverse arc)
  // Augmenting paths by breadth-first searches from single left vertices; false when it gave up on its work
  // budget (the flow is then valid but not maximum). On success level_ marks the nodes reachable from the source.
  bool AugmentLocally();
  void Dinic();  // completes the maximum flow; level_ then marks the nodes reachable from the source
  bool BuildLevels();
  Status CheckWeights(const std::vector<double>& weights);  // also sets eps_
  Result<double> MaxFlowAndCut(const std::vector<double>& weights, std::vector<char>* in_cover);

  int left_count_ = 0;
  int right_count_ = 0;
  int node_count_ = 0;  // left + right + source + sink
  // CSR arcs: arcs of node x are [first_[x], first_[x+1]); each arc holds its residual capacity, head node and
  // paired reverse arc together (one cache line fetch per arc in the searches).
  struct Arc {
    double cap = 0.0;
    int head = 0;
    int rev = 0;
  };
  std::vector<int> first_;
  std::vector<Arc> arcs_;
  std::vector<double> base_cap_;  // capacity of the middle arcs (infinite) and 0 for reverse arcs
  std::vector<int> edge_arc_;     // per edge: its forward (left -> right) arc
  std::vector<int> level_;
  std::vector<int> cursor_;
  std::vector<int> queue_;
  std::vector<int> stack_;
  std::vector<int> parent_;          // per node: the arc a local search reached it by
  std::vector<std::uint32_t> seen_;  // per node: stamp of the last local search that reached it
  std::uint32_t stamp_ = 0;
  double eps_ = 0.0;
  bool has_flow_ = false;  // arcs_ hold a feasible flow of the current network
  std::int64_t last_phases_ = 0;
};

}  // namespace commerge
