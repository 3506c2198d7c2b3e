// SPDX-License-Identifier: BSD-3-Clause
#include "core/solvers/bipartite_matching.hpp"

#include <algorithm>
#include <limits>
#include <string>
#include <utility>

namespace commerge {

Result<BipartiteGraph> BipartiteGraph::Create(int left_count, int right_count, std::vector<BipartiteEdge> edges) {
  if (left_count < 0 || right_count < 0) {
    return InvalidArgument("bipartite graph: negative vertex count (left " + std::to_string(left_count) +
                           ", right " + std::to_string(right_count) + ")");
  }
  BipartiteGraph g;
  g.left_count_ = left_count;
  g.right_count_ = right_count;
  g.left_adjacency_.assign(static_cast<std::size_t>(left_count), {});
  g.right_adjacency_.assign(static_cast<std::size_t>(right_count), {});
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const BipartiteEdge& e = edges[k];
    if (e.left < 0 || e.left >= left_count || e.right < 0 || e.right >= right_count) {
      return InvalidArgument("bipartite graph: edge " + std::to_string(k) + " (" + std::to_string(e.left) + ", " +
                             std::to_string(e.right) + ") is outside " + std::to_string(left_count) + " x " +
                             std::to_string(right_count) + " vertices");
    }
    g.left_adjacency_[static_cast<std::size_t>(e.left)].push_back(e.right);
    g.right_adjacency_[static_cast<std::size_t>(e.right)].push_back(e.left);
  }
  g.edges_ = std::move(edges);
  return g;
}

Result<Matching> HopcroftKarp(const BipartiteGraph& graph) {
  const int n = graph.left_count();
  const int m = graph.right_count();
  const auto& adj = graph.left_adjacency();
  constexpr int kInf = std::numeric_limits<int>::max();
  Matching mt;
  mt.mate_of_left.assign(static_cast<std::size_t>(n), -1);
  mt.mate_of_right.assign(static_cast<std::size_t>(m), -1);
  std::vector<int> dist(static_cast<std::size_t>(n), kInf);
  std::vector<int> queue;
  std::vector<std::size_t> next_edge(static_cast<std::size_t>(n), 0);
  std::vector<int> stack;
  queue.reserve(static_cast<std::size_t>(n));

  // Greedy initial matching (cheap, halves the phases in practice).
  for (int u = 0; u < n; ++u) {
    for (int v : adj[static_cast<std::size_t>(u)]) {
      if (mt.mate_of_right[static_cast<std::size_t>(v)] < 0) {
        mt.mate_of_left[static_cast<std::size_t>(u)] = v;
        mt.mate_of_right[static_cast<std::size_t>(v)] = u;
        ++mt.size;
        break;
      }
    }
  }

  while (true) {
    // BFS layers from the free left vertices.
    queue.clear();
    for (int u = 0; u < n; ++u) {
      if (mt.mate_of_left[static_cast<std::size_t>(u)] < 0) {
        dist[static_cast<std::size_t>(u)] = 0;
        queue.push_back(u);
      } else {
        dist[static_cast<std::size_t>(u)] = kInf;
      }
    }
    bool found = false;
    for (std::size_t head = 0; head < queue.size(); ++head) {
      const int u = queue[head];
      for (int v : adj[static_cast<std::size_t>(u)]) {
        const int w = mt.mate_of_right[static_cast<std::size_t>(v)];
        if (w < 0) {
          found = true;
        } else if (dist[static_cast<std::size_t>(w)] == kInf) {
          dist[static_cast<std::size_t>(w)] = dist[static_cast<std::size_t>(u)] + 1;
          queue.push_back(w);
        }
      }
    }
    if (!found) break;

    // Iterative layered DFS from every free left vertex.
    std::fill(next_edge.begin(), next_edge.end(), 0);
    int augmented = 0;
    for (int root = 0; root < n; ++root) {
      if (mt.mate_of_left[static_cast<std::size_t>(root)] >= 0) continue;
      stack.clear();
      stack.push_back(root);
      while (!stack.empty()) {
        const int u = stack.back();
        const auto& nbrs = adj[static_cast<std::size_t>(u)];
        std::size_t& it = next_edge[static_cast<std::size_t>(u)];
        if (it >= nbrs.size()) {
          dist[static_cast<std::size_t>(u)] = kInf;  // dead end for this phase
          stack.pop_back();
          continue;
        }
        const int v = nbrs[it];
        const int w = mt.mate_of_right[static_cast<std::size_t>(v)];
        if (w < 0) {
          // Augment along the stack: each left vertex takes the right vertex its edge cursor points at.
          for (int x : stack) {
            const int vx = adj[static_cast<std::size_t>(x)][next_edge[static_cast<std::size_t>(x)]];
            mt.mate_of_left[static_cast<std::size_t>(x)] = vx;
            mt.mate_of_right[static_cast<std::size_t>(vx)] = x;
          }
          ++augmented;
          break;
        }
        if (dist[static_cast<std::size_t>(w)] != kInf &&
            dist[static_cast<std::size_t>(w)] == dist[static_cast<std::size_t>(u)] + 1) {
          stack.push_back(w);  // keep u's cursor on v until w's subtree is exhausted
        } else {
          ++it;
        }
      }
    }
    if (augmented == 0) break;  // cannot happen when found == true; guards against an endless loop
    mt.size += augmented;
  }
  return mt;
}

