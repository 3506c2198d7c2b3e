// SPDX-License-Identifier: BSD-3-Clause
// Maximum clique branch-and-bound: all three objectives vs a brute force over every vertex subset on thousands of
// seeded random graphs of <= 14 vertices (integer and real weights, zero weights included), node limits that
// must still bracket the optimum, graph and parameter validation, degenerate graphs, determinism, and a few
// small DIMACS instances against the optima listed in ../shared/data/graphs (the big sweeps are in
// tests/core/solvers_heavy/).
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "core/common/tsv_table.hpp"
#include "core/solvers/max_clique.hpp"
#include "tests/support/graph_data.hpp"
#include "tests/support/small_clique_graph.hpp"
#include "tests/support/test_data.hpp"

namespace commerge {
namespace {

constexpr CliqueObjective kObjectives[] = {CliqueObjective::kCardinality, CliqueObjective::kVertexWeight,
                                           CliqueObjective::kEdgeWeight};

using SmallGraph = test::SmallCliqueGraph;
SmallGraph MakeRandom(std::mt19937& rng, int n, double density, bool integer_weights) {
  return test::MakeRandomCliqueGraph(rng, n, density, integer_weights);
}
CliqueGraph Build(const SmallGraph& s, bool with_edge_weights = true) { return test::BuildCliqueGraph(s, with_edge_weights); }

struct BruteOptima {
  double cardinality = 0.0;
  double vertex = 0.0;
  double edge = 0.0;
  double Of(CliqueObjective o) const {
    return o == CliqueObjective::kCardinality ? cardinality : (o == CliqueObjective::kVertexWeight ? vertex : edge);
  }
};

// Every subset: clique[mask] from clique[mask without its lowest vertex]; weights accumulated the same way.
BruteOptima BruteForce(const SmallGraph& g) {
  const std::size_t subsets = static_cast<std::size_t>(1) << g.n;
  std::vector<char> clique(subsets, 0);
  std::vector<double> vsum(subsets, 0.0), esum(subsets, 0.0);
  clique[0] = 1;
  BruteOptima best;
  for (std::size_t mask = 1; mask < subsets; ++mask) {
    const int low = __builtin_ctz(static_cast<unsigned>(mask));
    const std::size_t rest = mask & (mask - 1);
    if (!clique[rest] || (static_cast<unsigned>(rest) & ~g.adj[static_cast<std::size_t>(low)]) != 0U) continue;
    clique[mask] = 1;
    vsum[mask] = vsum[rest] + g.vertex_w[static_cast<std::size_t>(low)];
    double e = esum[rest];
    for (unsigned r = static_cast<unsigned>(rest); r != 0U; r &= r - 1) e += g.Ew(low, __builtin_ctz(r));
    esum[mask] = e;
    best.cardinality = std::max(best.cardinality, static_cast<double>(__builtin_popcount(static_cast<unsigned>(mask))));
    best.vertex = std::max(best.vertex, vsum[mask]);
    best.edge = std::max(best.edge, e);
  }
  return best;
}

double Objective(const SmallGraph& g, const std::vector<int>& k, CliqueObjective o) {
  double sum = 0.0;
  if (o == CliqueObjective::kCardinality) return static_cast<double>(k.size());
  if (o == CliqueObjective::kVertexWeight) {
    for (int v : k) sum += g.vertex_w[static_cast<std::size_t>(v)];
    return sum;
  }
  for (std::size_t a = 0; a < k.size(); ++a) {
    for (std::size_t b = a + 1; b < k.size(); ++b) sum += g.Ew(k[a], k[b]);
  }
  return sum;
}

// Sorted, unique, in range, pairwise adjacent, never empty for a non-empty graph, objective recomputed.
void CheckClique(const SmallGraph& g, const CliqueSearchResult& r, CliqueObjective o) {
  REQUIRE(!r.clique.empty());
  REQUIRE(std::is_sorted(r.clique.begin(), r.clique.end()));
  REQUIRE(std::adjacent_find(r.clique.begin(), r.clique.end()) == r.clique.end());
  for (std::size_t a = 0; a < r.clique.size(); ++a) {
    REQUIRE(r.clique[a] >= 0);
    REQUIRE(r.clique[a] < g.n);
    for (std::size_t b = a + 1; b < r.clique.size(); ++b) {
      REQUIRE((g.adj[static_cast<std::size_t>(r.clique[a])] >> r.clique[b] & 1U) != 0U);
    }
  }
  CHECK(r.objective == doctest::Approx(Objective(g, r.clique, o)).epsilon(1e-12));
  CHECK(r.objective <= r.upper_bound);
}

CliqueSearchParams Params(CliqueObjective o, std::int64_t max_nodes = 100'000'000) {
  CliqueSearchParams p;
  p.objective = o;
  p.time_limit_s = 1000.0;
  p.max_nodes = max_nodes;
  return p;
}

void RunRandomBlock(std::uint32_t seed, int graphs, bool integer_weights) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> size(1, 14);
  std::uniform_real_distribution<double> dens(0.1, 0.95);
  int checked = 0;
  for (int t = 0; t < graphs; ++t) {
    const int n = size(rng);  // drawn one per statement: argument evaluation order differs between compilers
    const double density = dens(rng);
    const SmallGraph s = MakeRandom(rng, n, density, integer_weights);
    const CliqueGraph g = Build(s);
    const BruteOptima opt = BruteForce(s);
    for (CliqueObjective o : kObjectives) {
      CAPTURE(t);
      CAPTURE(static_cast<int>(o));
      Result<CliqueSearchResult> r = SolveMaxClique(g, Params(o));
      REQUIRE(r.ok());
      REQUIRE(r->status == CliqueSearchStatus::kOptimal);
      CheckClique(s, *r, o);
      CHECK(r->objective == doctest::Approx(opt.Of(o)).epsilon(1e-9));
      CHECK(r->upper_bound == r->objective);
      CHECK(r->gap() == 0.0);
      CHECK(r->nodes >= 1);
      // Node limits stop early but must still bracket the optimum.
      for (std::int64_t limit : {1, 2, 5}) {
        Result<CliqueSearchResult> lr = SolveMaxClique(g, Params(o, limit));
        REQUIRE(lr.ok());
        CheckClique(s, *lr, o);
        CHECK(lr->nodes <= limit);
        CHECK(lr->objective <= opt.Of(o) * (1.0 + 1e-9) + 1e-9);
        CHECK(lr->upper_bound >= opt.Of(o) * (1.0 - 1e-9) - 1e-9);
        if (lr->status == CliqueSearchStatus::kOptimal) {
          CHECK(lr->objective == doctest::Approx(opt.Of(o)).epsilon(1e-9));
        } else {
          REQUIRE(lr->status == CliqueSearchStatus::kLimitReached);
          CHECK(lr->upper_bound > lr->objective);
        }
      }
      ++checked;
    }
  }
  CHECK(checked == 3 * graphs);
}

TEST_CASE("Max clique equals brute force on random graphs with integer weights, block 1") { RunRandomBlock(1U, 700, true); }
TEST_CASE("Max clique equals brute force on random graphs with integer weights, block 2") { RunRandomBlock(2U, 700, true); }
TEST_CASE("Max clique equals brute force on random graphs with real weights, block 1") { RunRandomBlock(3U, 700, false); }
TEST_CASE("Max clique equals brute force on random graphs with real weights, block 2") { RunRandomBlock(4U, 700, false); }

TEST_CASE("Max clique optimum is invariant under relabelling and the result is deterministic") {
  std::mt19937 rng(77U);
  for (int t = 0; t < 60; ++t) {
    const SmallGraph s = MakeRandom(rng, 14, 0.3 + 0.01 * t, t % 2 == 0);
    std::vector<int> perm(14);
    for (int i = 0; i < 14; ++i) perm[static_cast<std::size_t>(i)] = i;
    std::shuffle(perm.begin(), perm.end(), rng);
    SmallGraph p = s;
    for (int u = 0; u < 14; ++u) {
      p.adj[static_cast<std::size_t>(perm[static_cast<std::size_t>(u)])] = 0U;
      p.vertex_w[static_cast<std::size_t>(perm[static_cast<std::size_t>(u)])] = s.vertex_w[static_cast<std::size_t>(u)];
    }
    for (int u = 0; u < 14; ++u) {
      for (int v = 0; v < 14; ++v) {
        const int pu = perm[static_cast<std::size_t>(u)];
        const int pv = perm[static_cast<std::size_t>(v)];
        if (s.adj[static_cast<std::size_t>(u)] >> v & 1U) p.adj[static_cast<std::size_t>(pu)] |= 1U << pv;
        p.edge_w[static_cast<std::size_t>(pu * 14 + pv)] = s.Ew(u, v);
      }
    }
    const CliqueGraph g = Build(s);
    const CliqueGraph h = Build(p);
    for (CliqueObjective o : kObjectives) {
      Result<CliqueSearchResult> a = SolveMaxClique(g, Params(o));
      Result<CliqueSearchResult> b = SolveMaxClique(g, Params(o));
      Result<CliqueSearchResult> c = SolveMaxClique(h, Params(o));
      REQUIRE((a.ok() && b.ok() && c.ok()));
      CHECK(a->clique == b->clique);
      CHECK(a->nodes == b->nodes);
      CHECK(a->objective == doctest::Approx(c->objective).epsilon(1e-9));
    }
  }
}

TEST_CASE("Max clique graph refuses bad sizes, self-loops, indices out of range and bad weights") {
  CHECK(CliqueGraph::Create(-1, false).status().code() == StatusCode::kInvalidArgument);
  CHECK(CliqueGraph::Create(kMaxCliqueVertices + 1, false).status().code() == StatusCode::kInvalidArgument);
  CHECK(CliqueGraph::Create(kMaxEdgeWeightedCliqueVertices + 1, true).status().code() == StatusCode::kInvalidArgument);
  CHECK(CliqueGraph::Create(kMaxEdgeWeightedCliqueVertices + 1, false).ok());

  Result<CliqueGraph> g = CliqueGraph::Create(4, true);
  REQUIRE(g.ok());
  CHECK(g->has_edge_weights());
  CHECK(g->AddEdge(1, 1, 1.0).code() == StatusCode::kInvalidArgument);
  CHECK(g->AddEdge(-1, 2, 1.0).code() == StatusCode::kInvalidArgument);
  CHECK(g->AddEdge(0, 4, 1.0).code() == StatusCode::kInvalidArgument);
  CHECK(g->AddEdge(0, 1, -0.5).code() == StatusCode::kInvalidArgument);
  CHECK(g->AddEdge(0, 1, std::nan("")).code() == StatusCode::kInvalidArgument);
  CHECK(g->AddEdge(0, 1, std::numeric_limits<double>::infinity()).code() == StatusCode::kInvalidArgument);
  CHECK(g->AddEdge(0, 1, 1e300).code() == StatusCode::kInvalidArgument);
  CHECK(g->SetVertexWeight(4, 1.0).code() == StatusCode::kInvalidArgument);
  CHECK(g->SetVertexWeight(-1, 1.0).code() == StatusCode::kInvalidArgument);
  CHECK(g->SetVertexWeight(0, -1.0).code() == StatusCode::kInvalidArgument);
  CHECK(g->SetVertexWeight(0, std::nan("")).code() == StatusCode::kInvalidArgument);
  CHECK(g->num_edges() == 0);
  // Nothing was added by the refused calls; a repeated edge counts once and takes the last weight.
  CHECK(g->AddEdge(0, 1, 2.0).ok());
  CHECK(g->AddEdge(1, 0, 3.5).ok());
  CHECK(g->num_edges() == 1);
  CHECK(g->HasEdge(0, 1));
  CHECK(g->HasEdge(1, 0));
  CHECK_FALSE(g->HasEdge(0, 2));
  CHECK_FALSE(g->HasEdge(0, 7));
  CHECK(g->edge_weight(0, 1) == 3.5);
  CHECK(g->edge_weight(0, 2) == 0.0);
  CHECK(g->vertex_weight(3) == 1.0);
  CHECK(g->MemoryBytes() >= 4 * 8 + 4 * 8 + 16 * 4);

  Result<CliqueGraph> u = CliqueGraph::Create(3, false);
  REQUIRE(u.ok());
  CHECK_FALSE(u->has_edge_weights());
  CHECK(u->AddEdge(0, 2, 7.0).ok());
  CHECK(u->edge_weight(0, 2) == 1.0);  // no edge weights: an edge weighs 1
  CHECK(u->edge_weight(0, 1) == 0.0);
}

TEST_CASE("Max clique refuses bad parameters and the edge objective without edge weights") {
  Result<CliqueGraph> g = CliqueGraph::Create(3, false);
  REQUIRE(g.ok());
  REQUIRE(g->AddEdge(0, 1).ok());
  CliqueSearchParams p = Params(CliqueObjective::kCardinality);
  p.time_limit_s = 0.0;
  CHECK(SolveMaxClique(*g, p).status().code() == StatusCode::kInvalidArgument);
  p.time_limit_s = -1.0;
  CHECK(SolveMaxClique(*g, p).status().code() == StatusCode::kInvalidArgument);
  p.time_limit_s = std::nan("");
  CHECK(SolveMaxClique(*g, p).status().code() == StatusCode::kInvalidArgument);
  p.time_limit_s = std::numeric_limits<double>::infinity();  // no limit
  CHECK(SolveMaxClique(*g, p).ok());
  p = Params(CliqueObjective::kCardinality, 0);
  CHECK(SolveMaxClique(*g, p).status().code() == StatusCode::kInvalidArgument);
  CHECK(SolveMaxClique(*g, Params(CliqueObjective::kEdgeWeight)).status().code() == StatusCode::kInvalidArgument);
  CHECK(SolveMaxClique(*g, Params(CliqueObjective::kVertexWeight)).ok());
  CHECK(std::string(CliqueSearchStatusName(CliqueSearchStatus::kOptimal)) == "optimal");
  CHECK(std::string(CliqueSearchStatusName(CliqueSearchStatus::kLimitReached)) == "limit reached");
  CHECK(std::string(CliqueSearchStatusName(CliqueSearchStatus::kEmptyGraph)) == "empty graph");
}

TEST_CASE("Max clique of the empty graph is empty") {
  for (bool weighted : {false, true}) {
    Result<CliqueGraph> g = CliqueGraph::Create(0, weighted);
    REQUIRE(g.ok());
    for (CliqueObjective o : kObjectives) {
      if (o == CliqueObjective::kEdgeWeight && !weighted) continue;
      Result<CliqueSearchResult> r = SolveMaxClique(*g, Params(o));
      REQUIRE(r.ok());
      CHECK(r->status == CliqueSearchStatus::kEmptyGraph);
      CHECK(r->clique.empty());
      CHECK(r->objective == 0.0);
      CHECK(r->upper_bound == 0.0);
    }
  }
  CliqueGraph unset;
  Result<CliqueSearchResult> r = SolveMaxClique(unset, Params(CliqueObjective::kCardinality));
  REQUIRE(r.ok());
  CHECK(r->status == CliqueSearchStatus::kEmptyGraph);
}

TEST_CASE("Max clique on edgeless graphs is one vertex, of objective 0 under edge weights") {
  Result<CliqueGraph> g = CliqueGraph::Create(70, true);  // more than one bitset word
  REQUIRE(g.ok());
  for (int v = 0; v < 70; ++v) REQUIRE(g->SetVertexWeight(v, v == 66 ? 9.0 : 1.0 + 0.01 * v).ok());
  Result<CliqueSearchResult> c = SolveMaxClique(*g, Params(CliqueObjective::kCardinality));
  REQUIRE(c.ok());
  CHECK(c->status == CliqueSearchStatus::kOptimal);
  CHECK(c->clique.size() == 1);
  CHECK(c->objective == 1.0);
  Result<CliqueSearchResult> w = SolveMaxClique(*g, Params(CliqueObjective::kVertexWeight));
  REQUIRE(w.ok());
  CHECK(w->clique == std::vector<int>{66});
  CHECK(w->objective == 9.0);
  Result<CliqueSearchResult> e = SolveMaxClique(*g, Params(CliqueObjective::kEdgeWeight));
  REQUIRE(e.ok());
  CHECK(e->status == CliqueSearchStatus::kOptimal);
  CHECK(e->clique.size() == 1);
  CHECK(e->objective == 0.0);
  CHECK(e->upper_bound == 0.0);

  // Edges of weight 0 only: still one vertex (a larger clique is not better).
  Result<CliqueGraph> z = CliqueGraph::Create(5, true);
  REQUIRE(z.ok());
  for (int u = 0; u < 5; ++u) {
    for (int v = u + 1; v < 5; ++v) REQUIRE(z->AddEdge(u, v, 0.0).ok());
  }
  Result<CliqueSearchResult> ze = SolveMaxClique(*z, Params(CliqueObjective::kEdgeWeight));
  REQUIRE(ze.ok());
  CHECK(ze->status == CliqueSearchStatus::kOptimal);
  CHECK(ze->clique.size() == 1);
  CHECK(ze->objective == 0.0);
}

TEST_CASE("Max clique ignores isolated vertices and handles a clique spanning bitset words") {
  // 130 vertices: a 5-clique {3, 64, 65, 100, 129}, a heavy edge {10, 11}, the rest isolated.
  Result<CliqueGraph> g = CliqueGraph::Create(130, true);
  REQUIRE(g.ok());
  const std::vector<int> k = {3, 64, 65, 100, 129};
  for (std::size_t a = 0; a < k.size(); ++a) {
    for (std::size_t b = a + 1; b < k.size(); ++b) REQUIRE(g->AddEdge(k[a], k[b], 1.0).ok());
  }
  REQUIRE(g->AddEdge(10, 11, 25.0).ok());
  REQUIRE(g->SetVertexWeight(10, 3.0).ok());
  Result<CliqueSearchResult> c = SolveMaxClique(*g, Params(CliqueObjective::kCardinality));
  REQUIRE(c.ok());
  CHECK(c->clique == k);
  CHECK(c->objective == 5.0);
  Result<CliqueSearchResult> w = SolveMaxClique(*g, Params(CliqueObjective::kVertexWeight));
  REQUIRE(w.ok());
  CHECK(w->clique == k);
  CHECK(w->objective == 5.0);
  Result<CliqueSearchResult> e = SolveMaxClique(*g, Params(CliqueObjective::kEdgeWeight));
  REQUIRE(e.ok());
  CHECK(e->clique == std::vector<int>{10, 11});
  CHECK(e->objective == 25.0);
}

// G(n, p) with integer edge weights, for the limit tests.
CliqueGraph RandomCliqueGraph(int n, double p, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::uniform_int_distribution<int> w(1, 200);
  Result<CliqueGraph> g = CliqueGraph::Create(n, true);
  REQUIRE(g.ok());
  for (int v = 0; v < n; ++v) REQUIRE(g->SetVertexWeight(v, static_cast<double>(w(rng))).ok());
  for (int u = 0; u < n; ++u) {
    for (int v = u + 1; v < n; ++v) {
      if (unit(rng) < p) REQUIRE(g->AddEdge(u, v, static_cast<double>(w(rng))).ok());
    }
  }
  return std::move(*g);
}

bool IsClique(const CliqueGraph& g, const std::vector<int>& k) {
  for (std::size_t a = 0; a < k.size(); ++a) {
    for (std::size_t b = a + 1; b < k.size(); ++b) {
      if (!g.HasEdge(k[a], k[b])) return false;
    }
  }
  return !k.empty();
}

TEST_CASE("Max clique node limit of 1 returns a valid clique and a bound around the optimum") {
  const CliqueGraph g = RandomCliqueGraph(90, 0.6, 5U);
  for (CliqueObjective o : kObjectives) {
    CAPTURE(static_cast<int>(o));
    Result<CliqueSearchResult> full = SolveMaxClique(g, Params(o));
    REQUIRE(full.ok());
    REQUIRE(full->status == CliqueSearchStatus::kOptimal);
    CHECK(IsClique(g, full->clique));
    Result<CliqueSearchResult> one = SolveMaxClique(g, Params(o, 1));
    REQUIRE(one.ok());
    CHECK(one->status == CliqueSearchStatus::kLimitReached);
    CHECK(one->nodes == 1);
    CHECK(IsClique(g, one->clique));
    CHECK(one->objective <= full->objective);
    CHECK(full->objective <= one->upper_bound);
    CHECK(one->gap() > 0.0);
    CHECK(one->gap() <= 1.0);
  }
}

TEST_CASE("Max clique time limit returns the best clique so far with a valid bound") {
  const CliqueGraph g = RandomCliqueGraph(300, 0.5, 6U);
  CliqueSearchParams p = Params(CliqueObjective::kCardinality);
  Result<CliqueSearchResult> full = SolveMaxClique(g, p);
  REQUIRE(full.ok());
  REQUIRE(full->status == CliqueSearchStatus::kOptimal);
  p.time_limit_s = 1e-9;
  Result<CliqueSearchResult> r = SolveMaxClique(g, p);
  REQUIRE(r.ok());
  CHECK(r->status == CliqueSearchStatus::kLimitReached);
  CHECK(r->nodes < full->nodes);
  CHECK(IsClique(g, r->clique));
  CHECK(r->objective <= full->objective);
  CHECK(full->objective <= r->upper_bound);
}

// ---- small DIMACS instances vs the optima of ../shared/data/graphs ----

// Rows of a TSV file keyed by the "name" column; each row maps column name -> value.
std::map<std::string, TsvRow> ReadTsv(const std::string& path) {
  std::map<std::string, TsvRow> rows;
  for (TsvRow& row : test::ReadTsvFile(path)) {
    const std::string name = row["name"];
    rows[name] = std::move(row);
  }
  return rows;
}

void CheckDimacs(const std::string& tsv, const std::vector<std::string>& names, const char* column,
                 CliqueObjective o) {
  const std::string dir = tsv.substr(0, tsv.find_last_of('/') + 1);
  const auto rows = ReadTsv(tsv);
  for (const std::string& name : names) {
    CAPTURE(name);
    const auto it = rows.find(name);
    REQUIRE(it != rows.end());
    const double optimum = std::stod(it->second.at(column));
    const CliqueGraph g = test::LoadDimacsCliqueGraph(dir + it->second.at("file"), true);
    Result<CliqueSearchResult> r = SolveMaxClique(g, Params(o));
    REQUIRE(r.ok());
    CHECK(r->status == CliqueSearchStatus::kOptimal);
    CHECK(IsClique(g, r->clique));
    CHECK(r->objective == optimum);
    CHECK(r->upper_bound == optimum);
  }
}

TEST_CASE("Max clique cardinality on small DIMACS instances equals omega of optima.tsv") {
  CM_SHARED_DATA_OR_SKIP(tsv, "graphs/optima.tsv");
  CheckDimacs(tsv, {"johnson8-2-4", "hamming6-4", "MANN_a9", "c-fat200-1", "johnson8-4-4"}, "omega",
              CliqueObjective::kCardinality);
}

TEST_CASE("Max clique vertex-weighted on small DIMACS instances equals mwc_optima.tsv") {
  CM_SHARED_DATA_OR_SKIP(tsv, "graphs/mwc_optima.tsv");
  CheckDimacs(tsv, {"MANN_a9", "johnson16-2-4"}, "mwc_weight", CliqueObjective::kVertexWeight);
}

TEST_CASE("Max clique edge-weighted on small DIMACS instances equals mewc_optima.tsv") {
  CM_SHARED_DATA_OR_SKIP(tsv, "graphs/mewc_optima.tsv");
  CheckDimacs(tsv, {"johnson8-2-4", "hamming6-4", "c-fat200-1"}, "mewc_weight",
              CliqueObjective::kEdgeWeight);
}

}  // namespace
}  // namespace commerge
