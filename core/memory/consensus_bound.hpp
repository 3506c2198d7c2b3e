// SPDX-License-Identifier: BSD-3-Clause
// commerge: the bound on the server's place consensus (core/exchange/place_consensus), here so that the budget
// table (core/memory/budget) and the consensus read one number without memory depending on exchange.
#pragma once

#include <cstddef>

namespace commerge {

/// The server's cap on the cells of stage A's cluster set (ExchangeCascadeParams::consensus_max_cells): with
/// its neighbour rank 1 a pair of N and M keyframes has at most N + M, so 50 000 covers two robots of 25 000.
constexpr std::size_t kServerConsensusMaxCells = 50000;
/// Transient bytes per cell while the set is built and used, worst case with vector growth: the labeller's
/// recorded cell (32 B) and union-find node (72 B), each up to twice over capacity, the grouping's labelled
/// cell (32 B) and index vectors (4 x 8 B), the set's cell (24 B), cluster (48 B) and offset (8 B).
constexpr std::size_t kConsensusCellBytes = 384;

}  // namespace commerge