Result<VertexCover> KonigVertexCover(const BipartiteGraph& graph, const Matching& matching) {
  const int n = graph.left_count();
  const int m = graph.right_count();
  if (matching.mate_of_left.size() != static_cast<std::size_t>(n) ||
      matching.mate_of_right.size() != static_cast<std::size_t>(m)) {
    return InvalidArgument("König cover: matching has " + std::to_string(matching.mate_of_left.size()) + " x " +
                           std::to_string(matching.mate_of_right.size()) + " mates, graph has " +
                           std::to_string(n) + " x " + std::to_string(m) + " vertices");
  }
  const auto& adj = graph.left_adjacency();
  int pairs = 0;
  for (int u = 0; u < n; ++u) {
    const int v = matching.mate_of_left[static_cast<std::size_t>(u)];
    if (v < 0) continue;
    if (v >= m || matching.mate_of_right[static_cast<std::size_t>(v)] != u) {
      return InvalidArgument("König cover: inconsistent mates at left vertex " + std::to_string(u));
    }
    const auto& nbrs = adj[static_cast<std::size_t>(u)];
    if (std::find(nbrs.begin(), nbrs.end(), v) == nbrs.end()) {
      return InvalidArgument("König cover: matched pair (" + std::to_string(u) + ", " + std::to_string(v) +
                             ") is not an edge");
    }
    ++pairs;
  }
  for (int v = 0; v < m; ++v) {
    const int u = matching.mate_of_right[static_cast<std::size_t>(v)];
    if (u >= 0 && (u >= n || matching.mate_of_left[static_cast<std::size_t>(u)] != v)) {
      return InvalidArgument("König cover: inconsistent mates at right vertex " + std::to_string(v));
    }
  }
  if (pairs != matching.size) {
    return InvalidArgument("König cover: matching.size " + std::to_string(matching.size) + " but " +
                           std::to_string(pairs) + " matched pairs");
  }

  std::vector<char> left_reached(static_cast<std::size_t>(n), 0);
  std::vector<char> right_reached(static_cast<std::size_t>(m), 0);
  std::vector<int> queue;
  for (int u = 0; u < n; ++u) {
    if (matching.mate_of_left[static_cast<std::size_t>(u)] < 0) {
      left_reached[static_cast<std::size_t>(u)] = 1;
      queue.push_back(u);
    }
  }
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const int u = queue[head];
    for (int v : adj[static_cast<std::size_t>(u)]) {
      if (v == matching.mate_of_left[static_cast<std::size_t>(u)] || right_reached[static_cast<std::size_t>(v)]) {
        continue;
      }
      right_reached[static_cast<std::size_t>(v)] = 1;
      const int w = matching.mate_of_right[static_cast<std::size_t>(v)];
      if (w >= 0 && !left_reached[static_cast<std::size_t>(w)]) {
        left_reached[static_cast<std::size_t>(w)] = 1;
        queue.push_back(w);
      }
    }
  }
  VertexCover cover;
  for (int u = 0; u < n; ++u) {
    if (!left_reached[static_cast<std::size_t>(u)]) cover.left.push_back(u);
  }
  for (int v = 0; v < m; ++v) {
    if (right_reached[static_cast<std::size_t>(v)]) cover.right.push_back(v);
  }
  if (cover.size() != static_cast<std::size_t>(matching.size)) {
    return InvalidArgument("König cover: the matching (size " + std::to_string(matching.size) +
                           ") is not maximum; an augmenting path exists");
  }
  return cover;
}

Result<BipartiteGraph> MakeCheckerboardGridGraph(int rows, int cols) {
  if (rows < 1 || cols < 1 || static_cast<long long>(rows) * cols > (1LL << 24)) {
    return InvalidArgument("checkerboard grid graph: need rows, cols >= 1 and rows * cols <= 2^24, got " +
                           std::to_string(rows) + " x " + std::to_string(cols));
  }
  const auto cell = [cols](int r, int c) { return static_cast<std::size_t>(r) * static_cast<std::size_t>(cols) + static_cast<std::size_t>(c); };
  std::vector<int> id(static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols));
  int black = 0, white = 0;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) id[cell(r, c)] = (r + c) % 2 == 0 ? black++ : white++;
  std::vector<BipartiteEdge> edges;
  const int dr[4] = {-1, 1, 0, 0};
  const int dc[4] = {0, 0, -1, 1};
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if ((r + c) % 2 != 0) continue;
      for (int k = 0; k < 4; ++k) {
        const int r2 = r + dr[k], c2 = c + dc[k];
        if (r2 >= 0 && r2 < rows && c2 >= 0 && c2 < cols) edges.push_back({id[cell(r, c)], id[cell(r2, c2)]});
      }
    }
  }
  return BipartiteGraph::Create(black, white, std::move(edges));
}

}  // namespace commerge
