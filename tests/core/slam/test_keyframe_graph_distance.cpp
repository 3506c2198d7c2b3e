// SPDX-License-Identifier: BSD-3-Clause
// KeyframeGraphDistance against Floyd-Warshall on the same chain-plus-links graph, built independently.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/slam/keyframe_graph_distance.hpp"

using namespace commerge;

namespace {

/// All-pairs fewest chain steps with free links (Floyd-Warshall on an adjacency matrix).
std::vector<std::vector<std::uint32_t>> AllPairs(std::size_t n, const std::vector<std::pair<std::uint32_t, std::uint32_t>>& links) {
  const std::uint32_t inf = 1u << 30;
  std::vector<std::vector<std::uint32_t>> d(n, std::vector<std::uint32_t>(n, inf));
  for (std::size_t i = 0; i < n; ++i) {
    d[i][i] = 0;
    if (i + 1 < n) d[i][i + 1] = d[i + 1][i] = 1;
  }
  for (const auto& [a, b] : links) d[a][b] = d[b][a] = 0;
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t j = 0; j < n; ++j) d[i][j] = std::min(d[i][j], d[i][k] + d[k][j]);
    }
  }
  return d;
}

}  // namespace

TEST_CASE("Keyframe graph distance: chain steps with free loop links equal Floyd-Warshall on random graphs") {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const std::size_t capacity = 60;
    const std::size_t n = 2 + rng() % (capacity - 1);
    KeyframeGraphDistance distance(capacity);
    std::vector<std::pair<std::uint32_t, std::uint32_t>> links;
    const std::size_t num_links = rng() % 12;
    for (std::size_t l = 0; l < num_links; ++l) {
      const auto a = static_cast<std::uint32_t>(rng() % n), b = static_cast<std::uint32_t>(rng() % n);
      if (a == b) continue;
      links.emplace_back(a, b);
      REQUIRE(distance.AddLink(a, b).ok());
    }
    const auto reference = AllPairs(n, links);
    // Every pair, twice over (the adjacency is cached between queries), and again after one more link.
    for (int pass = 0; pass < 2; ++pass) {
      for (std::uint32_t a = 0; a < n; ++a) {
        for (std::uint32_t b = 0; b < n; ++b) REQUIRE(distance.Steps(a, b, n) == reference[a][b]);
      }
    }
    const auto a = static_cast<std::uint32_t>(rng() % n), b = static_cast<std::uint32_t>((a + 1 + rng() % (n - 1)) % n);
    links.emplace_back(a, b);
    REQUIRE(distance.AddLink(a, b).ok());
    const auto after = AllPairs(n, links);
    for (std::uint32_t x = 0; x < n; ++x) {
      for (std::uint32_t y = 0; y < n; ++y) REQUIRE(distance.Steps(x, y, n) == after[x][y]);
    }
  }
}

TEST_CASE("Keyframe graph distance: a growing chain, a loop shortcut, bad links and the capacity") {
  KeyframeGraphDistance distance(5);
  CHECK(distance.Steps(0, 2, 3) == 2);
  CHECK(distance.Steps(0, 4, 5) == 4);          // the chain grew to 5 keyframes: the cache follows
  REQUIRE(distance.AddLink(0, 4).ok());
  CHECK(distance.Steps(0, 4, 5) == 0);
  CHECK(distance.Steps(1, 3, 5) == 2);          // 1-0-4-3 is 2 steps, the chain 1-2-3 too
  CHECK(distance.Steps(1, 4, 5) == 1);
  CHECK(distance.AddLink(2, 2).message().find("2-2") != std::string::npos);
  CHECK(distance.AddLink(1, 5).message().find("below 5") != std::string::npos);
  for (int i = 0; i < 4; ++i) REQUIRE(distance.AddLink(1, 2).ok());
  CHECK(distance.AddLink(1, 3).code() == StatusCode::kResourceExhausted);
  CHECK(distance.num_links() == 5);
  CHECK(distance.workspace_bytes() >= 5 * 8);
}
