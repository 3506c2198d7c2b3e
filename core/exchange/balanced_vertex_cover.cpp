// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/balanced_vertex_cover.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>

namespace commerge {
namespace {

using Clock = std::chrono::steady_clock;
constexpr double kIntTol = 1e-6;

// Vertex ids: left i -> i, right j -> left_count + j. Side 0 = left robot, side 1 = right robot.
struct Model {
  int left_count = 0;
  int vertex_count = 0;
  std::vector<std::vector<int>> neighbours;
  std::vector<std::pair<int, int>> edges;  // (left id, right id), global ids
  int share = 0;
  int Side(int v) const { return v < left_count ? 0 : 1; }
};

// Fixing of one vertex in a node: -1 free, 0 not sent, 1 sent.
using Fixing = std::vector<std::int8_t>;

// Unit propagation: a vertex fixed to 0 forces its neighbours to 1; a side with exactly `share` vertices not
// fixed to 0 forces them all to 1. Returns false when the node is infeasible.
bool Propagate(const Model& md, Fixing& fix) {
  bool changed = true;
  while (changed) {
    changed = false;
    for (int v = 0; v < md.vertex_count; ++v) {
      if (fix[static_cast<std::size_t>(v)] != 0) continue;
      for (int w : md.neighbours[static_cast<std::size_t>(v)]) {
        std::int8_t& fw = fix[static_cast<std::size_t>(w)];
        if (fw == 0) return false;
        if (fw < 0) {
          fw = 1;
          changed = true;
        }
      }
    }
    int possible[2] = {0, 0};
    for (int v = 0; v < md.vertex_count; ++v) {
      if (fix[static_cast<std::size_t>(v)] != 0) ++possible[md.Side(v)];
    }
    for (int s = 0; s < 2; ++s) {
      if (possible[s] < md.share) return false;
      if (possible[s] == md.share) {
        for (int v = 0; v < md.vertex_count; ++v) {
          if (md.Side(v) == s && fix[static_cast<std::size_t>(v)] < 0) {
            fix[static_cast<std::size_t>(v)] = 1;
            changed = true;
          }
        }
      }
    }
  }
  return true;
}

bool IsFeasible(const Model& md, const std::vector<char>& in) {
  for (const auto& e : md.edges) {
    if (!in[static_cast<std::size_t>(e.first)] && !in[static_cast<std::size_t>(e.second)]) return false;
  }
  int count[2] = {0, 0};
  for (int v = 0; v < md.vertex_count; ++v) {
    if (in[static_cast<std::size_t>(v)]) ++count[md.Side(v)];
  }
  return count[0] >= md.share && count[1] >= md.share;
}

// Turns an edge cover `in` into a balanced cover: while a side is short of its share, adds the vertex of that side
// that makes the most selected opposite vertices redundant, and drops those while the opposite side stays at or
// above its share; finally drops every redundant vertex whose side stays at or above its share. Returns false when
// a side has too few candidates.
bool RepairAndPrune(const Model& md, std::vector<char>& in) {
  const auto nv = static_cast<std::size_t>(md.vertex_count);
  std::vector<int> missing(nv, 0);  // neighbours not selected
  int count[2] = {0, 0};
  for (int v = 0; v < md.vertex_count; ++v) {
    if (in[static_cast<std::size_t>(v)]) ++count[md.Side(v)];
    for (int w : md.neighbours[static_cast<std::size_t>(v)]) {
      if (!in[static_cast<std::size_t>(w)]) ++missing[static_cast<std::size_t>(v)];
    }
  }
  auto select = [&](int v) {
    in[static_cast<std::size_t>(v)] = 1;
    ++count[md.Side(v)];
    for (int w : md.neighbours[static_cast<std::size_t>(v)]) --missing[static_cast<std::size_t>(w)];
  };
  auto drop = [&](int v) {
    in[static_cast<std::size_t>(v)] = 0;
    --count[md.Side(v)];
    for (int w : md.neighbours[static_cast<std::size_t>(v)]) ++missing[static_cast<std::size_t>(w)];
  };
  for (int s = 0; s < 2; ++s) {
    while (count[s] < md.share) {
      int best = -1;
      int best_gain = -1;
      for (int u = 0; u < md.vertex_count; ++u) {
        if (md.Side(u) != s || in[static_cast<std::size_t>(u)] || md.neighbours[static_cast<std::size_t>(u)].empty()) {
          continue;
        }
        int gain = 0;
        for (int w : md.neighbours[static_cast<std::size_t>(u)]) {
          if (in[static_cast<std::size_t>(w)] && missing[static_cast<std::size_t>(w)] == 1) ++gain;
        }
        if (gain > best_gain) {
          best_gain = gain;
          best = u;
        }
      }
      if (best < 0) return false;
      select(best);
      for (int w : md.neighbours[static_cast<std::size_t>(best)]) {
        if (in[static_cast<std::size_t>(w)] && missing[static_cast<std::size_t>(w)] == 0 && count[1 - s] > md.share) {
          drop(w);
        }
      }
    }
  }
  std::vector<int> order;
  for (int v = 0; v < md.vertex_count; ++v) {
    if (in[static_cast<std::size_t>(v)]) order.push_back(v);
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return md.neighbours[static_cast<std::size_t>(a)].size() < md.neighbours[static_cast<std::size_t>(b)].size();
  });
  for (int v : order) {
    if (in[static_cast<std::size_t>(v)] && missing[static_cast<std::size_t>(v)] == 0 && count[md.Side(v)] > md.share) {
      drop(v);
    }
  }
  return true;
}

struct Node {
  Fixing fix;
  int bound = 0;  // lower bound inherited from the parent
};

}  // namespace

