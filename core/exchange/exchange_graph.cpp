// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/exchange_graph.hpp"

#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>

namespace commerge {
namespace {

constexpr std::int64_t kMaxExchangeVertices = std::int64_t{1} << 30;

// 2-colours every component by BFS; false when some component has an odd cycle.
bool TwoColour(const std::vector<std::vector<int>>& adj, std::vector<int>* colour) {
  const std::size_t n = adj.size();
  colour->assign(n, -1);
  std::vector<int> queue;
  for (std::size_t s = 0; s < n; ++s) {
    if ((*colour)[s] >= 0) continue;
    (*colour)[s] = 0;
    queue.assign(1, static_cast<int>(s));
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const int v = queue[head];
      for (int w : adj[static_cast<std::size_t>(v)]) {
        int& cw = (*colour)[static_cast<std::size_t>(w)];
        if (cw < 0) {
          cw = 1 - (*colour)[static_cast<std::size_t>(v)];
          queue.push_back(w);
        } else if (cw == (*colour)[static_cast<std::size_t>(v)]) {
          return false;
        }
      }
    }
  }
  return true;
}

// Edmonds' blossom algorithm (maximum-cardinality matching of a general graph): one alternating-tree search per
// exposed vertex, contracting odd cycles by relabelling their vertices with the blossom base. Per-search state is
// reset only where the search touched it, so a search costs O(tree size x blossoms + scanned edges), not O(n).
class BlossomMatcher {
 public:
  explicit BlossomMatcher(const std::vector<std::vector<int>>& adj)
      : adj_(adj),
        n_(adj.size()),
        mate_(n_, -1),
        parent_(n_, -1),
        base_(n_, 0),
        in_tree_(n_, 0),
        touched_flag_(n_, 0),
        path_mark_(n_, 0),
        blossom_mark_(n_, 0) {
    for (std::size_t i = 0; i < n_; ++i) base_[i] = static_cast<int>(i);
  }

  int Solve() {
    int size = 0;
    for (std::size_t v = 0; v < n_; ++v) {  // greedy start
      if (mate_[v] >= 0) continue;
      for (int w : adj_[v]) {
        if (mate_[static_cast<std::size_t>(w)] < 0) {
          mate_[v] = w;
          mate_[static_cast<std::size_t>(w)] = static_cast<int>(v);
          ++size;
          break;
        }
      }
    }
    // A vertex that has no augmenting path now never gets one later, so one pass over the roots suffices.
    for (std::size_t root = 0; root < n_; ++root) {
      if (mate_[root] >= 0 || adj_[root].empty()) continue;
      int v = FindAugmentingPath(static_cast<int>(root));
      if (v >= 0) {
        while (v >= 0) {  // flip the path root ... parent_[v] - v
          const int pv = parent_[static_cast<std::size_t>(v)];
          const int next = mate_[static_cast<std::size_t>(pv)];
          mate_[static_cast<std::size_t>(v)] = pv;
          mate_[static_cast<std::size_t>(pv)] = v;
          v = next;
        }
        ++size;
      }
      Reset();
    }
    return size;
  }

 private:
  void Touch(int v) {
    if (!touched_flag_[static_cast<std::size_t>(v)]) {
      touched_flag_[static_cast<std::size_t>(v)] = 1;
      touched_.push_back(v);
    }
  }
  void Reset() {
    for (int v : touched_) {
      parent_[static_cast<std::size_t>(v)] = -1;
      base_[static_cast<std::size_t>(v)] = v;
      in_tree_[static_cast<std::size_t>(v)] = 0;
      touched_flag_[static_cast<std::size_t>(v)] = 0;
    }
    touched_.clear();
  }

  int Lca(int a, int b) {
    ++path_stamp_;
    while (true) {
      a = base_[static_cast<std::size_t>(a)];
      path_mark_[static_cast<std::size_t>(a)] = path_stamp_;
      if (mate_[static_cast<std::size_t>(a)] < 0) break;
      a = parent_[static_cast<std::size_t>(mate_[static_cast<std::size_t>(a)])];
    }
    while (true) {
      b = base_[static_cast<std::size_t>(b)];
      if (path_mark_[static_cast<std::size_t>(b)] == path_stamp_) return b;
      b = parent_[static_cast<std::size_t>(mate_[static_cast<std::size_t>(b)])];
    }
  }

