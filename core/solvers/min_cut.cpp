// SPDX-License-Identifier: BSD-3-Clause
#include "core/solvers/min_cut.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace commerge {
namespace {
constexpr double kInfiniteCapacity = std::numeric_limits<double>::infinity();
}  // namespace

Status BipartiteCoverFlow::Assign(int left_count, int right_count, const std::vector<std::pair<int, int>>& edges) {
  left_count_ = 0;
  right_count_ = 0;
  node_count_ = 2;
  first_.assign(3, 0);
  arcs_.clear();
  base_cap_.clear();
  edge_arc_.clear();
  has_flow_ = false;
  if (left_count < 0 || right_count < 0 || left_count > (1 << 29) || right_count > (1 << 29)) {
    return InvalidArgument("min cut: bad vertex counts " + std::to_string(left_count) + " x " +
                           std::to_string(right_count));
  }
  for (std::size_t k = 0; k < edges.size(); ++k) {
    const auto& e = edges[k];
    if (e.first < 0 || e.first >= left_count || e.second < 0 || e.second >= right_count) {
      return InvalidArgument("min cut: edge " + std::to_string(k) + " (" + std::to_string(e.first) + ", " +
                             std::to_string(e.second) + ") is outside " + std::to_string(left_count) + " x " +
                             std::to_string(right_count));
    }
  }
  const int n = left_count + right_count;
  const int source = n;
  const int sink = n + 1;
  node_count_ = n + 2;
  // Degrees: every vertex has one terminal arc; each edge gives an arc at both ends.
  std::vector<int>& deg = level_;
  deg.assign(static_cast<std::size_t>(node_count_), 0);
  for (int v = 0; v < n; ++v) deg[static_cast<std::size_t>(v)] = 1;
  deg[static_cast<std::size_t>(source)] = left_count;
  deg[static_cast<std::size_t>(sink)] = right_count;
  for (const auto& e : edges) {
    ++deg[static_cast<std::size_t>(e.first)];
    ++deg[static_cast<std::size_t>(left_count + e.second)];
  }
  first_.assign(static_cast<std::size_t>(node_count_) + 1, 0);
  for (int x = 0; x < node_count_; ++x) {
    first_[static_cast<std::size_t>(x) + 1] = first_[static_cast<std::size_t>(x)] + deg[static_cast<std::size_t>(x)];
  }
  const auto arcs = static_cast<std::size_t>(first_.back());
  arcs_.assign(arcs, Arc{});
  base_cap_.assign(arcs, 0.0);
  cursor_.assign(first_.begin(), first_.end() - 1);
  auto add = [&](int a, int b, double cap) {
    const int ia = cursor_[static_cast<std::size_t>(a)]++;
    const int ib = cursor_[static_cast<std::size_t>(b)]++;
    arcs_[static_cast<std::size_t>(ia)].head = b;
    arcs_[static_cast<std::size_t>(ib)].head = a;
    arcs_[static_cast<std::size_t>(ia)].rev = ib;
    arcs_[static_cast<std::size_t>(ib)].rev = ia;
    base_cap_[static_cast<std::size_t>(ia)] = cap;
  };
  // Terminal arcs first, so the terminal arc of vertex v is arc first_[v] (capacity set per Solve()).
  for (int u = 0; u < left_count; ++u) add(u, source, 0.0);
  for (int v = left_count; v < n; ++v) add(v, sink, 0.0);
  edge_arc_.resize(edges.size());
  for (std::size_t k = 0; k < edges.size(); ++k) {
    edge_arc_[k] = cursor_[static_cast<std::size_t>(edges[k].first)];
    add(edges[k].first, left_count + edges[k].second, kInfiniteCapacity);
  }
  left_count_ = left_count;
  right_count_ = right_count;
  seen_.assign(static_cast<std::size_t>(node_count_), 0U);
  stamp_ = 0;
  return Status::Ok();
}

double BipartiteCoverFlow::TerminalResidual(int v) const {
  const Arc& terminal = arcs_[static_cast<std::size_t>(first_[static_cast<std::size_t>(v)])];
  return v < left_count_ ? arcs_[static_cast<std::size_t>(terminal.rev)].cap : terminal.cap;
}

void BipartiteCoverFlow::Send(int a, double f) {
  Arc& arc = arcs_[static_cast<std::size_t>(a)];
  arc.cap -= f;
  arcs_[static_cast<std::size_t>(arc.rev)].cap += f;
}

