// SPDX-License-Identifier: BSD-3-Clause
// Stage B balanced vertex cover: our branch-and-bound (SolveMultiRobotBalancedCover) vs GLPK's own MIP solver
// (glp_intopt with its default presolve, branching and backtracking) on the SAME 0/1 model: objective = total
// vertex weight, one cover row per edge, one share row per robot (the shares our solver derived), variables only
// for candidate (non-isolated) scans.
// Usage: bench_vertex_cover [--family NAME]... [--instance SUBSTRING] [--glpk-limit S] [--our-limit S] [--reps N]
//                           [--no-glpk] [--no-dense]
//   families: grid, blocks, random, band, nrobot, icra-unbalanced, icra-balanced, icra-unit, rss (default: all)
//   --glpk-limit: glp_intopt time limit in s (default 60); --our-limit: our time limit (default 60)
//   --reps: our solver runs N times, the median is reported (GLPK runs once; default 3)
//   --no-dense: skip the second timing of ours with the dense master simplex
// Prints one row per instance: vertices, edges, share, our time (default master LP engine: GLPK, warm-started),
// our time with the dense master simplex and the ratio of the two ("!" when the two engines end with different
// statuses or optima), GLPK's MIP time, speed-up (GLPK / ours), both optima and both statuses, our node,
// min-cut and master-LP counts and GLPK simplex iterations; then per-family geometric means of the master ratio,
// and of the speed-ups with the count of >= 10x rows.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <random>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "core/exchange/balanced_cover_milp.hpp"
#include "core/exchange/balanced_vertex_cover.hpp"
#include "core/exchange/exchange_graph.hpp"
#include "core/solvers/dimacs_graph.hpp"
#include "core/solvers/lp_relaxation.hpp"
#include "profiling/bench_common.hpp"
#include "tests/support/exchange_graph_generators.hpp"

namespace {

using commerge::BalancedCoverParams;
using commerge::BalancedCoverStatus;
using commerge::ExchangeEdge;
using commerge::ExchangeGraph;
using commerge::MakeCheckerboardGridGraph;
using commerge::Result;

struct Options {
  std::vector<std::string> families;
  double glpk_limit_s = 60.0;
  double our_limit_s = 60.0;
  int reps = 3;
  bool glpk = true;
  bool dense = true;  // also time our solver with the dense master simplex (MasterLpEngine::kDense)
  std::string only;  // run only instances whose name contains this
};

struct Instance {
  std::string family;
  std::string name;
  ExchangeGraph graph;
  BalancedCoverParams params;
};

struct Row {
  std::string family;
  double speedup = 0.0;
  bool equal = false;
  bool both_optimal = false;
  double master_ratio = 0.0;  // our time with the GLPK master / with the dense master (0 = not measured)
};

ExchangeGraph Make(std::vector<int> counts, std::vector<ExchangeEdge> edges) {
  auto g = ExchangeGraph::Create(std::move(counts), std::move(edges));
  if (!g.ok()) {
    std::fprintf(stderr, "bad graph: %s\n", g.status().ToString().c_str());
    std::exit(1);
  }
  return std::move(g).value();
}

// Checkerboard grid graph (core/solvers): black cells = robot 0, white cells = robot 1, 4-neighbour edges.
ExchangeGraph Grid(int rows, int cols) {
  auto grid = MakeCheckerboardGridGraph(rows, cols);
  auto g = grid.ok() ? ExchangeGraph::FromBipartite(*grid) : Result<ExchangeGraph>(grid.status());
  if (!g.ok()) {
    std::fprintf(stderr, "bad grid graph: %s\n", g.status().ToString().c_str());
    std::exit(1);
  }
  return std::move(g).value();
}

// `blocks` complete-ish bipartite blocks K_{k,l} (each edge kept with probability keep), chained by one edge.
ExchangeGraph Blocks(int blocks, int k, int l, double keep, std::mt19937& rng) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int na = blocks * k;
  std::vector<ExchangeEdge> e;
  for (int b = 0; b < blocks; ++b) {
    for (int u = 0; u < k; ++u)
      for (int v = 0; v < l; ++v)
        if (unit(rng) < keep) e.push_back({b * k + u, na + b * l + v});
    if (b + 1 < blocks) e.push_back({b * k + k - 1, na + (b + 1) * l});
  }
  return Make({na, blocks * l}, e);
}

