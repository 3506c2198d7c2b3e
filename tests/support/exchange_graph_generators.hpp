// SPDX-License-Identifier: BSD-3-Clause
// Random exchange-graph edge sets for the stage B vertex cover: shared by its test
// (tests/core/exchange/test_balanced_vertex_cover.cpp) and its benchmark (profiling/bench_vertex_cover.cpp), so
// both build the same graphs from the same generator state. Each function draws one uniform number per candidate
// pair, in row order (u ascending, then v ascending). No doctest here: the benchmark includes it too.
#pragma once

#include <cmath>
#include <cstddef>
#include <random>
#include <vector>

#include "core/exchange/exchange_graph.hpp"
#include "core/solvers/bipartite_matching.hpp"

namespace commerge::test {

/// Two robots, n left and m right scans: each pair (u, v) is an edge with probability avg_degree / m, so a left
/// scan has avg_degree candidate loops on average.
inline std::vector<BipartiteEdge> RandomBipartiteEdges(int n, int m, double avg_degree, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double p = avg_degree / static_cast<double>(m);
  std::vector<BipartiteEdge> e;
  for (int u = 0; u < n; ++u)
    for (int v = 0; v < m; ++v)
      if (unit(rng) < p) e.push_back({u, v});
  return e;
}

/// Like sequential matching output (stage A): left u joins right v when |v - u * m / n| <= half_width, each such
/// pair kept with probability keep.
inline std::vector<BipartiteEdge> DiagonalBandEdges(int n, int m, double half_width, double keep, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<BipartiteEdge> e;
  for (int u = 0; u < n; ++u) {
    const double centre = static_cast<double>(u) * static_cast<double>(m) / static_cast<double>(n);
    for (int v = 0; v < m; ++v) {
      if (std::fabs(static_cast<double>(v) - centre) <= half_width && unit(rng) < keep) e.push_back({u, v});
    }
  }
  return e;
}

/// N robots with counts[r] scans each, vertices numbered robot after robot: every pair of scans of two different
/// robots is an edge with probability avg_degree / (total scans).
inline std::vector<ExchangeEdge> RandomMultiRobotEdges(const std::vector<int>& counts, double avg_degree,
                                                       std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<int> robot_of;
  for (std::size_t r = 0; r < counts.size(); ++r) {
    robot_of.insert(robot_of.end(), static_cast<std::size_t>(counts[r]), static_cast<int>(r));
  }
  const int total = static_cast<int>(robot_of.size());
  const double p = avg_degree / total;
  std::vector<ExchangeEdge> e;
  for (int u = 0; u < total; ++u)
    for (int v = u + 1; v < total; ++v)
      if (robot_of[static_cast<std::size_t>(u)] != robot_of[static_cast<std::size_t>(v)] && unit(rng) < p) {
        e.push_back({u, v});
      }
  return e;
}

}  // namespace commerge::test