bool BipartiteCoverFlow::BuildLevels() {
  const int source = left_count_ + right_count_;
  const int sink = source + 1;
  level_.assign(static_cast<std::size_t>(node_count_), -1);
  level_[static_cast<std::size_t>(source)] = 0;
  queue_.assign(1, source);
  for (std::size_t h = 0; h < queue_.size(); ++h) {
    const int x = queue_[h];
    // Nodes at the sink's level or deeper cannot lie on a shortest augmenting path.
    if (level_[static_cast<std::size_t>(sink)] >= 0 &&
        level_[static_cast<std::size_t>(x)] >= level_[static_cast<std::size_t>(sink)]) {
      break;
    }
    for (int a = first_[static_cast<std::size_t>(x)]; a < first_[static_cast<std::size_t>(x) + 1]; ++a) {
      const int y = arcs_[static_cast<std::size_t>(a)].head;
      if (level_[static_cast<std::size_t>(y)] < 0 && arcs_[static_cast<std::size_t>(a)].cap > eps_) {
        level_[static_cast<std::size_t>(y)] = level_[static_cast<std::size_t>(x)] + 1;
        queue_.push_back(y);
      }
    }
  }
  return level_[static_cast<std::size_t>(sink)] >= 0;
}

Status BipartiteCoverFlow::CheckWeights(const std::vector<double>& weights) {
  const int n = left_count_ + right_count_;
  if (weights.size() != static_cast<std::size_t>(n)) {
    return InvalidArgument("min cut: " + std::to_string(weights.size()) + " weights for " + std::to_string(n) +
                           " vertices");
  }
  double max_w = 0.0;
  for (int v = 0; v < n; ++v) {
    const double w = weights[static_cast<std::size_t>(v)];
    if (!std::isfinite(w) || w < 0.0) {
      return InvalidArgument("min cut: weight of vertex " + std::to_string(v) + " is not finite and >= 0");
    }
    max_w = std::max(max_w, w);
  }
  eps_ = 1e-12 * std::max(1.0, max_w);
  return Status::Ok();
}

Result<double> BipartiteCoverFlow::Resolve(const std::vector<double>& weights, std::vector<char>* in_cover) {
  if (!has_flow_) return Solve(weights, in_cover);
  Status valid = CheckWeights(weights);
  if (!valid.ok()) return valid;
  // Keep the current flow; where a vertex's new capacity is below the flow through it, send the excess back
  // along its edges (each unit of a left vertex's flow goes to one right neighbour and on to the sink, so the
  // reduction stays a valid flow). Left vertices first, then right vertices with their updated flows.
  for (int u = 0; u < left_count_; ++u) {
    const int back = first_[static_cast<std::size_t>(u)];  // u -> source: its capacity is the flow through u
    const int forward = arcs_[static_cast<std::size_t>(back)].rev;
    const double c = weights[static_cast<std::size_t>(u)];
    const double old_flow = arcs_[static_cast<std::size_t>(back)].cap;
    double excess = old_flow - c;
    double reduced = 0.0;
    for (int a = back + 1; a < first_[static_cast<std::size_t>(u) + 1] && excess > 0.0; ++a) {
      const int ra = arcs_[static_cast<std::size_t>(a)].rev;  // v -> u: its capacity is the flow on u -> v
      const double d = std::min(arcs_[static_cast<std::size_t>(ra)].cap, excess);
      if (d <= 0.0) continue;
      arcs_[static_cast<std::size_t>(ra)].cap -= d;
      const int v = arcs_[static_cast<std::size_t>(a)].head;
      Send(arcs_[static_cast<std::size_t>(first_[static_cast<std::size_t>(v)])].rev, d);  // sink -> v
      excess -= d;
      reduced += d;
    }
    const double f = std::min(c, std::max(0.0, old_flow - reduced));
    arcs_[static_cast<std::size_t>(back)].cap = f;
    arcs_[static_cast<std::size_t>(forward)].cap = c - f;
  }
  for (int v = left_count_; v < left_count_ + right_count_; ++v) {
    const int to_sink = first_[static_cast<std::size_t>(v)];
    const int back = arcs_[static_cast<std::size_t>(to_sink)].rev;  // sink -> v: its capacity is the flow through v
    const double c = weights[static_cast<std::size_t>(v)];
    const double old_flow = arcs_[static_cast<std::size_t>(back)].cap;
    double excess = old_flow - c;
    double reduced = 0.0;
    for (int a = to_sink + 1; a < first_[static_cast<std::size_t>(v) + 1] && excess > 0.0; ++a) {
      const double d = std::min(arcs_[static_cast<std::size_t>(a)].cap, excess);  // v -> u: flow on u -> v
      if (d <= 0.0) continue;
      arcs_[static_cast<std::size_t>(a)].cap -= d;
      const int u = arcs_[static_cast<std::size_t>(a)].head;
      Send(first_[static_cast<std::size_t>(u)], d);  // u -> source
      excess -= d;
      reduced += d;
    }
    const double f = std::min(c, std::max(0.0, old_flow - reduced));
    arcs_[static_cast<std::size_t>(back)].cap = f;
    arcs_[static_cast<std::size_t>(to_sink)].cap = c - f;
  }
  return MaxFlowAndCut(weights, in_cover);
}

