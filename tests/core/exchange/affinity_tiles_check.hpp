// SPDX-License-Identifier: BSD-3-Clause
// Test helper shared by the affinity suites (unit-L2 kernel, Scan Context source): random blocks of a tile
// source must equal the whole matrix bit for bit, with their reported minimum, whatever their position.
#pragma once

#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/exchange/affinity.hpp"

namespace commerge::test {

/// `trials` random blocks (offsets anywhere, 1 .. max_side rows and columns) of `source` checked against `whole`
/// (n x m, row-major, computed in one tile). Returns the cells computed.
inline std::uint64_t CheckRandomTiles(AffinityTileSource& source, const std::vector<float>& whole, std::size_t n,
                                      std::size_t m, std::size_t max_side, int trials, std::mt19937* rng) {
  AffinityTile t;
  std::uint64_t cells = 0;
  for (int trial = 0; trial < trials; ++trial) {
    const std::size_t r0 = std::uniform_int_distribution<std::size_t>(0, n - 1)(*rng);
    const std::size_t c0 = std::uniform_int_distribution<std::size_t>(0, m - 1)(*rng);
    const std::size_t rows = std::uniform_int_distribution<std::size_t>(1, std::min(max_side, n - r0))(*rng);
    const std::size_t cols = std::uniform_int_distribution<std::size_t>(1, std::min(max_side, m - c0))(*rng);
    REQUIRE(source.ComputeTile(r0, c0, rows, cols, &t).ok());
    cells += rows * cols;
    float tile_min = std::numeric_limits<float>::infinity();
    for (std::size_t r = 0; r < rows; ++r) {
      for (std::size_t c = 0; c < cols; ++c) {
        const float w = whole[(r0 + r) * m + c0 + c];
        REQUIRE(t.at(r, c) == w);  // bit for bit (inf == inf)
        tile_min = std::min(tile_min, w);
      }
    }
    CHECK(t.min_distance == tile_min);
  }
  return cells;
}

}  // namespace commerge::test