// Two robots from bipartite edges (left u, right v): robot 0 holds vertices 0..n-1, robot 1 n..n+m-1.
ExchangeGraph TwoRobots(int n, int m, const std::vector<commerge::BipartiteEdge>& bipartite) {
  std::vector<ExchangeEdge> e;
  e.reserve(bipartite.size());
  for (const commerge::BipartiteEdge& b : bipartite) e.push_back({b.left, n + b.right});
  return Make({n, m}, e);
}

// The random graph families of the test (tests/support/exchange_graph_generators.hpp).
ExchangeGraph RandomBipartite(int n, int m, double avg_degree, std::mt19937& rng) {
  return TwoRobots(n, m, commerge::test::RandomBipartiteEdges(n, m, avg_degree, rng));
}

// Stage-A-like output: left i joins right j when |j - i * m / n| <= half_width, each kept with probability keep.
ExchangeGraph Band(int n, int m, double half_width, double keep, std::mt19937& rng) {
  return TwoRobots(n, m, commerge::test::DiagonalBandEdges(n, m, half_width, keep, rng));
}

// N robots with `per_robot` scans each; every pair of scans of two robots is a candidate loop at random.
ExchangeGraph RandomMultiRobot(int robots, int per_robot, double avg_degree, std::mt19937& rng) {
  std::vector<int> counts(static_cast<std::size_t>(robots), per_robot);
  std::vector<ExchangeEdge> e = commerge::test::RandomMultiRobotEdges(counts, avg_degree, rng);
  return Make(std::move(counts), std::move(e));
}

// Every random instance has its own generator, seeded from its name, so a family or instance filter never changes
// the instances.
std::mt19937 SeededBy(const std::string& name) {
  std::uint32_t h = 2166136261U;  // FNV-1a
  for (const char c : name) h = (h ^ static_cast<unsigned char>(c)) * 16777619U;
  return std::mt19937(h);
}

std::vector<double> RandomWeights(int n, std::mt19937& rng) {
  std::uniform_int_distribution<int> w(1, 100);
  std::vector<double> out(static_cast<std::size_t>(n));
  for (double& x : out) x = w(rng);
  return out;
}

bool LoadDimacs(const std::string& path, ExchangeGraph* g, std::vector<double>* weights) {
  std::ifstream f(path);
  if (!f) return false;
  std::stringstream ss;
  ss << f.rdbuf();
  auto d = commerge::ParseDimacsGraph(ss.str(), path);
  auto eg = d.ok() ? ExchangeGraph::FromDimacs(*d, path) : commerge::Result<ExchangeGraph>(d.status());
  if (!eg.ok()) {
    std::fprintf(stderr, "%s\n", eg.status().ToString().c_str());
    return false;
  }
  *g = std::move(*eg);
  *weights = std::move(d->vertex_weights);
  return true;
}

struct GlpkOutcome {
  commerge::MipStatus status = commerge::MipStatus::kNoSolution;
  double objective = 0.0;
  double ms = 0.0;
};

GlpkOutcome RunGlpk(const ExchangeGraph& g, const std::vector<double>& weights, const std::vector<int>& shares,
                    double limit_s) {
  auto lp = commerge::BalancedCoverMilp(g, weights, shares);
  if (!lp.ok()) return {};
  const std::size_t nv = lp->objective.size();
  commerge::MipOptions opt;
  opt.time_limit_s = limit_s;
  GlpkOutcome out;
  const auto t0 = std::chrono::steady_clock::now();
  auto sol = commerge::SolveMipWithGlpk(*lp, std::vector<bool>(nv, true), opt);
  out.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  if (sol.ok()) {
    out.status = sol->status;
    out.objective = sol->objective;
  }
  return out;
}

const char* MipName(commerge::MipStatus s) {
  switch (s) {
    case commerge::MipStatus::kOptimal: return "optimal";
    case commerge::MipStatus::kFeasible: return "time-limit";
    case commerge::MipStatus::kInfeasible: return "infeasible";
    case commerge::MipStatus::kNoSolution: return "no-solution";
    case commerge::MipStatus::kUnbounded: return "unbounded";
  }
  return "?";
}

bool Wanted(const Options& o, const std::string& family) {
  return o.families.empty() || std::find(o.families.begin(), o.families.end(), family) != o.families.end();
}

