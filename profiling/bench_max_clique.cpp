// SPDX-License-Identifier: BSD-3-Clause
// Maximum clique branch-and-bound (core/solvers/max_clique) on the DIMACS benchmarks of ../shared/data/graphs,
// and against GLPK's own MIP (glp_intopt) on the same models.
// Usage: bench_max_clique [--only NAME] [--objective cardinality|vertex|edge] [--time-limit-s S]
//                         [--glpk-time-limit-s S] [--quick] [--no-glpk]
//   --only NAME          one instance (all objectives it appears in, or only --objective)
//   --time-limit-s S     our per-instance limit (default 120 s; "proven" says whether the search completed)
//   --glpk-time-limit-s  GLPK's per-instance limit (default 60 s; "timeout" when it hits)
//   --quick              our limit 5 s, GLPK limit 10 s, GLPK only on the four smallest instances
// time_ms is wall-clock time, cpu_ms this process's CPU time (steadier on a shared machine).
// Tables, one line per instance and objective:
//   1. cardinality (optima.tsv omega), 2. vertex weights w(i) = i mod 200 + 1 (mwc_optima.tsv), 3. edge weights
//   w(u,v) = (u+v) mod 200 + 1 on 1-based ids (mewc_optima.tsv; rows whose status is not exact are lower bounds).
//   The edge table runs ours three times: the default parameters (the LP bound of clique_lp_bound.hpp solved once
//   the search passes lp_after_nodes = 1 000 000 nodes; lp_bound is that LP's bound, "-" when not solved), the LP
//   at the root (lp_after_nodes = 0: every instance pays for one LP solve) and without the LP (lp_bound = false,
//   colouring bounds only). "upper" is the upper bound reported at the limit (the optimum when proven).
//   4. GLPK comparison. MEWC model: x_v binary, y_uv in [0, 1] for every edge with y_uv <= x_u and y_uv <= x_v,
//   x_u + x_v <= 1 for every non-edge, maximise sum w_uv y_uv (y may stay continuous: for binary x the best y is
//   min(x_u, x_v), binary). Cardinality model: x_v binary, x_u + x_v <= 1 for non-edges, maximise sum x_v.
//   GLPK runs with presolve and its clique cuts on; its time is glp_intopt alone (model building excluded), ours
//   is the whole SolveMaxClique call (ordering, greedy, search).
// The instances the heavy test skips for the CI budget (see tests/core/solvers_heavy/test_max_clique_dimacs.cpp)
// are measured here.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/common/bytes.hpp"
#include "core/common/tsv_table.hpp"
#include "core/solvers/dimacs_graph.hpp"
#include "core/solvers/max_clique.hpp"
#include "platform/io/file_util.hpp"
#include "platform/memory/peak_rss.hpp"
#include "profiling/bench_common.hpp"
#include "profiling/glpk_reference.hpp"

namespace {

using commerge::CliqueGraph;
using commerge::CliqueObjective;
using commerge::CliqueSearchParams;
using commerge::CliqueSearchResult;
using commerge::CliqueSearchStatus;

struct Options {
  std::string only;
  std::string objective;  // empty: all three
  double time_limit_s = 120.0;
  double glpk_time_limit_s = 60.0;
  bool quick = false;
  bool glpk = true;
};

bool ParseOptions(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (std::strcmp(argv[i], "--only") == 0 && has_value) {
      o->only = argv[++i];
    } else if (std::strcmp(argv[i], "--time-limit-s") == 0 && has_value) {
      o->time_limit_s = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--glpk-time-limit-s") == 0 && has_value) {
      o->glpk_time_limit_s = std::atof(argv[++i]);
    } else if (std::strcmp(argv[i], "--quick") == 0) {
      o->quick = true;
      o->time_limit_s = 5.0;
      o->glpk_time_limit_s = 10.0;
    } else if (std::strcmp(argv[i], "--objective") == 0 && has_value) {
      o->objective = argv[++i];
    } else if (std::strcmp(argv[i], "--no-glpk") == 0) {
      o->glpk = false;
    } else {
      std::fprintf(stderr,
                   "usage: %s [--only NAME] [--objective cardinality|vertex|edge] [--time-limit-s S] "
                   "[--glpk-time-limit-s S] [--quick] [--no-glpk]\n",
                   argv[0]);
      return false;
    }
  }
  if (!o->objective.empty() && o->objective != "cardinality" && o->objective != "vertex" && o->objective != "edge") {
    std::fprintf(stderr, "--objective must be cardinality, vertex or edge\n");
    return false;
  }
  if (!(o->time_limit_s > 0.0) || !(o->glpk_time_limit_s > 0.0)) {
    std::fprintf(stderr, "time limits must be > 0\n");
    return false;
  }
  return true;
}

