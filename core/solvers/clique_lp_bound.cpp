// SPDX-License-Identifier: BSD-3-Clause
// LP relaxation bound of the maximum edge-weighted clique (model and certificate: clique_lp_bound.hpp). The model
// is counted in a first pass over the subset's vertex pairs (no allocation beyond O(|V'| + classes)), refused
// above the coefficient budget, and only then built.
#include "core/solvers/clique_lp_bound.hpp"

#include <algorithm>
#include <cfloat>
#include <cmath>
#include <string>
#include <utility>

#include "core/solvers/max_clique.hpp"

namespace commerge {
namespace {

inline std::size_t LpIndex(int i) { return static_cast<std::size_t>(i); }

// Weight of {u, v} when it is an edge of positive weight, else 0.
double PositiveEdgeWeight(const CliqueGraph& g, int u, int v) {
  if (!g.HasEdge(u, v)) return 0.0;
  const double w = g.edge_weight(u, v);
  return w > 0.0 ? w : 0.0;
}

Status CheckLpColouring(const CliqueGraph& g, const CliqueColouring& c, const std::vector<int>& position,
                      std::vector<int>* class_of) {
  const std::vector<int>& s = c.class_start;
  if (s.empty() || s.front() != 0 || s.back() != static_cast<int>(c.vertices.size())) {
    return InvalidArgument("clique LP: colouring offsets must start at 0 and end at the number of listed vertices");
  }
  for (std::size_t k = 1; k < s.size(); ++k) {
    if (s[k] < s[k - 1]) return InvalidArgument("clique LP: colouring offsets decrease at class " + std::to_string(k - 1));
  }
  const int n = g.num_vertices();
  for (int k = 0; k + 1 < static_cast<int>(s.size()); ++k) {
    for (int a = s[LpIndex(k)]; a < s[LpIndex(k) + 1]; ++a) {
      const int v = c.vertices[LpIndex(a)];
      if (v < 0 || v >= n || position[LpIndex(v)] < 0) {
        return InvalidArgument("clique LP: colour class " + std::to_string(k) + " holds vertex " + std::to_string(v) +
                               ", which is not in the vertex subset");
      }
      int& cls = (*class_of)[LpIndex(position[LpIndex(v)])];
      if (cls >= 0) return InvalidArgument("clique LP: vertex " + std::to_string(v) + " is in two colour classes");
      cls = k;
      for (int b = s[LpIndex(k)]; b < a; ++b) {
        if (g.HasEdge(v, c.vertices[LpIndex(b)])) {
          return InvalidArgument("clique LP: colour class " + std::to_string(k) + " is not independent (edge " +
                                 std::to_string(v) + ", " + std::to_string(c.vertices[LpIndex(b)]) + ")");
        }
      }
    }
  }
  return Status::Ok();
}

}  // namespace

const char* CliqueLpStatusName(CliqueLpStatus status) noexcept {
  switch (status) {
    case CliqueLpStatus::kNotRun:
      return "not run";
    case CliqueLpStatus::kOptimal:
      return "optimal";
    case CliqueLpStatus::kTrivial:
      return "trivial";
    case CliqueLpStatus::kTooLarge:
      return "too large";
    case CliqueLpStatus::kFailed:
      return "failed";
  }
  return "unknown";
}

CliqueColouring GreedyCliqueColouring(const CliqueGraph& graph, const std::vector<int>& vertices) {
  const int n = graph.num_vertices();
  std::vector<char> seen(LpIndex(n), 0);
  std::vector<int> order;
  order.reserve(vertices.size());
  for (const int v : vertices) {
    if (v < 0 || v >= n || seen[LpIndex(v)] != 0) continue;
    seen[LpIndex(v)] = 1;
    order.push_back(v);
  }
  const std::size_t k = order.size();
  std::vector<int> degree(k, 0);
  for (std::size_t a = 0; a < k; ++a) {
    for (std::size_t b = a + 1; b < k; ++b) {
      if (graph.HasEdge(order[a], order[b])) {
        ++degree[a];
        ++degree[b];
      }
    }
  }
  std::vector<std::size_t> rank(k);
  for (std::size_t a = 0; a < k; ++a) rank[a] = a;
  std::stable_sort(rank.begin(), rank.end(), [&](std::size_t a, std::size_t b) { return degree[a] > degree[b]; });
  std::vector<std::vector<int>> classes;
  for (const std::size_t r : rank) {
    const int v = order[r];
    std::size_t c = 0;
    for (; c < classes.size(); ++c) {
      bool free = true;
      for (const int u : classes[c]) {
        if (graph.HasEdge(u, v)) {
          free = false;
          break;
        }
      }
      if (free) break;
    }
    if (c == classes.size()) classes.emplace_back();
    classes[c].push_back(v);
  }
  CliqueColouring out;
  out.vertices.reserve(k);
  for (const std::vector<int>& cls : classes) {
    out.vertices.insert(out.vertices.end(), cls.begin(), cls.end());
    out.class_start.push_back(static_cast<int>(out.vertices.size()));
  }
  return out;
}

Result<CliqueLpModel> BuildCliqueLpModel(const CliqueGraph& graph, const std::vector<int>& vertices,
                                         const std::vector<double>& vertex_gain, const CliqueColouring* colouring,
                                         const CliqueLpBoundParams& params) {
  if (!graph.has_edge_weights()) {
    return InvalidArgument("clique LP: the edge-weight bound needs a graph created with edge weights");
  }
  if (params.max_nonzeros < 0) {
    return InvalidArgument("clique LP: max_nonzeros must be >= 0 (got " + std::to_string(params.max_nonzeros) + ")");
  }
  const int n = graph.num_vertices();
  const int k = static_cast<int>(vertices.size());
  if (!vertex_gain.empty() && vertex_gain.size() != vertices.size()) {
    return InvalidArgument("clique LP: " + std::to_string(vertex_gain.size()) + " vertex gains for " +
                           std::to_string(k) + " vertices");
  }
  std::vector<int> position(LpIndex(n), -1);  // graph vertex -> index in `vertices`
  for (int i = 0; i < k; ++i) {
    const int v = vertices[LpIndex(i)];
    if (v < 0 || v >= n) return InvalidArgument("clique LP: vertex " + std::to_string(v) + " is outside the graph");
    if (position[LpIndex(v)] >= 0) return InvalidArgument("clique LP: vertex " + std::to_string(v) + " is listed twice");
    position[LpIndex(v)] = i;
    if (!vertex_gain.empty() && !std::isfinite(vertex_gain[LpIndex(i)])) {
      return InvalidArgument("clique LP: the gain of vertex " + std::to_string(v) + " is not finite");
    }
  }
  auto gain = [&](int i) { return vertex_gain.empty() ? 0.0 : vertex_gain[LpIndex(i)]; };

  // Colour classes, as a class index per subset position (-1: in no class).
  std::vector<int> class_of(LpIndex(k), -1);
  CliqueColouring greedy;
  const CliqueColouring* col = nullptr;
  if (params.colour_rows) {
    if (colouring == nullptr) {
      greedy = GreedyCliqueColouring(graph, vertices);
      col = &greedy;
    } else {
      col = colouring;
    }
    Status st = CheckLpColouring(graph, *col, position, &class_of);
    if (!st.ok()) return st;
  }
  const int classes = col == nullptr ? 0 : col->num_classes();

  // Pass 1: count. A vertex gets a column when it has a positive gain or a positive edge in the subset.
  std::vector<int> column(LpIndex(k), -1);
  std::int64_t positive_edges = 0;
  int x_columns = 0;
  for (int i = 0; i < k; ++i) {
    bool relevant = gain(i) > 0.0;
    for (int j = 0; j < k; ++j) {
      if (j != i && PositiveEdgeWeight(graph, vertices[LpIndex(i)], vertices[LpIndex(j)]) > 0.0) {
        relevant = true;
        if (j > i) ++positive_edges;
      }
    }
    if (relevant) column[LpIndex(i)] = x_columns++;
  }
  std::vector<int> relevant_in_class(LpIndex(classes), 0);
  for (int i = 0; i < k; ++i) {
    if (column[LpIndex(i)] >= 0 && class_of[LpIndex(i)] >= 0) ++relevant_in_class[LpIndex(class_of[LpIndex(i)])];
  }
  std::int64_t rows = 0;
  std::int64_t nonzeros = 0;
  for (int c = 0; c < classes; ++c) {
    if (relevant_in_class[LpIndex(c)] >= 2) {
      ++rows;
      nonzeros += relevant_in_class[LpIndex(c)];
    }
  }
  // Per vertex u: one neighbour row per class holding a positive neighbour, one row y_uv <= x_u per positive
  // neighbour v in no class (every neighbour without colour rows); non-edge rows: one per later class S holding
  // non-neighbours of u, x_u + sum_{v in S, v !~ u} x_v <= 1 ({u} plus those is independent), and x_u + x_v <= 1
  // for a later non-neighbour v in no class.
  std::vector<int> per_class(LpIndex(classes), 0);
  std::vector<int> non_adjacent(LpIndex(classes), 0);
  for (int i = 0; i < k; ++i) {
    if (column[LpIndex(i)] < 0) continue;
    std::fill(per_class.begin(), per_class.end(), 0);
    std::fill(non_adjacent.begin(), non_adjacent.end(), 0);
    const int own = class_of[LpIndex(i)];
    for (int j = 0; j < k; ++j) {
      if (j == i || column[LpIndex(j)] < 0) continue;
      const int u = vertices[LpIndex(i)];
      const int v = vertices[LpIndex(j)];
      const int cj = class_of[LpIndex(j)];
      if (PositiveEdgeWeight(graph, u, v) > 0.0) {
        if (cj >= 0) {
          ++per_class[LpIndex(cj)];
        } else {
          ++rows;
          nonzeros += 2;
        }
      } else if (params.non_edge_rows && !graph.HasEdge(u, v)) {
        if (cj > own) {
          ++non_adjacent[LpIndex(cj)];
        } else if (cj < 0 && own < 0 && j > i) {
          ++rows;
          nonzeros += 2;
        }
      }
    }
    for (int c = 0; c < classes; ++c) {
      if (per_class[LpIndex(c)] >= 1) {
        ++rows;
        nonzeros += per_class[LpIndex(c)] + 1;
      }
      if (non_adjacent[LpIndex(c)] >= 1) {
        ++rows;
        nonzeros += non_adjacent[LpIndex(c)] + 1;
      }
    }
  }
  CliqueLpModel model;
  model.num_vertex_columns = x_columns;
  model.nonzeros = nonzeros;
  model.colour_classes = classes;
  const std::int64_t columns = x_columns + positive_edges;
  if (nonzeros > params.max_nonzeros || rows > std::int64_t{1} << 30 || columns > std::int64_t{1} << 30) {
    model.too_large = true;
    model.rows = static_cast<int>(std::min<std::int64_t>(rows, std::int64_t{1} << 30));
    model.columns = static_cast<int>(std::min<std::int64_t>(columns, std::int64_t{1} << 30));
    return model;
  }
  model.rows = static_cast<int>(rows);
  model.columns = static_cast<int>(columns);

  // Pass 2: build (sizes now bounded by max_nonzeros).
  LinearProgram& lp = model.lp;
  lp.objective.assign(LpIndex(model.columns), 0.0);
  lp.variable_lower.assign(LpIndex(model.columns), 0.0);
  lp.variable_upper.assign(LpIndex(model.columns), 1.0);
  lp.rows.reserve(LpIndex(model.rows));
  model.vertex_of_column.assign(LpIndex(x_columns), -1);
  for (int i = 0; i < k; ++i) {
    const int x = column[LpIndex(i)];
    if (x < 0) continue;
    model.vertex_of_column[LpIndex(x)] = vertices[LpIndex(i)];
    lp.objective[LpIndex(x)] = -gain(i);
  }
  // Positive edges as adjacency lists (subset position, y column), both directions.
  std::vector<int> first(LpIndex(k) + 1, 0);
  std::vector<std::pair<int, int>> incident(static_cast<std::size_t>(2 * positive_edges));
  for (int i = 0; i < k; ++i) {
    for (int j = 0; j < k; ++j) {
      if (j != i && column[LpIndex(j)] >= 0 && PositiveEdgeWeight(graph, vertices[LpIndex(i)], vertices[LpIndex(j)]) > 0.0) {
        ++first[LpIndex(i) + 1];
      }
    }
  }
  for (int i = 0; i < k; ++i) first[LpIndex(i) + 1] += first[LpIndex(i)];
  std::vector<int> fill(first.begin(), first.end() - 1);
  int y = x_columns;
  for (int i = 0; i < k; ++i) {
    for (int j = i + 1; j < k; ++j) {
      const double w = PositiveEdgeWeight(graph, vertices[LpIndex(i)], vertices[LpIndex(j)]);
      if (w <= 0.0) continue;
      lp.objective[LpIndex(y)] = -w;
      incident[LpIndex(fill[LpIndex(i)]++)] = {j, y};
      incident[LpIndex(fill[LpIndex(j)]++)] = {i, y};
      ++y;
    }
  }
  if (col != nullptr) {
    for (int c = 0; c < classes; ++c) {
      if (relevant_in_class[LpIndex(c)] < 2) continue;
      LpRow r;
      for (int a = col->class_start[LpIndex(c)]; a < col->class_start[LpIndex(c) + 1]; ++a) {
        const int x = column[LpIndex(position[LpIndex(col->vertices[LpIndex(a)])])];
        if (x >= 0) r.terms.push_back({x, 1.0});
      }
      r.upper = 1.0;
      lp.rows.push_back(std::move(r));
    }
  }
  std::vector<std::vector<LpTerm>> neighbour_terms(LpIndex(classes));
  std::vector<std::vector<LpTerm>> non_adjacent_terms(LpIndex(classes));
  for (int i = 0; i < k; ++i) {
    if (column[LpIndex(i)] < 0) continue;
    if (params.non_edge_rows) {
      for (std::vector<LpTerm>& t : non_adjacent_terms) t.clear();
      const int own = class_of[LpIndex(i)];
      for (int j = 0; j < k; ++j) {
        if (j == i || column[LpIndex(j)] < 0 || graph.HasEdge(vertices[LpIndex(i)], vertices[LpIndex(j)])) continue;
        const int cj = class_of[LpIndex(j)];
        if (cj > own) {
          non_adjacent_terms[LpIndex(cj)].push_back({column[LpIndex(j)], 1.0});
        } else if (cj < 0 && own < 0 && j > i) {
          LpRow r;
          r.terms = {{column[LpIndex(i)], 1.0}, {column[LpIndex(j)], 1.0}};
          r.upper = 1.0;
          lp.rows.push_back(std::move(r));
        }
      }
      for (std::vector<LpTerm>& t : non_adjacent_terms) {
        if (t.empty()) continue;
        LpRow r;
        r.terms = t;
        r.terms.push_back({column[LpIndex(i)], 1.0});
        r.upper = 1.0;
        lp.rows.push_back(std::move(r));
      }
    }
    for (std::vector<LpTerm>& t : neighbour_terms) t.clear();
    for (int e = first[LpIndex(i)]; e < first[LpIndex(i) + 1]; ++e) {
      const int c = class_of[LpIndex(incident[LpIndex(e)].first)];
      if (c >= 0) {
        neighbour_terms[LpIndex(c)].push_back({incident[LpIndex(e)].second, 1.0});
      } else {
        LpRow r;
        r.terms = {{incident[LpIndex(e)].second, 1.0}, {column[LpIndex(i)], -1.0}};
        r.upper = 0.0;
        lp.rows.push_back(std::move(r));
      }
    }
    for (std::vector<LpTerm>& t : neighbour_terms) {
      if (t.empty()) continue;
      LpRow r;
      r.terms = t;
      r.terms.push_back({column[LpIndex(i)], -1.0});
      r.upper = 0.0;
      lp.rows.push_back(std::move(r));
    }
  }
  if (static_cast<int>(lp.rows.size()) != model.rows) {
    return Status(StatusCode::kInternal, "clique LP: built " + std::to_string(lp.rows.size()) + " rows, counted " +
                                             std::to_string(model.rows));
  }
  return model;
}

Result<CliqueLpBoundResult> ComputeCliqueLpBound(const CliqueGraph& graph, const std::vector<int>& vertices,
                                                 const std::vector<double>& vertex_gain,
                                                 const CliqueColouring* colouring, LpSolver* solver,
                                                 const CliqueLpBoundParams& params) {
  if (solver == nullptr) return InvalidArgument("clique LP: no LP solver");
  Result<CliqueLpModel> built = BuildCliqueLpModel(graph, vertices, vertex_gain, colouring, params);
  if (!built.ok()) return built.status();
  const CliqueLpModel& model = *built;
  CliqueLpBoundResult out;
  out.rows = model.rows;
  out.columns = model.columns;
  out.nonzeros = model.nonzeros;
  out.colour_classes = model.colour_classes;
  if (model.too_large) {
    out.status = CliqueLpStatus::kTooLarge;
    return out;
  }
  if (model.columns == 0) {
    out.status = CliqueLpStatus::kTrivial;
    out.upper_bound = 0.0;
    out.lp_objective = 0.0;
    out.certified = true;
    return out;
  }
  const LinearProgram& lp = model.lp;
  Result<LpSolution> sol = solver->Minimize(lp);
  ++out.simplex_solves;
  if (!sol.ok()) return sol.status();
  if (sol->status != LpStatus::kOptimal) {
    return Status(StatusCode::kInternal, std::string("clique LP: the engine calls the relaxation ") +
                                             (sol->status == LpStatus::kInfeasible ? "infeasible" : "unbounded"));
  }
  out.status = CliqueLpStatus::kOptimal;
  out.lp_objective = -sol->objective;

  // Objective coefficients in the maximisation sense; integral when every one is an integer.
  const std::size_t columns = lp.objective.size();
  bool integral = true;
  for (const double c : lp.objective) integral = integral && std::floor(c) == c;

  double bound = 0.0;
  if (sol->row_duals.size() == lp.rows.size()) {
    // Dual certificate (header): mu_r = max(0, -dual_r) for the rows A z <= b of the minimisation.
    std::vector<double> reduced(columns), magnitude(columns);
    for (std::size_t j = 0; j < columns; ++j) {
      reduced[j] = -lp.objective[j];
      magnitude[j] = std::fabs(lp.objective[j]);
    }
    double rhs = 0.0;
    double total = 0.0;
    for (std::size_t r = 0; r < lp.rows.size(); ++r) {
      const double mu = std::max(0.0, -sol->row_duals[r]);
      if (!(mu > 0.0) || !std::isfinite(mu)) continue;
      const LpRow& row = lp.rows[r];
      rhs += mu * row.upper;
      total += mu * std::fabs(row.upper);
      for (const LpTerm& t : row.terms) {
        const double a = mu * t.coefficient;
        reduced[LpIndex(t.variable)] -= a;
        magnitude[LpIndex(t.variable)] += std::fabs(a);
      }
    }
    bound = rhs;
    for (std::size_t j = 0; j < columns; ++j) {
      bound += std::max(0.0, reduced[j]);
      total += magnitude[j];
    }
    bound += 2.0 * static_cast<double>(lp.rows.size() + columns + 8) * DBL_EPSILON * total;
    out.certified = true;
  } else {
    bound = out.lp_objective + 1e-6 * (std::fabs(out.lp_objective) + 1.0);
  }
  if (out.certified && integral && bound < 4503599627370496.0) {  // 2^52
    bound = std::floor(bound);
    out.integer_rounded = true;
  }
  out.upper_bound = bound;
  return out;
}

Result<CliqueLpBoundResult> ComputeCliqueLpBound(const CliqueGraph& graph, const CliqueLpBoundParams& params) {
  std::vector<int> all(LpIndex(graph.num_vertices()));
  for (int v = 0; v < graph.num_vertices(); ++v) all[LpIndex(v)] = v;
  GlpkSimplexSolver glpk;
  return ComputeCliqueLpBound(graph, all, {}, nullptr, &glpk, params);
}

}  // namespace commerge