const char* BalancedCoverStatusName(BalancedCoverStatus status) noexcept {
  switch (status) {
    case BalancedCoverStatus::kOptimal: return "optimal";
    case BalancedCoverStatus::kFeasibleWithGap: return "feasible with gap";
    case BalancedCoverStatus::kInfeasible: return "infeasible";
    case BalancedCoverStatus::kLimitWithoutSolution: return "limit without solution";
    case BalancedCoverStatus::kNoCandidates: return "no candidates";
  }
  return "unknown";
}

Result<int> BalancedShare(int max_matching_size, const std::vector<double>& participation) {
  if (max_matching_size < 0) return InvalidArgument("balanced share: negative matching size");
  std::vector<double> p = participation;
  if (p.empty()) p = {0.5, 0.5};
  double sum = 0.0;
  double entropy_bits = 0.0;
  for (double pr : p) {
    if (!std::isfinite(pr) || pr < 0.0) return InvalidArgument("balanced share: participation ratios must be finite and >= 0");
    sum += pr;
    if (pr > 0.0) entropy_bits -= pr * std::log2(pr);
  }
  if (std::fabs(sum - 1.0) > 1e-9) {
    return InvalidArgument("balanced share: participation ratios sum to " + std::to_string(sum) + ", not 1");
  }
  const double effective_robots = std::exp2(std::max(0.0, entropy_bits));
  const double raw = static_cast<double>(max_matching_size) / effective_robots;
  return static_cast<int>(std::ceil(raw - 1e-9));
}