void BipartiteCoverFlow::EdgeFlows(std::vector<double>* flows) const {
  flows->resize(edge_arc_.size());
  for (std::size_t k = 0; k < edge_arc_.size(); ++k) {
    (*flows)[k] = arcs_[static_cast<std::size_t>(arcs_[static_cast<std::size_t>(edge_arc_[k])].rev)].cap;
  }
}

Result<double> BipartiteCoverFlow::Solve(const std::vector<double>& weights, std::vector<char>* in_cover,
                                         const std::vector<double>* start_flow) {
  const int n = left_count_ + right_count_;
  Status valid = CheckWeights(weights);
  if (!valid.ok()) return valid;
  if (start_flow != nullptr && start_flow->size() != edge_arc_.size()) {
    return InvalidArgument("min cut: " + std::to_string(start_flow->size()) + " start flows for " +
                           std::to_string(edge_arc_.size()) + " edges");
  }
  for (std::size_t a = 0; a < arcs_.size(); ++a) arcs_[a].cap = base_cap_[a];
  for (int v = 0; v < n; ++v) {
    // Terminal arc of v is arc first_[v]; its pair is the arc source -> v (left) or v -> sink (right).
    const int a = first_[static_cast<std::size_t>(v)];
    const double w = weights[static_cast<std::size_t>(v)];
    if (v < left_count_) {
      arcs_[static_cast<std::size_t>(arcs_[static_cast<std::size_t>(a)].rev)].cap = w;  // source -> u
    } else {
      arcs_[static_cast<std::size_t>(a)].cap = w;  // v -> sink
    }
  }
  if (start_flow != nullptr) {
    // Warm start: route each edge's old flow source -> u -> v -> sink as far as the new capacities allow.
    for (std::size_t k = 0; k < edge_arc_.size(); ++k) {
      const double want = (*start_flow)[k];
      if (!(want > eps_)) continue;  // also skips NaN
      const int a = edge_arc_[k];
      const int u = arcs_[static_cast<std::size_t>(arcs_[static_cast<std::size_t>(a)].rev)].head;
      const int v = arcs_[static_cast<std::size_t>(a)].head;
      const int su = arcs_[static_cast<std::size_t>(first_[static_cast<std::size_t>(u)])].rev;
      const int vt = first_[static_cast<std::size_t>(v)];
      const double f = std::min({want, arcs_[static_cast<std::size_t>(su)].cap, arcs_[static_cast<std::size_t>(vt)].cap});
      if (f <= eps_) continue;
      Send(su, f);
      Send(a, f);
      Send(vt, f);
    }
  }
  return MaxFlowAndCut(weights, in_cover);
}

bool BipartiteCoverFlow::AugmentLocally() {
  // Ford-Fulkerson from one left vertex u at a time: a breadth-first search from u (never through the source)
  // for a right vertex with residual sink capacity, then an augmentation along the path found. A search that
  // fails proves that nothing it visited can reach the sink, and that stays true for the rest of the computation
  // (an augmenting path entering that set could not leave it), so its nodes are marked reached from the source
  // for good and skipped by all later searches. Failed searches thus cost one pass over the source side in total;
  // after a warm start the successful ones stay near the few vertices whose capacities changed.
  level_.assign(static_cast<std::size_t>(node_count_), -1);  // >= 0: reached from the source
  parent_.resize(static_cast<std::size_t>(node_count_));
  // Work allowed for successful searches, in scanned arcs: about one Dinic phase. Short searches are free: many
  // short augmenting paths suit this method, many long ones suit Dinic's phases.
  constexpr std::int64_t kFreeWork = 16;
  std::int64_t budget = 2 * static_cast<std::int64_t>(arcs_.size()) + 64;
  for (int u = 0; u < left_count_; ++u) {
    const int from_source = arcs_[static_cast<std::size_t>(first_[static_cast<std::size_t>(u)])].rev;
    while (level_[static_cast<std::size_t>(u)] < 0 && arcs_[static_cast<std::size_t>(from_source)].cap > eps_) {
      if (++stamp_ == 0) {  // wrapped: forget all old marks
        std::fill(seen_.begin(), seen_.end(), 0U);
        stamp_ = 1;
      }
      queue_.assign(1, u);
      seen_[static_cast<std::size_t>(u)] = stamp_;
      int found = -1;
      std::int64_t work = 0;
      for (std::size_t h = 0; h < queue_.size() && found < 0; ++h) {
        const int x = queue_[h];
        const int end = first_[static_cast<std::size_t>(x) + 1];
        work += end - first_[static_cast<std::size_t>(x)];
        // Arc first_[x] is x's terminal arc; the others are left -> right arcs (infinite) or right -> left arcs
        // (residual capacity = the flow on the edge).
        for (int a = first_[static_cast<std::size_t>(x)] + 1; a < end; ++a) {
          const Arc& arc = arcs_[static_cast<std::size_t>(a)];
          const auto y = static_cast<std::size_t>(arc.head);
          if (seen_[y] == stamp_ || level_[y] >= 0 || !(arc.cap > eps_)) continue;
          seen_[y] = stamp_;
          parent_[y] = a;
          if (arc.head >= left_count_ && arcs_[static_cast<std::size_t>(first_[y])].cap > eps_) {
            found = arc.head;
            break;
          }
          queue_.push_back(arc.head);
        }
      }
      if (found < 0) {
        for (int x : queue_) level_[static_cast<std::size_t>(x)] = 0;
        break;
      }
      budget -= std::max<std::int64_t>(0, work - kFreeWork);
      if (budget < 0) return false;
      // Bottleneck: the source arc, the sink arc and the right -> left arcs of the path.
      const int to_sink = first_[static_cast<std::size_t>(found)];
      double f = std::min(arcs_[static_cast<std::size_t>(from_source)].cap, arcs_[static_cast<std::size_t>(to_sink)].cap);
      for (int y = found; y != u;) {
        const Arc& arc = arcs_[static_cast<std::size_t>(parent_[static_cast<std::size_t>(y)])];
        f = std::min(f, arc.cap);
        y = arcs_[static_cast<std::size_t>(arc.rev)].head;
      }
      for (int y = found; y != u;) {
        const int a = parent_[static_cast<std::size_t>(y)];
        Send(a, f);
        y = arcs_[static_cast<std::size_t>(arcs_[static_cast<std::size_t>(a)].rev)].head;
      }
      Send(from_source, f);
      Send(to_sink, f);
    }
  }
  return true;
}

