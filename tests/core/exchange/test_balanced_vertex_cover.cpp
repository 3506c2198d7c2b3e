// SPDX-License-Identifier: BSD-3-Clause
// Stage B balanced vertex cover: our branch-and-bound vs exhaustive enumeration (thousands of random instances
// of <= 14 vertices, random participation vectors and shares) and vs GLPK's own MIP (glp_intopt on the same model)
// on random and structured exchange graphs of ~50-200 vertices; shares, limits, no-candidate and error cases.
#include <doctest/doctest.h>
#include <glpk.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/exchange/balanced_vertex_cover.hpp"

namespace commerge {
namespace {

int Popcount(unsigned x) { return __builtin_popcount(x); }

// Exact optimum by enumerating every subset of the non-isolated vertices; -1 when infeasible.
int BruteForceBalanced(const BipartiteGraph& g, int share) {
  const int n = g.left_count();
  const int total = n + g.right_count();
  unsigned candidates = 0;
  for (const BipartiteEdge& e : g.edges()) candidates |= (1U << e.left) | (1U << (n + e.right));
  const unsigned left_mask = (1U << n) - 1U;
  int best = -1;
  for (unsigned s = 0; s < (1U << total); ++s) {
    if ((s & ~candidates) != 0U) continue;
    if (Popcount(s & left_mask) < share || Popcount(s & ~left_mask) < share) continue;
    bool cover = true;
    for (const BipartiteEdge& e : g.edges()) {
      if (!(s >> e.left & 1U) && !(s >> (n + e.right) & 1U)) {
        cover = false;
        break;
      }
    }
    if (cover && (best < 0 || Popcount(s) < best)) best = Popcount(s);
  }
  return best;
}

// Reference: GLPK branch-and-cut (glp_intopt) on the same 0/1 model; -1 when infeasible.
int GlpkMipOptimum(const BipartiteGraph& g, int share) {
  const int n = g.left_count();
  const int total = n + g.right_count();
  std::vector<char> cand(static_cast<std::size_t>(total), 0);
  for (const BipartiteEdge& e : g.edges()) {
    cand[static_cast<std::size_t>(e.left)] = 1;
    cand[static_cast<std::size_t>(n + e.right)] = 1;
  }
  glp_term_out(GLP_OFF);
  glp_prob* p = glp_create_prob();
  glp_set_obj_dir(p, GLP_MIN);
  glp_add_cols(p, total);
  for (int v = 0; v < total; ++v) {
    glp_set_col_kind(p, v + 1, GLP_BV);
    glp_set_obj_coef(p, v + 1, 1.0);
    if (!cand[static_cast<std::size_t>(v)]) glp_set_col_bnds(p, v + 1, GLP_FX, 0.0, 0.0);
  }
  const int m = static_cast<int>(g.edges().size());
  glp_add_rows(p, m + 2);
  for (int i = 0; i < m; ++i) {
    const BipartiteEdge& e = g.edges()[static_cast<std::size_t>(i)];
    int ind[3] = {0, e.left + 1, n + e.right + 1};
    double val[3] = {0.0, 1.0, 1.0};
    glp_set_row_bnds(p, i + 1, GLP_LO, 1.0, 0.0);
    glp_set_mat_row(p, i + 1, 2, ind, val);
  }
  for (int side = 0; side < 2; ++side) {
    std::vector<int> ind(1, 0);
    std::vector<double> val(1, 0.0);
    for (int v = side == 0 ? 0 : n; v < (side == 0 ? n : total); ++v) {
      ind.push_back(v + 1);
      val.push_back(1.0);
    }
    glp_set_row_bnds(p, m + side + 1, GLP_LO, static_cast<double>(share), 0.0);
    glp_set_mat_row(p, m + side + 1, static_cast<int>(ind.size()) - 1, ind.data(), val.data());
  }
  glp_iocp parm;
  glp_init_iocp(&parm);
  parm.msg_lev = GLP_MSG_OFF;
  parm.presolve = GLP_ON;
  const int rc = glp_intopt(p, &parm);
  int result = -2;
  if (rc == 0 && glp_mip_status(p) == GLP_OPT) {
    result = static_cast<int>(std::lround(glp_mip_obj_val(p)));
  } else if (rc == GLP_ENOPFS || rc == GLP_ENODFS || glp_mip_status(p) == GLP_NOFEAS) {
    result = -1;
  }
  glp_delete_prob(p);
  return result;
}

// Checks everything a caller relies on: cover, shares, no isolated vertex, sorted unique indices, counts.
void CheckSelection(const BipartiteGraph& g, const BalancedCoverResult& r) {
  std::vector<char> l(static_cast<std::size_t>(g.left_count()), 0), rr(static_cast<std::size_t>(g.right_count()), 0);
  std::vector<int> deg_l(l.size(), 0), deg_r(rr.size(), 0);
  for (const BipartiteEdge& e : g.edges()) {
    ++deg_l[static_cast<std::size_t>(e.left)];
    ++deg_r[static_cast<std::size_t>(e.right)];
  }
  REQUIRE(std::is_sorted(r.selected_left.begin(), r.selected_left.end()));
  REQUIRE(std::is_sorted(r.selected_right.begin(), r.selected_right.end()));
  for (int u : r.selected_left) {
    REQUIRE(deg_l[static_cast<std::size_t>(u)] > 0);
    l[static_cast<std::size_t>(u)] = 1;
  }
  for (int v : r.selected_right) {
    REQUIRE(deg_r[static_cast<std::size_t>(v)] > 0);
    rr[static_cast<std::size_t>(v)] = 1;
  }
  for (const BipartiteEdge& e : g.edges()) {
    REQUIRE((l[static_cast<std::size_t>(e.left)] || rr[static_cast<std::size_t>(e.right)]));
  }
  REQUIRE(static_cast<int>(r.selected_left.size()) >= r.min_share_per_robot);
  REQUIRE(static_cast<int>(r.selected_right.size()) >= r.min_share_per_robot);
  REQUIRE(r.objective_scans == static_cast<int>(r.selected_left.size() + r.selected_right.size()));
  REQUIRE(r.lower_bound_scans <= r.objective_scans);
  REQUIRE(r.objective_scans >= r.max_matching_size);
}

BipartiteGraph MakeGraph(int n, int m, const std::vector<BipartiteEdge>& edges) {
  Result<BipartiteGraph> g = BipartiteGraph::Create(n, m, edges);
  REQUIRE(g.ok());
  return *g;
}

BipartiteGraph RandomSmall(std::mt19937& rng) {
  std::uniform_int_distribution<int> size(0, 7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = size(rng);
  const int m = size(rng);
  const double density = unit(rng);
  std::vector<BipartiteEdge> edges;
  for (int u = 0; u < n; ++u)
    for (int v = 0; v < m; ++v)
      if (unit(rng) < density) edges.push_back({u, v});
  return MakeGraph(n, m, edges);
}

void RunBruteForceBlock(unsigned seed, int instances) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const double kLeftShares[] = {0.5, 0.5, 0.3, 0.8, 1.0};
  int optimal = 0;
  int infeasible = 0;
  for (int trial = 0; trial < instances; ++trial) {
    const BipartiteGraph g = RandomSmall(rng);
    BalancedCoverParams params;
    const double q = kLeftShares[trial % 5];
    params.participation = {q, 1.0 - q};
    if (trial % 7 == 3) params.min_share_per_robot_override = static_cast<int>(rng() % 6U);
    Result<BalancedCoverResult> r = SolveBalancedVertexCover(g, params);
    REQUIRE(r.ok());
    if (g.edges().empty()) {
      REQUIRE(r->status == BalancedCoverStatus::kNoCandidates);
      REQUIRE(r->objective_scans == 0);
      continue;
    }
    const int brute = BruteForceBalanced(g, r->min_share_per_robot);
    if (brute < 0) {
      REQUIRE(r->status == BalancedCoverStatus::kInfeasible);
      ++infeasible;
      continue;
    }
    REQUIRE(r->status == BalancedCoverStatus::kOptimal);
    CheckSelection(g, *r);
    REQUIRE(r->objective_scans == brute);
    REQUIRE(r->lower_bound_scans == brute);
    ++optimal;
  }
  CHECK(optimal > instances / 2);
  CHECK(infeasible > 0);
}

TEST_CASE("Balanced cover equals exhaustive enumeration, random block 1") { RunBruteForceBlock(11U, 1000); }
TEST_CASE("Balanced cover equals exhaustive enumeration, random block 2") { RunBruteForceBlock(22U, 1000); }
TEST_CASE("Balanced cover equals exhaustive enumeration, random block 3") { RunBruteForceBlock(33U, 1000); }

TEST_CASE("Balanced share follows ceil of N_MM over 2 to the entropy") {
  CHECK(*BalancedShare(7, {}) == 4);
  CHECK(*BalancedShare(8, {0.5, 0.5}) == 4);
  CHECK(*BalancedShare(8, {1.0, 0.0}) == 8);  // H = 0: one effective robot
  CHECK(*BalancedShare(0, {}) == 0);
  // H(0.9, 0.1) = 0.469 bits -> 2^H = 1.384 -> ceil(10 / 1.384) = 8
  CHECK(*BalancedShare(10, {0.9, 0.1}) == 8);
  CHECK(*BalancedShare(9, {0.25, 0.25, 0.25, 0.25}) == 3);  // four robots: 2^H = 4
  CHECK(BalancedShare(5, {0.5, 0.6}).status().code() == StatusCode::kInvalidArgument);
  CHECK(BalancedShare(5, {-0.5, 1.5}).status().code() == StatusCode::kInvalidArgument);
  CHECK(BalancedShare(-1, {}).status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("Monologue example: K4,8 needs 6 balanced scans instead of 4") {
  std::vector<BipartiteEdge> edges;
  for (int u = 0; u < 4; ++u)
    for (int v = 0; v < 8; ++v) edges.push_back({u, v});
  const BipartiteGraph g = MakeGraph(4, 8, edges);
  Result<BalancedCoverResult> r = SolveBalancedVertexCover(g, {});
  REQUIRE(r.ok());
  CHECK(r->status == BalancedCoverStatus::kOptimal);
  CHECK(r->max_matching_size == 4);
  CHECK(r->min_share_per_robot == 2);
  CHECK(r->objective_scans == 6);
  CHECK(r->selected_left.size() == 4);
  CHECK(r->selected_right.size() == 2);
  CheckSelection(g, *r);
}

TEST_CASE("No candidates: empty graph and isolated vertices only, isolated vertices never selected") {
  Result<BalancedCoverResult> r = SolveBalancedVertexCover(MakeGraph(0, 0, {}), {});
  REQUIRE(r.ok());
  CHECK(r->status == BalancedCoverStatus::kNoCandidates);
  r = SolveBalancedVertexCover(MakeGraph(5, 3, {}), {});
  REQUIRE(r.ok());
  CHECK(r->status == BalancedCoverStatus::kNoCandidates);
  CHECK(r->selected_left.empty());
  CHECK(r->selected_right.empty());
  // One edge plus isolated vertices: share ceil(1/2) = 1 each -> both endpoints, no isolated vertex.
  const BipartiteGraph g = MakeGraph(5, 5, {{2, 3}});
  r = SolveBalancedVertexCover(g, {});
  REQUIRE(r.ok());
  CHECK(r->status == BalancedCoverStatus::kOptimal);
  CHECK(r->selected_left == std::vector<int>{2});
  CHECK(r->selected_right == std::vector<int>{3});
  CheckSelection(g, *r);
  // A share larger than the candidates of one side is infeasible (isolated vertices do not count).
  BalancedCoverParams params;
  params.min_share_per_robot_override = 2;
  r = SolveBalancedVertexCover(g, params);
  REQUIRE(r.ok());
  CHECK(r->status == BalancedCoverStatus::kInfeasible);
}

TEST_CASE("Bad parameters are InvalidArgument") {
  const BipartiteGraph g = MakeGraph(2, 2, {{0, 0}});
  BalancedCoverParams params;
  params.participation = {0.2, 0.2};
  CHECK(SolveBalancedVertexCover(g, params).status().code() == StatusCode::kInvalidArgument);
  params.participation = {0.2, 0.3, 0.5};
  CHECK(SolveBalancedVertexCover(g, params).status().code() == StatusCode::kInvalidArgument);
  params = {};
  params.max_nodes = 0;
  CHECK(SolveBalancedVertexCover(g, params).status().code() == StatusCode::kInvalidArgument);
  params = {};
  params.time_limit_s = 0.0;
  CHECK(SolveBalancedVertexCover(g, params).status().code() == StatusCode::kInvalidArgument);
}

class FailingLp final : public LpSolver {
 public:
  Result<LpSolution> Minimize(const LinearProgram&) override { return Status(StatusCode::kInternal, "engine down"); }
};

// ---- medium instances vs glp_intopt ----

BipartiteGraph Chain(int n) {  // path l0-r0-l1-r1-...
  std::vector<BipartiteEdge> e;
  for (int i = 0; i < n; ++i) {
    e.push_back({i, i});
    if (i + 1 < n) e.push_back({i + 1, i});
  }
  return MakeGraph(n, n, e);
}

BipartiteGraph Grid(int rows, int cols) {  // checkerboard colouring: black cells left, white cells right
  std::vector<int> id(static_cast<std::size_t>(rows * cols));
  int nl = 0;
  int nr = 0;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) id[static_cast<std::size_t>(r * cols + c)] = (r + c) % 2 == 0 ? nl++ : nr++;
  std::vector<BipartiteEdge> e;
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < cols; ++c) {
      if ((r + c) % 2 != 0) continue;
      const int a = id[static_cast<std::size_t>(r * cols + c)];
      const int dr[4] = {-1, 1, 0, 0};
      const int dc[4] = {0, 0, -1, 1};
      for (int k = 0; k < 4; ++k) {
        const int r2 = r + dr[k];
        const int c2 = c + dc[k];
        if (r2 >= 0 && r2 < rows && c2 >= 0 && c2 < cols) e.push_back({a, id[static_cast<std::size_t>(r2 * cols + c2)]});
      }
    }
  }
  return MakeGraph(nl, nr, e);
}

BipartiteGraph Complete(int n, int m) {
  std::vector<BipartiteEdge> e;
  for (int u = 0; u < n; ++u)
    for (int v = 0; v < m; ++v) e.push_back({u, v});
  return MakeGraph(n, m, e);
}

// Like sequential matching output: left i joins right j when |j - i * m / n| <= half_width, with random gaps.
BipartiteGraph DiagonalBand(int n, int m, double half_width, double keep, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<BipartiteEdge> e;
  for (int u = 0; u < n; ++u) {
    const double centre = static_cast<double>(u) * static_cast<double>(m) / static_cast<double>(n);
    for (int v = 0; v < m; ++v) {
      if (std::fabs(static_cast<double>(v) - centre) <= half_width && unit(rng) < keep) e.push_back({u, v});
    }
  }
  return MakeGraph(n, m, e);
}

// Hub-heavy: a few high-degree left vertices (a monologue-prone graph) plus sparse random edges.
BipartiteGraph Hubs(int n, int m, int hubs, double p, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<BipartiteEdge> e;
  for (int u = 0; u < n; ++u)
    for (int v = 0; v < m; ++v)
      if ((u < hubs && unit(rng) < 0.6) || unit(rng) < p) e.push_back({u, v});
  return MakeGraph(n, m, e);
}

void CheckAgainstGlpk(const BipartiteGraph& g, const BalancedCoverParams& params) {
  Result<BalancedCoverResult> r = SolveBalancedVertexCover(g, params);
  REQUIRE(r.ok());
  const int ref = GlpkMipOptimum(g, r->min_share_per_robot);
  REQUIRE(ref >= 0);
  REQUIRE(r->status == BalancedCoverStatus::kOptimal);
  CheckSelection(g, *r);
  REQUIRE(r->objective_scans == ref);
}

TEST_CASE("Balanced cover equals glp_intopt on chains and grids") {
  // Note: square-ish grids with q = 1/2 are the hardest case for the LP bound (x = 1/2 everywhere); 12 x 15 takes
  // ~1000 nodes, so the test keeps to grids of <= 105 cells.
  for (const double q : {0.5, 0.75}) {
    BalancedCoverParams params;
    params.participation = {q, 1.0 - q};
    CheckAgainstGlpk(Chain(50), params);
    CheckAgainstGlpk(Chain(99), params);
    CheckAgainstGlpk(Grid(8, 9), params);
    CheckAgainstGlpk(Grid(7, 15), params);
    CheckAgainstGlpk(Grid(4, 20), params);
  }
}

TEST_CASE("Balanced cover equals glp_intopt on complete, diagonal band and hub graphs") {
  std::mt19937 rng(7U);
  for (const double q : {0.5, 0.75}) {
    BalancedCoverParams params;
    params.participation = {q, 1.0 - q};
    CheckAgainstGlpk(Complete(5, 40), params);
    CheckAgainstGlpk(Complete(20, 23), params);
    CheckAgainstGlpk(DiagonalBand(60, 90, 2.0, 1.0, rng), params);
    CheckAgainstGlpk(DiagonalBand(100, 70, 3.0, 0.6, rng), params);
    CheckAgainstGlpk(Hubs(40, 60, 4, 0.03, rng), params);
  }
}

void RunGlpkRandomBlock(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> size(25, 100);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 5; ++trial) {
    const int n = size(rng);
    const int m = size(rng);
    const double avg_degree = 1.0 + 3.0 * unit(rng);
    const double p = avg_degree / static_cast<double>(m);
    std::vector<BipartiteEdge> e;
    for (int u = 0; u < n; ++u)
      for (int v = 0; v < m; ++v)
        if (unit(rng) < p) e.push_back({u, v});
    BalancedCoverParams params;
    params.participation = {0.5, 0.5};
    if (trial % 3 == 1) params.participation = {0.9, 0.1};
    CheckAgainstGlpk(MakeGraph(n, m, e), params);
  }
}

