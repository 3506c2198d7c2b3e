// SPDX-License-Identifier: BSD-3-Clause
// Hopcroft-Karp and König: matching size vs a brute-force maximum matching, König cover validity and minimality
// vs a brute-force minimum cover, on thousands of seeded random small bipartite graphs; input validation.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdlib>
#include <utility>
#include <random>
#include <vector>

#include "core/solvers/bipartite_matching.hpp"

namespace commerge {
namespace {

// Maximum matching by DP over left vertices and the bitmask of used right vertices.
int BruteForceMatching(int n, int m, const std::vector<unsigned>& right_mask_of_left) {
  std::vector<int> best(static_cast<std::size_t>(1) << m, 0);  // best[mask] after processing a prefix
  for (int u = n - 1; u >= 0; --u) {
    std::vector<int> next(best.size(), 0);
    for (unsigned mask = 0; mask < best.size(); ++mask) {
      int b = best[mask];  // u unmatched
      for (int v = 0; v < m; ++v) {
        if ((right_mask_of_left[static_cast<std::size_t>(u)] >> v & 1U) && !(mask >> v & 1U)) {
          b = std::max(b, 1 + best[mask | (1U << v)]);
        }
      }
      next[mask] = b;
    }
    best.swap(next);
  }
  return best[0];
}

int BruteForceMinCover(int n, int m, const std::vector<unsigned>& right_mask_of_left) {
  int best = n + m;
  for (unsigned lmask = 0; lmask < (1U << n); ++lmask) {
    unsigned need = 0;  // right vertices forced by unselected left vertices
    for (int u = 0; u < n; ++u) {
      if (!(lmask >> u & 1U)) need |= right_mask_of_left[static_cast<std::size_t>(u)];
    }
    best = std::min(best, __builtin_popcount(lmask) + __builtin_popcount(need));
  }
  return best;
}

struct RandomGraph {
  BipartiteGraph graph;
  std::vector<unsigned> masks;
};

RandomGraph MakeRandom(std::mt19937& rng) {
  std::uniform_int_distribution<int> size(0, 7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = size(rng);
  const int m = size(rng);
  const double density = unit(rng);
  RandomGraph rgraph;
  rgraph.masks.assign(static_cast<std::size_t>(n), 0U);
  std::vector<BipartiteEdge> edges;
  for (int u = 0; u < n; ++u) {
    for (int v = 0; v < m; ++v) {
      if (unit(rng) < density) {
        edges.push_back({u, v});
        if (unit(rng) < 0.1) edges.push_back({u, v});  // duplicates are allowed
        rgraph.masks[static_cast<std::size_t>(u)] |= 1U << v;
      }
    }
  }
  std::shuffle(edges.begin(), edges.end(), rng);
  Result<BipartiteGraph> g = BipartiteGraph::Create(n, m, edges);
  REQUIRE(g.ok());
  rgraph.graph = std::move(*g);
  return rgraph;
}

bool IsMatching(const BipartiteGraph& g, const Matching& mt) {
  int pairs = 0;
  for (int u = 0; u < g.left_count(); ++u) {
    const int v = mt.mate_of_left[static_cast<std::size_t>(u)];
    if (v < 0) continue;
    if (mt.mate_of_right[static_cast<std::size_t>(v)] != u) return false;
    const auto& nb = g.left_adjacency()[static_cast<std::size_t>(u)];
    if (std::find(nb.begin(), nb.end(), v) == nb.end()) return false;
    ++pairs;
  }
  return pairs == mt.size;
}

bool IsCover(const BipartiteGraph& g, const VertexCover& c) {
  std::vector<char> l(static_cast<std::size_t>(g.left_count()), 0), r(static_cast<std::size_t>(g.right_count()), 0);
  for (int u : c.left) l[static_cast<std::size_t>(u)] = 1;
  for (int v : c.right) r[static_cast<std::size_t>(v)] = 1;
  for (const BipartiteEdge& e : g.edges()) {
    if (!l[static_cast<std::size_t>(e.left)] && !r[static_cast<std::size_t>(e.right)]) return false;
  }
  return true;
}

TEST_CASE("Hopcroft-Karp matches brute force and König cover is minimum on 4000 random graphs") {
  std::mt19937 rng(20240601U);
  int nonempty = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    RandomGraph rg = MakeRandom(rng);
    Result<Matching> mt = HopcroftKarp(rg.graph);
    REQUIRE(mt.ok());
    REQUIRE(IsMatching(rg.graph, *mt));
    const int brute = BruteForceMatching(rg.graph.left_count(), rg.graph.right_count(), rg.masks);
    REQUIRE(mt->size == brute);
    Result<VertexCover> cover = KonigVertexCover(rg.graph, *mt);
    REQUIRE(cover.ok());
    REQUIRE(IsCover(rg.graph, *cover));
    REQUIRE(static_cast<int>(cover->size()) == mt->size);
    REQUIRE(static_cast<int>(cover->size()) ==
            BruteForceMinCover(rg.graph.left_count(), rg.graph.right_count(), rg.masks));
    if (!rg.graph.edges().empty()) ++nonempty;
  }
  CHECK(nonempty > 2500);
}

TEST_CASE("Hopcroft-Karp on structured graphs: perfect chain, complete bipartite, star, empty") {
  std::vector<BipartiteEdge> chain;
  const int n = 500;
  for (int i = 0; i < n; ++i) {
    chain.push_back({i, i});
    if (i + 1 < n) chain.push_back({i + 1, i});
  }
  Result<BipartiteGraph> g = BipartiteGraph::Create(n, n, chain);
  REQUIRE(g.ok());
  Result<Matching> mt = HopcroftKarp(*g);
  REQUIRE(mt.ok());
  CHECK(mt->size == n);
  Result<VertexCover> c = KonigVertexCover(*g, *mt);
  REQUIRE(c.ok());
  CHECK(IsCover(*g, *c));

  std::vector<BipartiteEdge> k;
  for (int u = 0; u < 6; ++u)
    for (int v = 0; v < 9; ++v) k.push_back({u, v});
  g = BipartiteGraph::Create(6, 9, k);
  REQUIRE(g.ok());
  mt = HopcroftKarp(*g);
  REQUIRE(mt.ok());
  CHECK(mt->size == 6);
  c = KonigVertexCover(*g, *mt);
  REQUIRE(c.ok());
  CHECK(c->left.size() == 6);
  CHECK(c->right.empty());

  g = BipartiteGraph::Create(1, 50, {});
  REQUIRE(g.ok());
  mt = HopcroftKarp(*g);
  REQUIRE(mt.ok());
  CHECK(mt->size == 0);
  c = KonigVertexCover(*g, *mt);
  REQUIRE(c.ok());
  CHECK(c->size() == 0);

  g = BipartiteGraph::Create(0, 0, {});
  REQUIRE(g.ok());
  mt = HopcroftKarp(*g);
  REQUIRE(mt.ok());
  CHECK(mt->size == 0);
}

TEST_CASE("BipartiteGraph and König reject bad input") {
  CHECK(BipartiteGraph::Create(-1, 2, {}).status().code() == StatusCode::kInvalidArgument);
  CHECK(BipartiteGraph::Create(2, 2, {{0, 2}}).status().code() == StatusCode::kInvalidArgument);
  CHECK(BipartiteGraph::Create(2, 2, {{-1, 0}}).status().code() == StatusCode::kInvalidArgument);
  CHECK(BipartiteGraph::Create(2, 2, {{2, 0}}).status().code() == StatusCode::kInvalidArgument);

  Result<BipartiteGraph> g = BipartiteGraph::Create(2, 2, {{0, 0}, {0, 1}, {1, 0}});
  REQUIRE(g.ok());
  Matching wrong_size;
  CHECK(KonigVertexCover(*g, wrong_size).status().code() == StatusCode::kInvalidArgument);
  Matching not_maximum{{0, -1}, {0, -1}, 1};  // (0,1),(1,0) is larger
  CHECK(KonigVertexCover(*g, not_maximum).status().code() == StatusCode::kInvalidArgument);
  Matching non_edge{{-1, 1}, {-1, 1}, 1};  // (1,1) is not an edge
  CHECK(KonigVertexCover(*g, non_edge).status().code() == StatusCode::kInvalidArgument);
  Matching inconsistent{{0, -1}, {-1, 0}, 1};
  CHECK(KonigVertexCover(*g, inconsistent).status().code() == StatusCode::kInvalidArgument);
  Matching bad_count{{1, 0}, {1, 0}, 1};
  CHECK(KonigVertexCover(*g, bad_count).status().code() == StatusCode::kInvalidArgument);
  Matching good{{1, 0}, {1, 0}, 2};
  Result<VertexCover> c = KonigVertexCover(*g, good);
  REQUIRE(c.ok());
  CHECK(c->size() == 2);
}

}  // namespace
TEST_CASE("Checkerboard grid graph: cell counts, exactly the 4-neighbour pairs, perfect matching when cells are even") {
  for (int rows = 1; rows <= 5; ++rows) {
    for (int cols = 1; cols <= 6; ++cols) {
      CAPTURE(rows);
      CAPTURE(cols);
      auto g = MakeCheckerboardGridGraph(rows, cols);
      REQUIRE(g.ok());
      CHECK(g->left_count() == (rows * cols + 1) / 2);
      CHECK(g->right_count() == rows * cols / 2);
      CHECK(g->edges().size() == static_cast<std::size_t>(rows * (cols - 1) + cols * (rows - 1)));
      // Independent check: map every edge back to its cells and require grid adjacency, each pair once.
      std::vector<std::pair<int, int>> black, white;  // (row, col) by side index
      for (int r = 0; r < rows; ++r)
        for (int c = 0; c < cols; ++c) ((r + c) % 2 == 0 ? black : white).emplace_back(r, c);
      std::vector<std::pair<int, int>> seen;
      for (const BipartiteEdge& e : g->edges()) {
        const auto [r1, c1] = black[static_cast<std::size_t>(e.left)];
        const auto [r2, c2] = white[static_cast<std::size_t>(e.right)];
        CHECK(std::abs(r1 - r2) + std::abs(c1 - c2) == 1);
        seen.emplace_back(e.left, e.right);
      }
      std::sort(seen.begin(), seen.end());
      CHECK(std::adjacent_find(seen.begin(), seen.end()) == seen.end());
      // A grid with an even number of cells and a side of even length has a perfect matching (dominoes).
      if (rows % 2 == 0 || cols % 2 == 0) {
        auto m = HopcroftKarp(*g);
        REQUIRE(m.ok());
        CHECK(m->size == rows * cols / 2);
      }
    }
  }
  CHECK_FALSE(MakeCheckerboardGridGraph(0, 3).ok());
  CHECK_FALSE(MakeCheckerboardGridGraph(5000, 5000).ok());
}

}  // namespace commerge