void BipartiteCoverFlow::Dinic() {
  const int source = left_count_ + right_count_;
  const int sink = source + 1;
  std::vector<int>& path = stack_;  // arcs of the current DFS path
  while (BuildLevels()) {
    ++last_phases_;
    cursor_.assign(first_.begin(), first_.end() - 1);
    path.clear();
    int x = source;
    while (true) {
      if (x == sink) {
        double f = kInfiniteCapacity;
        for (int a : path) f = std::min(f, arcs_[static_cast<std::size_t>(a)].cap);
        std::size_t cut_at = path.size();
        for (std::size_t i = 0; i < path.size(); ++i) {
          const int a = path[i];
          Send(a, f);
          if (cut_at == path.size() && arcs_[static_cast<std::size_t>(a)].cap <= eps_) cut_at = i;
        }
        // Retreat to the tail of the first saturated arc.
        path.resize(cut_at);
        x = path.empty() ? source : arcs_[static_cast<std::size_t>(path.back())].head;
        continue;
      }
      int& it = cursor_[static_cast<std::size_t>(x)];
      const int end = first_[static_cast<std::size_t>(x) + 1];
      const int next_level = level_[static_cast<std::size_t>(x)] + 1;
      while (it < end && !(arcs_[static_cast<std::size_t>(it)].cap > eps_ &&
                           level_[static_cast<std::size_t>(arcs_[static_cast<std::size_t>(it)].head)] == next_level)) {
        ++it;
      }
      if (it < end) {
        path.push_back(it);
        x = arcs_[static_cast<std::size_t>(it)].head;
        continue;
      }
      // Dead end: remove x from this phase and retreat.
      level_[static_cast<std::size_t>(x)] = -1;
      if (path.empty()) break;  // the source is exhausted
      path.pop_back();
      x = path.empty() ? source : arcs_[static_cast<std::size_t>(path.back())].head;
      ++cursor_[static_cast<std::size_t>(x)];
    }
  }
}

Result<double> BipartiteCoverFlow::MaxFlowAndCut(const std::vector<double>& weights, std::vector<char>* in_cover) {
  const int n = left_count_ + right_count_;
  has_flow_ = true;
  last_phases_ = 0;
  // Local searches from each vertex with spare source capacity, which suit the small changes between successive
  // solves; Dinic's phases take over when the remaining augmenting paths turn out to be many and long.
  if (!AugmentLocally()) Dinic();
  // level_ >= 0 now marks the nodes reachable from the source in the residual network.
  double flow = 0.0;
  in_cover->resize(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) {
    const bool reached = level_[static_cast<std::size_t>(v)] >= 0;
    if (v < left_count_) {
      flow += weights[static_cast<std::size_t>(v)] - TerminalResidual(v);
      (*in_cover)[static_cast<std::size_t>(v)] = reached ? 0 : 1;
    } else {
      (*in_cover)[static_cast<std::size_t>(v)] = reached ? 1 : 0;
    }
  }
  return std::max(0.0, flow);
}

}  // namespace commerge
