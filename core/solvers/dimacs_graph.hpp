// SPDX-License-Identifier: BSD-3-Clause
// commerge: parser for DIMACS graph text ("p edge N M", "e u v", optional "n v w" vertex weights, "c" comments),
// the format of the clique and exchange-graph benchmarks. Also reads the two structured comments of the
// exchange graphs: "c bipartite NA NB" and "c robots K n1 ... nK" (contiguous vertex blocks per robot).
// Pure text in, graph out: the caller reads the file.
#pragma once

#include <cstddef>
#include <string_view>
#include <utility>
#include <vector>

#include "core/common/status.hpp"

namespace commerge {

struct DimacsGraph {
  int num_vertices = 0;                      ///< N of the "p edge N M" line
  std::vector<std::pair<int, int>> edges;    ///< 0-based (u, v) in file order, u != v
  std::vector<double> vertex_weights;        ///< empty without "n" lines; else N entries (unlisted vertices: 0)
  std::vector<int> block_sizes;              ///< "c bipartite NA NB" -> {NA, NB}; "c robots K n1..nK" -> {n1..nK}
};

/// Parses DIMACS text. `source_name` (usually the file name) prefixes every error, which names the line.
/// Errors (DataLoss): no or a second "p" line, a malformed line, a vertex id outside 1..N, a self-loop, an edge
/// count different from M, a weight that is not finite, block sizes that do not sum to N. N is limited to
/// kMaxDimacsVertices and M to what the text can hold (no allocation driven by the header alone).
Result<DimacsGraph> ParseDimacsGraph(std::string_view text, std::string_view source_name);

inline constexpr int kMaxDimacsVertices = 10'000'000;

}  // namespace commerge