  void MarkPath(int v, int b, int child) {
    while (base_[static_cast<std::size_t>(v)] != b) {
      const int m = mate_[static_cast<std::size_t>(v)];
      blossom_mark_[static_cast<std::size_t>(base_[static_cast<std::size_t>(v)])] = blossom_stamp_;
      blossom_mark_[static_cast<std::size_t>(base_[static_cast<std::size_t>(m)])] = blossom_stamp_;
      parent_[static_cast<std::size_t>(v)] = child;
      Touch(v);
      child = m;
      v = parent_[static_cast<std::size_t>(m)];
    }
  }

  // Returns the exposed end vertex of an augmenting path from `root` (path recorded in parent_/mate_), or -1.
  int FindAugmentingPath(int root) {
    in_tree_[static_cast<std::size_t>(root)] = 1;  // in_tree_ marks the even (outer) vertices
    Touch(root);
    queue_.assign(1, root);
    for (std::size_t head = 0; head < queue_.size(); ++head) {
      const int v = queue_[head];
      for (int to : adj_[static_cast<std::size_t>(v)]) {
        if (base_[static_cast<std::size_t>(v)] == base_[static_cast<std::size_t>(to)] ||
            mate_[static_cast<std::size_t>(v)] == to) {
          continue;
        }
        const int mt = mate_[static_cast<std::size_t>(to)];
        if (to == root || (mt >= 0 && parent_[static_cast<std::size_t>(mt)] >= 0)) {
          // `to` is outer too: the tree paths close an odd cycle; contract it into its base. Every vertex of the
          // cycle lies on a tree path, so it has been touched.
          const int cur = Lca(v, to);
          ++blossom_stamp_;
          MarkPath(v, cur, to);
          MarkPath(to, cur, v);
          const std::size_t touched = touched_.size();
          for (std::size_t t = 0; t < touched; ++t) {
            const auto i = static_cast<std::size_t>(touched_[t]);
            if (blossom_mark_[static_cast<std::size_t>(base_[i])] == blossom_stamp_) {
              base_[i] = cur;
              if (!in_tree_[i]) {
                in_tree_[i] = 1;
                queue_.push_back(static_cast<int>(i));
              }
            }
          }
        } else if (parent_[static_cast<std::size_t>(to)] < 0) {
          parent_[static_cast<std::size_t>(to)] = v;
          Touch(to);
          if (mt < 0) return to;
          in_tree_[static_cast<std::size_t>(mt)] = 1;
          Touch(mt);
          queue_.push_back(mt);
        }
      }
    }
    return -1;
  }

  const std::vector<std::vector<int>>& adj_;
  std::size_t n_;
  std::vector<int> mate_;
  std::vector<int> parent_;
  std::vector<int> base_;
  std::vector<char> in_tree_;
  std::vector<char> touched_flag_;
  std::vector<int> touched_;
  std::vector<std::uint64_t> path_mark_;
  std::vector<std::uint64_t> blossom_mark_;
  std::uint64_t path_stamp_ = 0;
  std::uint64_t blossom_stamp_ = 0;
  std::vector<int> queue_;
};

}  // namespace

