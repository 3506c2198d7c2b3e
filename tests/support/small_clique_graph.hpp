// SPDX-License-Identifier: BSD-3-Clause
// A small graph the clique tests keep on their own (adjacency bit masks, vertex and edge weights), independent of
// CliqueGraph, for brute-force references: seeded random graphs of at most 32 vertices and their CliqueGraph.
#pragma once

#include <doctest/doctest.h>

#include <cstddef>
#include <random>
#include <utility>
#include <vector>

#include "core/solvers/max_clique.hpp"

namespace commerge::test {

struct SmallCliqueGraph {
  int n = 0;
  std::vector<unsigned> adj;  // adj[v]: bit u set when {u, v} is an edge
  std::vector<double> vertex_w;
  std::vector<double> edge_w;  // n x n, symmetric, 0 for non-edges (values already rounded to float)
  double Ew(int u, int v) const { return edge_w[static_cast<std::size_t>(u * n + v)]; }
};

/// Every pair an edge with probability `density`; weights integers 0..9 or floats in [0, 5) (vertex weights too).
inline SmallCliqueGraph MakeRandomCliqueGraph(std::mt19937& rng, int n, double density, bool integer_weights) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> small_int(0, 9);
  auto weight = [&] {
    return integer_weights ? static_cast<double>(small_int(rng)) : static_cast<double>(static_cast<float>(5.0 * unit(rng)));
  };
  SmallCliqueGraph g;
  g.n = n;
  g.adj.assign(static_cast<std::size_t>(n), 0U);
  g.vertex_w.resize(static_cast<std::size_t>(n));
  g.edge_w.assign(static_cast<std::size_t>(n * n), 0.0);
  for (int v = 0; v < n; ++v) g.vertex_w[static_cast<std::size_t>(v)] = weight();
  for (int u = 0; u < n; ++u) {
    for (int v = u + 1; v < n; ++v) {
      if (unit(rng) < density) {
        g.adj[static_cast<std::size_t>(u)] |= 1U << v;
        g.adj[static_cast<std::size_t>(v)] |= 1U << u;
        const double w = weight();
        g.edge_w[static_cast<std::size_t>(u * n + v)] = w;
        g.edge_w[static_cast<std::size_t>(v * n + u)] = w;
      }
    }
  }
  return g;
}

/// The same graph as a CliqueGraph (vertex weights set; edge weights when `with_edge_weights`).
inline CliqueGraph BuildCliqueGraph(const SmallCliqueGraph& s, bool with_edge_weights = true) {
  Result<CliqueGraph> g = CliqueGraph::Create(s.n, with_edge_weights);
  REQUIRE(g.ok());
  for (int v = 0; v < s.n; ++v) REQUIRE(g->SetVertexWeight(v, s.vertex_w[static_cast<std::size_t>(v)]).ok());
  for (int u = 0; u < s.n; ++u) {
    for (int v = u + 1; v < s.n; ++v) {
      if (s.adj[static_cast<std::size_t>(u)] >> v & 1U) REQUIRE(g->AddEdge(u, v, s.Ew(u, v)).ok());
    }
  }
  return std::move(*g);
}

}  // namespace commerge::test