TEST_CASE("Balanced cover equals glp_intopt on random exchange graphs of 50 to 200 vertices, block 1") { RunGlpkRandomBlock(99U); }
TEST_CASE("Balanced cover equals glp_intopt on random exchange graphs of 50 to 200 vertices, block 2") { RunGlpkRandomBlock(98U); }
TEST_CASE("Balanced cover equals glp_intopt on random exchange graphs of 50 to 200 vertices, block 3") { RunGlpkRandomBlock(97U); }
TEST_CASE("Balanced cover equals glp_intopt on random exchange graphs of 50 to 200 vertices, block 4") { RunGlpkRandomBlock(96U); }

TEST_CASE("Node limit yields a feasible selection with a proven gap, LP errors propagate") {
  std::mt19937 rng(5U);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int gaps = 0;
  for (int trial = 0; trial < 40 && gaps < 3; ++trial) {
    std::vector<BipartiteEdge> e;
    for (int u = 0; u < 60; ++u)
      for (int v = 0; v < 60; ++v)
        if (unit(rng) < 0.05) e.push_back({u, v});
    const BipartiteGraph g = MakeGraph(60, 60, e);
    BalancedCoverParams params;
    params.max_nodes = 1;
    Result<BalancedCoverResult> r = SolveBalancedVertexCover(g, params);
    REQUIRE(r.ok());
    REQUIRE(r->nodes_explored <= 1);
    REQUIRE((r->status == BalancedCoverStatus::kOptimal || r->status == BalancedCoverStatus::kFeasibleWithGap));
    CheckSelection(g, *r);
    const int ref = GlpkMipOptimum(g, r->min_share_per_robot);
    REQUIRE(r->lower_bound_scans <= ref);
    REQUIRE(ref <= r->objective_scans);
    if (r->status == BalancedCoverStatus::kFeasibleWithGap) {
      ++gaps;
      REQUIRE(r->lower_bound_scans < r->objective_scans);
    } else {
      REQUIRE(r->objective_scans == ref);
    }
  }
  MESSAGE("instances with a gap after one node: " << gaps);

  FailingLp failing;
  // K4,8 needs the LP (the König bound 4 is below the optimum 6).
  Result<BalancedCoverResult> r = SolveBalancedVertexCover(Complete(4, 8), {}, &failing);
  CHECK(r.status().code() == StatusCode::kInternal);
}

}  // namespace
}  // namespace commerge