void RunInstance(const Options& o, Instance& inst, std::vector<Row>* rows) {
  if (!o.only.empty() && inst.name.find(o.only) == std::string::npos) return;
  inst.params.time_limit_s = o.our_limit_s;
  inst.params.max_nodes = 100000000;
  commerge::Result<commerge::MultiRobotCoverResult> res = commerge::SolveMultiRobotBalancedCover(inst.graph, inst.params);
  if (!res.ok()) {
    std::printf("%-14s %-34s error: %s\n", inst.family.c_str(), inst.name.c_str(), res.status().ToString().c_str());
    return;
  }
  std::vector<double> ms = commerge::bench::TimeMs(o.reps, [&] {
    res = commerge::SolveMultiRobotBalancedCover(inst.graph, inst.params);
  });
  const double ours_ms = commerge::bench::Median(ms);
  // The same solver with the dense master simplex: its time, and whether it reaches the same optimum.
  double dense_ms = 0.0;
  bool dense_equal = true;
  if (o.dense) {
    Instance dense = inst;
    dense.params.master_lp = commerge::MasterLpEngine::kDense;
    commerge::Result<commerge::MultiRobotCoverResult> dres = commerge::SolveMultiRobotBalancedCover(dense.graph, dense.params);
    std::vector<double> dms = commerge::bench::TimeMs(o.reps, [&] {
      dres = commerge::SolveMultiRobotBalancedCover(dense.graph, dense.params);
    });
    dense_ms = commerge::bench::Median(dms);
    dense_equal = dres.ok() && dres->status == res->status &&
                  std::fabs(dres->objective_weight - res->objective_weight) <= 1e-6 * std::max(1.0, res->objective_weight);
  }
  int share = 0;
  for (int s : res->share_per_robot) share = std::max(share, s);
  GlpkOutcome gl;
  if (o.glpk) gl = RunGlpk(inst.graph, inst.params.vertex_weights, res->share_per_robot, o.glpk_limit_s);
  const bool ours_opt = res->status == BalancedCoverStatus::kOptimal;
  const bool glpk_opt = gl.status == commerge::MipStatus::kOptimal;
  const bool equal = std::fabs(gl.objective - res->objective_weight) <= 1e-6 * std::max(1.0, gl.objective);
  const double speedup = o.glpk && ours_ms > 0.0 ? gl.ms / ours_ms : 0.0;
  const double master_ratio = o.dense && dense_ms > 0.0 ? ours_ms / dense_ms : 0.0;
  std::printf("%-14s %-34s %6d %7zu %5d %10.2f %10.2f %6.2f%s %10.1f %8.1fx %12.0f %12.0f %-8s %-11s %s %8lld %8lld %8lld %7lld\n",
              inst.family.c_str(), inst.name.c_str(), inst.graph.vertex_count(), inst.graph.edges().size(), share,
              ours_ms, dense_ms, master_ratio, dense_equal ? " " : "!", gl.ms, speedup, res->objective_weight,
              gl.objective, ours_opt ? "optimal" : commerge::BalancedCoverStatusName(res->status), MipName(gl.status),
              !o.glpk ? "  " : (equal ? "==" : "!="), static_cast<long long>(res->nodes_explored),
              static_cast<long long>(res->min_cut_solves), static_cast<long long>(res->lp_solves),
              static_cast<long long>(res->simplex_iterations));
  std::fflush(stdout);
  rows->push_back({inst.family, speedup, equal, ours_opt && glpk_opt, master_ratio});
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--family") == 0 && i + 1 < argc) {
      o.families.push_back(argv[++i]);
    } else if (std::strcmp(argv[i], "--glpk-limit") == 0 && i + 1 < argc) {
      o.glpk_limit_s = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--our-limit") == 0 && i + 1 < argc) {
      o.our_limit_s = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--reps") == 0 && i + 1 < argc) {
      o.reps = std::atoi(argv[++i]);
    } else if (std::strcmp(argv[i], "--instance") == 0 && i + 1 < argc) {
      o.only = argv[++i];
    } else if (std::strcmp(argv[i], "--no-glpk") == 0) {
      o.glpk = false;
    } else if (std::strcmp(argv[i], "--no-dense") == 0) {
      o.dense = false;
    } else {
      std::fprintf(stderr,
                   "usage: %s [--family grid|blocks|random|band|nrobot|icra-unbalanced|icra-balanced|icra-unit|rss]... "
                   "[--instance SUBSTRING] [--glpk-limit S] [--our-limit S] [--reps N] [--no-glpk] [--no-dense]\n",
                   argv[0]);
      return 2;
    }
  }
  if (o.reps < 1 || !(o.glpk_limit_s > 0.0) || !(o.our_limit_s > 0.0)) {
    std::fprintf(stderr, "--reps must be >= 1 and the limits > 0\n");
    return 2;
  }
  std::printf("glp_intopt: default presolve/branching/backtracking, time limit %.0f s; ours: time limit %.0f s, "
              "median of %d runs\n",
              o.glpk_limit_s, o.our_limit_s, o.reps);
  std::printf("%-14s %-34s %6s %7s %5s %10s %10s %7s %10s %9s %12s %12s %-8s %-11s %s %8s %8s %8s %7s\n", "family",
              "instance", "V", "E", "share", "ours_ms", "dense_ms", "ratio", "glpk_ms", "speedup", "ours_opt",
              "glpk_opt", "ours", "glpk", "eq", "nodes", "mincuts", "masters", "simplex");
  std::vector<Row> rows;

  if (Wanted(o, "grid")) {
    const int sizes[][2] = {{6, 8}, {8, 9}, {10, 10}, {10, 12}, {12, 15}, {14, 14}, {4, 40}};
    for (const auto& sz : sizes) {
      Instance inst{"grid", "grid_" + std::to_string(sz[0]) + "x" + std::to_string(sz[1]) + "_p0.5",
                    Grid(sz[0], sz[1]), {}};
      RunInstance(o, inst, &rows);
    }
  }
  if (Wanted(o, "blocks")) {
    const int cfg[][3] = {{4, 6, 9}, {8, 5, 7}, {6, 10, 12}, {12, 8, 8}};
    for (const auto& c : cfg) {
      const std::string name =
          "blocks_" + std::to_string(c[0]) + "xK" + std::to_string(c[1]) + "," + std::to_string(c[2]);
      std::mt19937 rng = SeededBy(name);
      Instance inst{"blocks", name, Blocks(c[0], c[1], c[2], 0.85, rng), {}};
      RunInstance(o, inst, &rows);
    }
  }
  if (Wanted(o, "random")) {
    const int sizes[] = {50, 100, 200, 300, 500};
    for (int total : sizes) {
      for (const bool weighted : {false, true}) {
        for (const double deg : {2.0, 4.0}) {
          const int n = total * 9 / 20;
          const std::string name = "rand_" + std::to_string(total) + "_deg" + std::to_string(static_cast<int>(deg)) +
                                   (weighted ? "_w" : "_u");
          std::mt19937 rng = SeededBy(name);
          Instance inst{"random", name, RandomBipartite(n, total - n, deg, rng), {}};
          if (weighted) inst.params.vertex_weights = RandomWeights(inst.graph.vertex_count(), rng);
          RunInstance(o, inst, &rows);
        }
      }
    }
  }
  if (Wanted(o, "band")) {
    const int cfg[][3] = {{100, 130, 2}, {300, 250, 3}, {500, 600, 4}, {1000, 900, 3}, {2000, 2000, 5}};
    for (const auto& c : cfg) {
      for (const bool weighted : {false, true}) {
        const std::string name = "band_" + std::to_string(c[0]) + "x" + std::to_string(c[1]) + "_w" +
                                 std::to_string(c[2]) + (weighted ? "_w" : "_u");
        std::mt19937 rng = SeededBy(name);
        Instance inst{"band", name, Band(c[0], c[1], c[2], 0.7, rng), {}};
        if (weighted) inst.params.vertex_weights = RandomWeights(inst.graph.vertex_count(), rng);
        RunInstance(o, inst, &rows);
      }
    }
  }
  if (Wanted(o, "nrobot")) {
    const int cfg[][2] = {{3, 40}, {3, 100}, {4, 60}, {4, 150}, {5, 100}};
    for (const auto& c : cfg) {
      for (const bool weighted : {false, true}) {
        const std::string name =
            "rand_" + std::to_string(c[0]) + "robots_" + std::to_string(c[1]) + (weighted ? "_w" : "_u");
        std::mt19937 rng = SeededBy(name);
        Instance inst{"nrobot", name, RandomMultiRobot(c[0], c[1], 2.5, rng), {}};
        if (weighted) inst.params.vertex_weights = RandomWeights(inst.graph.vertex_count(), rng);
        RunInstance(o, inst, &rows);
      }
    }
  }
  const std::string dir = commerge::bench::SharedDataDir() + "/graphs/exchange_cslam_resource/";
  const bool icra = Wanted(o, "icra-unbalanced") || Wanted(o, "icra-balanced") || Wanted(o, "icra-unit");
  if (icra) {
    std::ifstream tsv(dir + "exchange_graphs.tsv");
    if (!tsv) std::printf("(exchange graphs not found under %s: ICRA families skipped)\n", dir.c_str());
    std::string line;
    std::getline(tsv, line);  // header
    while (std::getline(tsv, line)) {
      const std::string name = line.substr(0, line.find('\t'));
      ExchangeGraph g;
      std::vector<double> w;
      if (!LoadDimacs(dir + name + ".dimacs", &g, &w)) continue;
      const std::string shortname = name.substr(std::strlen("icra18_"));
      if (Wanted(o, "icra-unbalanced")) {
        Instance inst{"icra-unbal", shortname, g, {}};
        inst.params.vertex_weights = w;
        inst.params.min_share_per_robot_override = 0;
        RunInstance(o, inst, &rows);
      }
      if (Wanted(o, "icra-balanced")) {
        Instance inst{"icra-bal-w", shortname, g, {}};
        inst.params.vertex_weights = w;
        RunInstance(o, inst, &rows);
      }
      if (Wanted(o, "icra-unit")) {
        Instance inst{"icra-bal-u", shortname, g, {}};
        RunInstance(o, inst, &rows);
      }
    }
  }
  if (Wanted(o, "rss")) {
    ExchangeGraph g;
    std::vector<double> w;
    if (LoadDimacs(dir + "rss18_kitti00_5robots.dimacs", &g, &w)) {
      Instance unbalanced{"rss-5robots", "unbalanced_unit", g, {}};
      unbalanced.params.min_share_per_robot_override = 0;
      RunInstance(o, unbalanced, &rows);
      Instance balanced{"rss-5robots", "balanced_unit_uniform_p", g, {}};
      RunInstance(o, balanced, &rows);
      Instance skewed{"rss-5robots", "balanced_unit_p.4.3.1.1.1", g, {}};
      skewed.params.participation = {0.4, 0.3, 0.1, 0.1, 0.1};
      RunInstance(o, skewed, &rows);
      Instance weighted{"rss-5robots", "balanced_random_weights", g, {}};
      std::mt19937 rng = SeededBy(weighted.name);
      weighted.params.vertex_weights = RandomWeights(g.vertex_count(), rng);
      RunInstance(o, weighted, &rows);
    } else {
      std::printf("(rss18_kitti00_5robots.dimacs not found: family skipped)\n");
    }
  }

  if (o.dense) {
    std::map<std::string, std::vector<const Row*>> by_family;
    for (const Row& r : rows) by_family[r.family].push_back(&r);
    std::printf("\nours with the GLPK master / with the dense master (time ratio; > 1: GLPK slower)\n");
    std::printf("family          instances  geo-mean ratio  max ratio\n");
    double all_log = 0.0;
    for (const auto& [family, list] : by_family) {
      double log_sum = 0.0;
      double max_ratio = 0.0;
      for (const Row* r : list) {
        log_sum += std::log(std::max(r->master_ratio, 1e-9));
        max_ratio = std::max(max_ratio, r->master_ratio);
      }
      all_log += log_sum;
      std::printf("%-15s %9zu %15.2f %10.2f\n", family.c_str(), list.size(),
                  std::exp(log_sum / static_cast<double>(list.size())), max_ratio);
    }
    if (!rows.empty()) std::printf("all             %9zu %15.2f\n", rows.size(), std::exp(all_log / static_cast<double>(rows.size())));
  }
  if (o.glpk) {
    std::map<std::string, std::vector<const Row*>> by_family;
    for (const Row& r : rows) by_family[r.family].push_back(&r);
    std::printf("\nfamily          instances  geo-mean speed-up  min speed-up  >=10x  equal optima  both optimal\n");
    for (const auto& [family, list] : by_family) {
      double log_sum = 0.0;
      double min_speedup = 1e300;
      int ten = 0;
      int equal = 0;
      int both = 0;
      for (const Row* r : list) {
        log_sum += std::log(std::max(r->speedup, 1e-9));
        min_speedup = std::min(min_speedup, r->speedup);
        ten += r->speedup >= 10.0 ? 1 : 0;
        equal += r->equal ? 1 : 0;
        both += r->both_optimal ? 1 : 0;
      }
      std::printf("%-15s %9zu %18.1fx %12.1fx %6d %13d %13d\n", family.c_str(), list.size(),
                  std::exp(log_sum / static_cast<double>(list.size())), min_speedup, ten, equal, both);
    }
  }
  return 0;
}
