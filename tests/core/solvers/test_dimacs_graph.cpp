// SPDX-License-Identifier: BSD-3-Clause
// DIMACS parser: hand-written texts (edges, weights, block comments), every malformed variant rejected with the
// line named, and all benchmark files of ../shared/data/graphs parsed with the sizes their index lists.
#include <doctest/doctest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "core/solvers/dimacs_graph.hpp"
#include "tests/support/test_data.hpp"

namespace commerge {
namespace {

TEST_CASE("DIMACS: edges, vertex weights and block comments are read 0-based") {
  const char* text =
      "c a comment\n"
      "p edge 4 3\n"
      "c bipartite 2 2\n"
      "n 1 5\n"
      "n 4 2.5\n"
      "e 1 3\n"
      "e 2 4\r\n"
      "\n"
      "e 1 4\n";
  auto g = ParseDimacsGraph(text, "t.clq");
  REQUIRE(g.ok());
  CHECK(g->num_vertices == 4);
  REQUIRE(g->edges.size() == 3);
  CHECK(g->edges[0] == std::make_pair(0, 2));
  CHECK(g->edges[1] == std::make_pair(1, 3));
  CHECK(g->edges[2] == std::make_pair(0, 3));
  REQUIRE(g->vertex_weights.size() == 4);
  CHECK(g->vertex_weights[0] == 5.0);
  CHECK(g->vertex_weights[1] == 0.0);
  CHECK(g->vertex_weights[3] == 2.5);
  CHECK(g->block_sizes == std::vector<int>{2, 2});

  auto r = ParseDimacsGraph("p edge 5 0\nc robots 3 1 2 2\n", "r.dimacs");
  REQUIRE(r.ok());
  CHECK(r->block_sizes == std::vector<int>{1, 2, 2});
  CHECK(r->vertex_weights.empty());
}

TEST_CASE("DIMACS: malformed texts are refused with the file and line") {
  struct Case {
    const char* text;
    const char* expect;
  };
  const Case cases[] = {
      {"", "no 'p edge N M' line"},
      {"e 1 2\n", "before the 'p' line"},
      {"p edge 3 1\np edge 3 1\n", "a second 'p' line"},
      {"p edge 3\n", "expected 'p edge N M'"},
      {"p edge -1 0\n", "vertex count"},
      {"p edge 3 1\ne 1 4\n", "vertex id outside 1..3"},
      {"p edge 3 1\ne 0 2\n", "vertex id outside 1..3"},
      {"p edge 3 1\ne 2 2\n", "self-loop"},
      {"p edge 3 2\ne 1 2\n", "found 1 'e' lines"},
      {"p edge 3 1\ne 1 2\ne 1 3\n", "more 'e' lines"},
      {"p edge 3 1\ne 1 2 7\n", "trailing text"},
      {"p edge 3 1\nn 1 nan\ne 1 2\n", "not a finite number"},
      {"p edge 3 1\nx 1 2\n", "unknown line type"},
      {"p edge 3 1\nc bipartite 1 1\ne 1 2\n", "block sizes sum to 2"},
      {"p edge 3 99999999999\n", "cannot fit"},
      {"p edge 3 1\ne 1 2x\n", "vertex id outside"},
  };
  for (const Case& c : cases) {
    CAPTURE(c.text);
    auto g = ParseDimacsGraph(c.text, "bad.clq");
    REQUIRE_FALSE(g.ok());
    CHECK(g.status().code() == StatusCode::kDataLoss);
    CHECK(g.status().message().find("bad.clq:") == 0);
    CHECK(g.status().message().find(c.expect) != std::string::npos);
  }
}

TEST_CASE("DIMACS: every shared benchmark graph parses with the sizes of its index") {
  CM_SHARED_DATA_OR_SKIP(dir, "graphs/optima.tsv");
  const std::filesystem::path root = std::filesystem::path(dir).parent_path();
  std::istringstream index(test::ReadTextFile(dir));
  std::string line;
  std::getline(index, line);  // header: name file n m ...
  int parsed = 0;
  while (std::getline(index, line)) {
    std::istringstream cols(line);
    std::string name, file;
    int n = 0;
    long long m = 0;
    cols >> name >> file >> n >> m;
    // The two largest files are parsed by the heavy clique tests; keep this one quick under qemu.
    if (std::filesystem::file_size(root / file) > 1'000'000) continue;
    auto g = ParseDimacsGraph(test::ReadTextFile((root / file).string()), file);
    REQUIRE_MESSAGE(g.ok(), g.status().ToString());
    CHECK(g->num_vertices == n);
    CHECK(static_cast<long long>(g->edges.size()) == m);
    ++parsed;
  }
  CHECK(parsed >= 30);
  const auto exchange = root / "exchange_cslam_resource" / "rss18_kitti00_5robots.dimacs";
  auto g = ParseDimacsGraph(test::ReadTextFile(exchange.string()), "rss18_kitti00_5robots.dimacs");
  REQUIRE_MESSAGE(g.ok(), g.status().ToString());
  CHECK(g->block_sizes.size() == 5);
  CHECK(g->vertex_weights.size() == static_cast<std::size_t>(g->num_vertices));
}

}  // namespace
}  // namespace commerge