using Row = commerge::TsvRow;

// TSV rows in file order, each as column name -> value.
std::vector<Row> ReadTsv(const std::string& path) {
  auto text = commerge::platform::ReadTextFile(path);
  if (!text.ok()) {
    std::fprintf(stderr, "%s\n", text.status().ToString().c_str());
    return {};
  }
  return commerge::ParseTsvTable(*text);
}

struct Instance {
  commerge::DimacsGraph dimacs;
  CliqueGraph graph;
};

// Vertex weights from the file's "n" lines (if any); edge weights (u+v) mod 200 + 1 on 1-based ids.
bool Load(const std::string& path, Instance* inst) {
  auto text = commerge::platform::ReadTextFile(path);
  if (!text.ok()) {
    std::fprintf(stderr, "%s\n", text.status().ToString().c_str());
    return false;
  }
  auto d = commerge::ParseDimacsGraph(*text, path);
  if (!d.ok()) {
    std::fprintf(stderr, "%s\n", d.status().ToString().c_str());
    return false;
  }
  auto g = CliqueGraph::Create(d->num_vertices, d->num_vertices <= commerge::kMaxEdgeWeightedCliqueVertices);
  if (!g.ok()) {
    std::fprintf(stderr, "%s\n", g.status().ToString().c_str());
    return false;
  }
  for (const auto& e : d->edges) {
    if (!g->AddEdge(e.first, e.second, static_cast<double>((e.first + e.second + 2) % 200 + 1)).ok()) return false;
  }
  for (std::size_t v = 0; v < d->vertex_weights.size(); ++v) {
    if (!g->SetVertexWeight(static_cast<int>(v), d->vertex_weights[v]).ok()) return false;
  }
  inst->dimacs = std::move(*d);
  inst->graph = std::move(*g);
  return true;
}

struct Timed {
  CliqueSearchResult result;
  double ms = 0.0;      // wall clock
  double cpu_ms = 0.0;  // process CPU time (std::clock): steadier than wall time on a shared machine
  bool ok = false;
};

enum class LpMode { kDefault, kRoot, kOff };

Timed Solve(const CliqueGraph& g, CliqueObjective objective, double time_limit_s, LpMode lp = LpMode::kDefault) {
  CliqueSearchParams p;
  p.objective = objective;
  p.time_limit_s = time_limit_s;
  p.max_nodes = std::int64_t{1} << 62;
  if (lp == LpMode::kRoot) p.lp_after_nodes = 0;
  if (lp == LpMode::kOff) p.lp_bound = false;
  Timed t;
  const auto start = std::chrono::steady_clock::now();
  const std::clock_t cpu_start = std::clock();
  auto r = commerge::SolveMaxClique(g, p);
  t.cpu_ms = 1e3 * static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  t.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  if (!r.ok()) {
    std::fprintf(stderr, "solve failed: %s\n", r.status().ToString().c_str());
    return t;
  }
  t.ok = true;
  t.result = std::move(*r);
  return t;
}