Result<ExchangeGraph> ExchangeGraph::Create(std::vector<int> robot_vertex_counts, std::vector<ExchangeEdge> edges) {
  ExchangeGraph g;
  std::int64_t total = 0;
  for (std::size_t r = 0; r < robot_vertex_counts.size(); ++r) {
    const int count = robot_vertex_counts[r];
    if (count < 0) {
      return InvalidArgument("exchange graph: robot " + std::to_string(r) + " has a negative scan count (" +
                             std::to_string(count) + ")");
    }
    g.robot_begins_.push_back(static_cast<int>(total));
    total += count;
    if (total > kMaxExchangeVertices) return InvalidArgument("exchange graph: more than 2^30 scans");
  }
  g.vertex_count_ = static_cast<int>(total);
  g.robot_sizes_ = std::move(robot_vertex_counts);
  g.robot_of_.resize(static_cast<std::size_t>(total));
  for (std::size_t r = 0; r < g.robot_sizes_.size(); ++r) {
    std::fill_n(g.robot_of_.begin() + g.robot_begins_[r], g.robot_sizes_[r], static_cast<int>(r));
  }
  g.adjacency_.assign(static_cast<std::size_t>(total), {});
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const ExchangeEdge& e = edges[k];
    if (e.u < 0 || e.u >= g.vertex_count_ || e.v < 0 || e.v >= g.vertex_count_) {
      return InvalidArgument("exchange graph: edge " + std::to_string(k) + " (" + std::to_string(e.u) + ", " +
                             std::to_string(e.v) + ") is outside 0.." + std::to_string(g.vertex_count_ - 1));
    }
    const int ru = g.robot_of_[static_cast<std::size_t>(e.u)];
    if (ru == g.robot_of_[static_cast<std::size_t>(e.v)]) {
      return InvalidArgument("exchange graph: edge " + std::to_string(k) + " (" + std::to_string(e.u) + ", " +
                             std::to_string(e.v) + ") joins two scans of robot " + std::to_string(ru) +
                             "; candidate loops are inter-robot only");
    }
    g.adjacency_[static_cast<std::size_t>(e.u)].push_back(e.v);
    g.adjacency_[static_cast<std::size_t>(e.v)].push_back(e.u);
  }
  for (auto& nb : g.adjacency_) {
    std::sort(nb.begin(), nb.end());
    nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
  }
  g.edges_ = std::move(edges);
  return g;
}

Result<ExchangeGraph> ExchangeGraph::FromBipartite(const BipartiteGraph& graph) {
  std::vector<ExchangeEdge> edges;
  edges.reserve(graph.edges().size());
  for (const BipartiteEdge& e : graph.edges()) edges.push_back({e.left, graph.left_count() + e.right});
  return Create({graph.left_count(), graph.right_count()}, std::move(edges));
}

Result<ExchangeGraph> ExchangeGraph::FromDimacs(const DimacsGraph& dimacs, const std::string& source_name) {
  if (dimacs.block_sizes.empty()) {
    return InvalidArgument(source_name + ": no robot blocks (a \"c bipartite NA NB\" or \"c robots K n1 .. nK\" "
                           "comment), so it is not an exchange graph");
  }
  std::vector<ExchangeEdge> edges;
  edges.reserve(dimacs.edges.size());
  for (const auto& [u, v] : dimacs.edges) edges.push_back({u, v});
  Result<ExchangeGraph> g = Create(dimacs.block_sizes, std::move(edges));
  if (!g.ok()) return InvalidArgument(source_name + ": " + g.status().message());
  return g;
}

int MaximumMatchingSize(const ExchangeGraph& graph) {
  const auto& adj = graph.adjacency();
  std::vector<int> colour;
  if (TwoColour(adj, &colour)) {
    std::vector<int> index(adj.size(), 0);
    int left = 0;
    int right = 0;
    for (std::size_t v = 0; v < adj.size(); ++v) index[v] = colour[v] == 0 ? left++ : right++;
    std::vector<BipartiteEdge> edges;
    for (std::size_t v = 0; v < adj.size(); ++v) {
      if (colour[v] != 0) continue;
      for (int w : adj[v]) edges.push_back({index[v], index[static_cast<std::size_t>(w)]});
    }
    Result<BipartiteGraph> bg = BipartiteGraph::Create(left, right, std::move(edges));
    if (bg.ok()) {
      Result<Matching> mm = HopcroftKarp(*bg);
      if (mm.ok()) return mm->size;
    }
  }
  return BlossomMatcher(adj).Solve();
}

}  // namespace commerge