Result<BalancedCoverResult> SolveBalancedVertexCover(const BipartiteGraph& graph, const BalancedCoverParams& params,
                                                     LpSolver* lp_solver) {
  if (!params.participation.empty() && params.participation.size() != 2) {
    return InvalidArgument("balanced vertex cover: participation must have 2 entries (one per robot), got " +
                           std::to_string(params.participation.size()));
  }
  if (params.max_nodes < 1) return InvalidArgument("balanced vertex cover: max_nodes must be >= 1");
  if (!(params.time_limit_s > 0.0)) return InvalidArgument("balanced vertex cover: time_limit_s must be > 0");
  const Clock::time_point start = Clock::now();
  GlpkSimplexSolver default_lp;
  LpSolver& lp = lp_solver != nullptr ? *lp_solver : default_lp;

  BalancedCoverResult res;
  Result<Matching> mm = HopcroftKarp(graph);
  if (!mm.ok()) return mm.status();
  res.max_matching_size = mm->size;
  if (params.min_share_per_robot_override >= 0) {
    res.min_share_per_robot = params.min_share_per_robot_override;
  } else {
    Result<int> share = BalancedShare(mm->size, params.participation);
    if (!share.ok()) return share.status();
    res.min_share_per_robot = *share;
  }
  if (graph.edges().empty()) {
    res.status = BalancedCoverStatus::kNoCandidates;
    return res;
  }

  Model md;
  md.left_count = graph.left_count();
  md.vertex_count = graph.left_count() + graph.right_count();
  md.share = res.min_share_per_robot;
  md.neighbours.assign(static_cast<std::size_t>(md.vertex_count), {});
  for (const BipartiteEdge& e : graph.edges()) {
    const int a = e.left;
    const int b = md.left_count + e.right;
    md.edges.emplace_back(a, b);
    md.neighbours[static_cast<std::size_t>(a)].push_back(b);
    md.neighbours[static_cast<std::size_t>(b)].push_back(a);
  }
  for (auto& nb : md.neighbours) {
    std::sort(nb.begin(), nb.end());
    nb.erase(std::unique(nb.begin(), nb.end()), nb.end());
  }
  const auto nv = static_cast<std::size_t>(md.vertex_count);

  // Incumbent from the König cover, repaired to meet the shares.
  std::vector<char> best(nv, 0);
  int best_obj = std::numeric_limits<int>::max();
  auto offer = [&](std::vector<char> in) {
    if (!RepairAndPrune(md, in) || !IsFeasible(md, in)) return;
    int obj = 0;
    for (char c : in) obj += c ? 1 : 0;
    if (obj < best_obj) {
      best_obj = obj;
      best = std::move(in);
    }
  };
  {
    Result<VertexCover> konig = KonigVertexCover(graph, *mm);
    if (!konig.ok()) return konig.status();
    std::vector<char> in(nv, 0);
    for (int u : konig->left) in[static_cast<std::size_t>(u)] = 1;
    for (int v : konig->right) in[static_cast<std::size_t>(md.left_count + v)] = 1;
    offer(std::move(in));
  }

  // Root node: isolated vertices are fixed to 0 (never needed, never counted).
  Node root;
  root.fix.assign(nv, -1);
  for (std::size_t v = 0; v < nv; ++v) {
    if (md.neighbours[v].empty()) root.fix[v] = 0;
  }
  root.bound = std::max(mm->size, 2 * md.share);
  std::vector<Node> stack;
  stack.push_back(std::move(root));
  bool limit_hit = false;
  int open_bound = std::numeric_limits<int>::max();  // min bound of nodes left open by a limit

  std::vector<int> free_ids;
  std::vector<int> local(nv, -1);
  while (!stack.empty()) {
    if (best_obj <= stack.back().bound) {  // cannot improve: prune without evaluating
      stack.pop_back();
      continue;
    }
    const double elapsed_s = std::chrono::duration<double>(Clock::now() - start).count();
    if (res.nodes_explored >= params.max_nodes || elapsed_s > params.time_limit_s) {
      limit_hit = true;
      for (const Node& nd : stack) open_bound = std::min(open_bound, nd.bound);
      break;
    }
    Node node = std::move(stack.back());
    stack.pop_back();
    ++res.nodes_explored;
    if (!Propagate(md, node.fix)) continue;

    int ones[2] = {0, 0};
    free_ids.clear();
    for (int v = 0; v < md.vertex_count; ++v) {
      const std::int8_t f = node.fix[static_cast<std::size_t>(v)];
      if (f == 1) ++ones[md.Side(v)];
      if (f < 0) {
        local[static_cast<std::size_t>(v)] = static_cast<int>(free_ids.size());
        free_ids.push_back(v);
      } else {
        local[static_cast<std::size_t>(v)] = -1;
      }
    }
    const int fixed_ones = ones[0] + ones[1];
    const int deficit = std::max(0, md.share - ones[0]) + std::max(0, md.share - ones[1]);

    // Residual graph: edges between two free vertices (all others are covered after propagation).
    std::vector<BipartiteEdge> residual;
    int left_free = 0;
    std::vector<int> compact(nv, -1);
    int right_free = 0;
    for (int v : free_ids) {
      compact[static_cast<std::size_t>(v)] = md.Side(v) == 0 ? left_free++ : right_free++;
    }
    for (const auto& e : md.edges) {
      if (local[static_cast<std::size_t>(e.first)] >= 0 && local[static_cast<std::size_t>(e.second)] >= 0) {
        residual.push_back({compact[static_cast<std::size_t>(e.first)], compact[static_cast<std::size_t>(e.second)]});
      }
    }
    if (free_ids.empty()) {
      std::vector<char> in(nv, 0);
      for (std::size_t v = 0; v < nv; ++v) in[v] = node.fix[v] == 1 ? 1 : 0;
      if (IsFeasible(md, in) && fixed_ones < best_obj) {
        best_obj = fixed_ones;
        best = std::move(in);
      }
      continue;
    }
    Result<BipartiteGraph> rg = BipartiteGraph::Create(left_free, right_free, residual);
    if (!rg.ok()) return rg.status();
    Result<Matching> rmm = HopcroftKarp(*rg);
    if (!rmm.ok()) return rmm.status();
    int bound = std::max(node.bound, fixed_ones + std::max(rmm->size, deficit));
    if (bound >= best_obj) continue;

    // LP relaxation over the free vertices.
    LinearProgram prog;
    prog.objective.assign(free_ids.size(), 1.0);
    prog.variable_lower.assign(free_ids.size(), 0.0);
    prog.variable_upper.assign(free_ids.size(), 1.0);
    for (const auto& e : md.edges) {
      const int a = local[static_cast<std::size_t>(e.first)];
      const int b = local[static_cast<std::size_t>(e.second)];
      if (a >= 0 && b >= 0) prog.rows.push_back(LpRow{{{a, 1.0}, {b, 1.0}}, 1.0, kLpInfinity});
    }
    for (int s = 0; s < 2; ++s) {
      if (md.share - ones[s] <= 0) continue;
      LpRow row;
      for (std::size_t k = 0; k < free_ids.size(); ++k) {
        if (md.Side(free_ids[k]) == s) row.terms.push_back({static_cast<int>(k), 1.0});
      }
      row.lower = static_cast<double>(md.share - ones[s]);
      prog.rows.push_back(std::move(row));
    }
    Result<LpSolution> sol = lp.Minimize(prog);
    ++res.lp_solves;
    if (!sol.ok()) return sol.status();
    if (sol->status == LpStatus::kInfeasible) continue;
    if (sol->status != LpStatus::kOptimal) {
      return Status(StatusCode::kInternal, "balanced vertex cover: LP relaxation is unbounded (a bug)");
    }
    bound = std::max(bound, fixed_ones + static_cast<int>(std::ceil(sol->objective - kIntTol)));
    if (bound >= best_obj) continue;

    // Rounding heuristic (x >= 1/2 covers every residual edge), then repair.
    std::vector<char> rounded(nv, 0);
    bool integral = true;
    for (std::size_t v = 0; v < nv; ++v) rounded[v] = node.fix[v] == 1 ? 1 : 0;
    int branch_var = -1;
    double branch_score = -1.0;
    for (std::size_t k = 0; k < free_ids.size(); ++k) {
      const double x = sol->values[k];
      const int v = free_ids[k];
      if (x >= 0.5) rounded[static_cast<std::size_t>(v)] = 1;
      const double frac = std::min(x, 1.0 - x);
      if (frac > kIntTol) integral = false;
      // Most fractional first; ties go to the most constrained (highest degree) vertex.
      const double score = std::max(0.0, frac) + 1e-7 * static_cast<double>(md.neighbours[static_cast<std::size_t>(v)].size());
      if (score > branch_score) {
        branch_score = score;
        branch_var = static_cast<int>(k);
      }
    }
    if (integral) {
      int obj = 0;
      for (char c : rounded) obj += c ? 1 : 0;
      if (IsFeasible(md, rounded)) {
        if (obj < best_obj) {
          best_obj = obj;
          best = std::move(rounded);
        }
        continue;  // the node's LP optimum is integral: the node is solved
      }
    }
    offer(rounded);
    if (bound >= best_obj) continue;

    const int v = free_ids[static_cast<std::size_t>(branch_var)];
    const int preferred = sol->values[static_cast<std::size_t>(branch_var)] >= 0.5 ? 1 : 0;
    Node other{node.fix, bound};
    other.fix[static_cast<std::size_t>(v)] = static_cast<std::int8_t>(1 - preferred);
    node.fix[static_cast<std::size_t>(v)] = static_cast<std::int8_t>(preferred);
    node.bound = bound;
    stack.push_back(std::move(other));
    stack.push_back(std::move(node));  // explored first
  }

  if (best_obj == std::numeric_limits<int>::max()) {
    res.status = limit_hit ? BalancedCoverStatus::kLimitWithoutSolution : BalancedCoverStatus::kInfeasible;
    res.lower_bound_scans = limit_hit ? std::min(open_bound, std::max(mm->size, 2 * md.share)) : 0;
    return res;
  }
  for (int v = 0; v < md.vertex_count; ++v) {
    if (!best[static_cast<std::size_t>(v)]) continue;
    if (v < md.left_count) {
      res.selected_left.push_back(v);
    } else {
      res.selected_right.push_back(v - md.left_count);
    }
  }
  res.objective_scans = best_obj;
  res.lower_bound_scans = limit_hit ? std::min(open_bound, best_obj) : best_obj;
  res.status = res.lower_bound_scans < best_obj ? BalancedCoverStatus::kFeasibleWithGap : BalancedCoverStatus::kOptimal;
  return res;
}

}  // namespace commerge