const char* ObjectiveName(CliqueObjective o) {
  return o == CliqueObjective::kCardinality ? "cardinality" : (o == CliqueObjective::kVertexWeight ? "vertex" : "edge");
}

// One table: every row of `tsv` (column `column` holds the optimum), solved under `objective`.
void RunTable(const std::string& dir, const char* tsv, const char* column, CliqueObjective objective,
              const Options& opt, std::map<std::string, Timed>* ours) {
  if (!opt.objective.empty() && opt.objective != ObjectiveName(objective)) return;
  const std::vector<Row> rows = ReadTsv(dir + "/" + tsv);
  std::printf("\n== %s objective: %s (column %s), our limit %.0f s ==\n", ObjectiveName(objective), tsv, column,
              opt.time_limit_s);
  const bool edge = objective == CliqueObjective::kEdgeWeight;
  if (edge) {
    std::printf("columns: default parameters | r_* LP at the root | o_* no LP\n");
    std::printf("%-16s %5s %7s %8s %8s | %-6s %9s %10s %8s %8s | %-6s %9s %10s %8s %8s | %-6s %9s %10s %8s | %s\n",
                "name", "n", "m", "optimum", "ours", "proven", "time_ms", "nodes", "upper", "lp_bound", "r_prov",
                "r_ms", "r_nodes", "r_upper", "r_lp", "o_prov", "o_ms", "o_nodes", "o_upper", "note");
  } else {
    std::printf("%-16s %5s %7s %10s %10s %-7s %10s %10s %12s %s\n", "name", "n", "m", "optimum", "ours", "proven",
                "time_ms", "cpu_ms", "nodes", "note");
  }
  int solved = 0;
  int proven = 0;
  int listed = 0;
  double total_ms = 0.0;
  for (const Row& row : rows) {
    const std::string& name = row.at("name");
    if (!opt.only.empty() && name != opt.only) continue;
    Instance inst;
    if (!Load(dir + "/" + row.at("file"), &inst)) continue;
    const double optimum = std::atof(row.at(column).c_str());
    // mewc_optima.tsv: "exact: ..." (computed) or "published: ..." (BBEWC's value, witness verified); anything
    // else would be a lower bound.
    const std::string source = row.count("source_of_optimum") ? row.at("source_of_optimum") : "";
    const bool exact_optimum = objective != CliqueObjective::kEdgeWeight || source.rfind("exact", 0) == 0 ||
                               source.rfind("published", 0) == 0;
    const Timed t = Solve(inst.graph, objective, opt.time_limit_s);
    if (!t.ok) continue;
    ++listed;
    const bool is_proven = t.result.status == CliqueSearchStatus::kOptimal;
    proven += is_proven ? 1 : 0;
    const bool agrees = std::fabs(t.result.objective - optimum) < 1e-6;
    solved += (is_proven && agrees) ? 1 : 0;
    total_ms += t.ms;
    std::string note;
    if (!exact_optimum) note = "TSV value is a lower bound only";
    if (!agrees && exact_optimum && is_proven) note = "MISMATCH";
    if (edge) {
      const Timed root = Solve(inst.graph, objective, opt.time_limit_s, LpMode::kRoot);
      const Timed off = Solve(inst.graph, objective, opt.time_limit_s, LpMode::kOff);
      if (!root.ok || !off.ok) continue;
      for (const Timed* other : {&root, &off}) {
        const bool both_proven = is_proven && other->result.status == CliqueSearchStatus::kOptimal;
        if (both_proven && other->result.clique != t.result.clique) {
          note += note.empty() ? "CLIQUE DIFFERS" : "; CLIQUE DIFFERS";
        }
      }
      auto lp_text = [](const CliqueSearchResult& r) {
        char buf[32];
        if (std::isnan(r.lp_bound)) {
          std::snprintf(buf, sizeof buf, "%s", r.lp_status == commerge::CliqueLpStatus::kTooLarge ? "large" : "-");
        } else {
          std::snprintf(buf, sizeof buf, "%.0f", r.lp_bound);
        }
        return std::string(buf);
      };
      auto yes = [](const Timed& x) { return x.result.status == CliqueSearchStatus::kOptimal ? "yes" : "NO"; };
      std::printf("%-16s %5d %7zu %8.0f %8.0f | %-6s %9.1f %10lld %8.0f %8s | %-6s %9.1f %10lld %8.0f %8s | %-6s %9.1f "
                  "%10lld %8.0f | %s\n",
                  name.c_str(), inst.graph.num_vertices(), inst.graph.num_edges(), optimum, t.result.objective, yes(t),
                  t.ms, static_cast<long long>(t.result.nodes), t.result.upper_bound, lp_text(t.result).c_str(),
                  yes(root), root.ms, static_cast<long long>(root.result.nodes), root.result.upper_bound,
                  lp_text(root.result).c_str(), yes(off), off.ms, static_cast<long long>(off.result.nodes),
                  off.result.upper_bound, note.c_str());
      std::fflush(stdout);
      (*ours)[name] = t;
      continue;
    }
    if (!is_proven) {
      char buf[96];
      std::snprintf(buf, sizeof buf, "%supper bound %.0f", note.empty() ? "" : "; ", t.result.upper_bound);
      note += buf;
    }
    std::printf("%-16s %5d %7zu %10.0f %10.0f %-7s %10.1f %10.1f %12lld %s\n", name.c_str(),
                inst.graph.num_vertices(), inst.graph.num_edges(), optimum, t.result.objective, is_proven ? "yes" : "NO",
                t.ms, t.cpu_ms, static_cast<long long>(t.result.nodes), note.c_str());
    std::fflush(stdout);
    (*ours)[name] = t;
  }
  std::printf("-- %d instances, %d proven, %d proven and equal to the TSV value, total %.1f s\n", listed, proven,
              solved, total_ms / 1e3);
}

