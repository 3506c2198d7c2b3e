// SPDX-License-Identifier: BSD-3-Clause
// The benchmark graphs of ../shared/data/graphs for the solver tests: TSV index files and DIMACS files read into a
// CliqueGraph with the weight conventions of the shared data README (vertex weights from the files' "n" lines,
// edge weights w(u, v) = (u + v) mod 200 + 1 on 1-based ids). Parsing is core's (ParseTsvTable, ParseDimacsGraph).
#pragma once

#include <doctest/doctest.h>

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include "core/common/tsv_table.hpp"
#include "core/solvers/dimacs_graph.hpp"
#include "core/solvers/max_clique.hpp"
#include "tests/support/test_data.hpp"

namespace commerge::test {

/// The rows of a TSV file (header line = column names); aborts when the file cannot be read.
inline std::vector<TsvRow> ReadTsvFile(const std::string& path) { return ParseTsvTable(ReadTextFile(path)); }

/// The graph of the DIMACS file at `path` (REQUIREs that it parses): vertex weights from its "n" lines when
/// present; with `edge_weights`, edge weights (u + v) mod 200 + 1 on 1-based ids.
inline CliqueGraph LoadDimacsCliqueGraph(const std::string& path, bool edge_weights) {
  Result<DimacsGraph> d = ParseDimacsGraph(ReadTextFile(path), path);
  REQUIRE(d.ok());
  Result<CliqueGraph> g = CliqueGraph::Create(d->num_vertices, edge_weights);
  REQUIRE(g.ok());
  for (const auto& e : d->edges) {
    // 0-based ids from the parser; the convention uses 1-based DIMACS ids.
    const double w = static_cast<double>(((e.first + 1) + (e.second + 1)) % 200 + 1);
    REQUIRE(g->AddEdge(e.first, e.second, w).ok());
  }
  for (std::size_t v = 0; v < d->vertex_weights.size(); ++v) {
    REQUIRE(g->SetVertexWeight(static_cast<int>(v), d->vertex_weights[v]).ok());
  }
  return std::move(*g);
}

}  // namespace commerge::test