void RunGlpkTable(const std::string& dir, const Options& opt, CliqueObjective objective,
                  const std::vector<std::string>& names) {
  if (!opt.objective.empty() && opt.objective != ObjectiveName(objective)) return;
  const std::vector<Row> rows = ReadTsv(dir + "/optima.tsv");
  std::printf("\n== %s objective: ours vs GLPK glp_intopt (GLPK limit %.0f s, ours %.0f s) ==\n", ObjectiveName(objective),
              opt.glpk_time_limit_s, opt.time_limit_s);
  const bool edge = objective == CliqueObjective::kEdgeWeight;
  if (edge) {
    std::printf("%-16s %5s %7s %10s %10s %12s %12s %10s %12s %10s %-7s\n", "name", "n", "m", "ours", "ours_ms",
                "root_lp_ms", "no_lp_ms", "glpk", "glpk_ms", "speed-up", "agree");
  } else {
    std::printf("%-16s %5s %7s %10s %10s %10s %12s %10s %-7s\n", "name", "n", "m", "ours", "ours_ms", "glpk", "glpk_ms",
                "speed-up", "agree");
  }
  for (const std::string& name : names) {
    if (!opt.only.empty() && name != opt.only) continue;
    const Row* row = nullptr;
    for (const Row& r : rows) {
      if (r.at("name") == name) row = &r;
    }
    if (row == nullptr) continue;
    Instance inst;
    if (!Load(dir + "/" + row->at("file"), &inst)) continue;
    const Timed ours = Solve(inst.graph, objective, opt.time_limit_s);
    if (!ours.ok) continue;
    const commerge::bench::GlpkRun glpk = commerge::bench::GlpkMaxClique(inst.graph, objective, opt.glpk_time_limit_s);
    char glpk_value[32];
    char speedup[32];
    const char* agree = "n/a";
    if (glpk.optimal) {
      std::snprintf(glpk_value, sizeof glpk_value, "%.0f", glpk.objective);
      std::snprintf(speedup, sizeof speedup, "%.0fx", glpk.ms / std::max(ours.ms, 1e-3));
      const bool ours_proven = ours.result.status == CliqueSearchStatus::kOptimal;
      agree = std::fabs(glpk.objective - ours.result.objective) < 1e-6 ? (ours_proven ? "yes" : "yes*") : "NO";
    } else if (glpk.timeout) {
      std::snprintf(glpk_value, sizeof glpk_value, "timeout");
      std::snprintf(speedup, sizeof speedup, ">%.0fx", glpk.ms / std::max(ours.ms, 1e-3));
      agree = "-";
    } else {
      std::snprintf(glpk_value, sizeof glpk_value, "failed");
      std::snprintf(speedup, sizeof speedup, "-");
    }
    if (edge) {
      const Timed root = Solve(inst.graph, objective, opt.time_limit_s, LpMode::kRoot);
      const Timed off = Solve(inst.graph, objective, opt.time_limit_s, LpMode::kOff);
      std::printf("%-16s %5d %7zu %10.0f %10.3f %12.3f %12.3f %10s %12.1f %10s %-7s", name.c_str(),
                  inst.graph.num_vertices(), inst.graph.num_edges(), ours.result.objective, ours.ms, root.ms, off.ms,
                  glpk_value, glpk.ms, speedup, agree);
    } else {
      std::printf("%-16s %5d %7zu %10.0f %10.3f %10s %12.1f %10s %-7s", name.c_str(), inst.graph.num_vertices(),
                  inst.graph.num_edges(), ours.result.objective, ours.ms, glpk_value, glpk.ms, speedup, agree);
    }
    if (glpk.timeout && glpk.objective > 0.0) std::printf(" (GLPK incumbent %.0f)", glpk.objective);
    if (ours.result.status != CliqueSearchStatus::kOptimal) std::printf(" (ours not proven)");
    std::printf("\n");
    std::fflush(stdout);
  }
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  if (!ParseOptions(argc, argv, &opt)) return 2;
  const std::string dir = commerge::bench::SharedDataDir() + "/graphs";
  if (ReadTsv(dir + "/optima.tsv").empty()) {
    std::fprintf(stderr, "bench_max_clique: needs %s/optima.tsv (licensed shared data)\n", dir.c_str());
    return 1;
  }
  std::printf("data: %s\n", dir.c_str());
  std::map<std::string, Timed> card, vertex, edge;
  RunTable(dir, "optima.tsv", "omega", CliqueObjective::kCardinality, opt, &card);
  RunTable(dir, "mwc_optima.tsv", "mwc_weight", CliqueObjective::kVertexWeight, opt, &vertex);
  RunTable(dir, "mewc_optima.tsv", "mewc_weight", CliqueObjective::kEdgeWeight, opt, &edge);
  if (opt.glpk) {
    const std::vector<std::string> small = {"johnson8-2-4", "hamming6-4", "MANN_a9", "johnson8-4-4"};
    std::vector<std::string> mewc = small;
    std::vector<std::string> cardinality = small;
    if (!opt.quick) {
      for (const char* extra : {"hamming6-2", "c-fat200-1", "johnson16-2-4", "keller4", "brock200_2"}) {
        mewc.push_back(extra);
      }
      for (const char* extra : {"hamming6-2", "c-fat200-1", "keller4", "brock200_2", "johnson16-2-4"}) {
        cardinality.push_back(extra);
      }
    }
    RunGlpkTable(dir, opt, CliqueObjective::kEdgeWeight, mewc);
    RunGlpkTable(dir, opt, CliqueObjective::kCardinality, cardinality);
  }
  const std::int64_t peak = commerge::platform::ReadRss().peak_bytes;
  std::printf("\npeak RSS: %s\n", commerge::FormatBytes(peak).c_str());
  return 0;
}
