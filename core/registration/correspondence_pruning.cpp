// SPDX-License-Identifier: BSD-3-Clause
// Compatibility graph and maximum k-core / clique pruning (../shared/spec/REGISTRATION.md §1.2 "Pipeline", steps 9-10).
#include "core/registration/correspondence_pruning.hpp"

#include <algorithm>
#include <cmath>
#include <string>

namespace commerge {
namespace {

inline int PopCount(std::uint64_t w) { return __builtin_popcountll(w); }
inline int LowestBit(std::uint64_t w) { return __builtin_ctzll(w); }

}  // namespace

Status ValidatePruningParams(const PruningParams& p) {
  if (!(std::isfinite(p.noise_bound_m) && p.noise_bound_m > 0.0)) {
    return InvalidArgument("registration pruning: noise_bound_m must be finite and > 0");
  }
  if (p.max_clique_nodes < 1 || !(p.max_clique_time_limit_s > 0.0)) {
    return InvalidArgument("registration pruning: max_clique_nodes and max_clique_time_limit_s must be > 0");
  }
  return Status::Ok();
}

Result<CliqueGraph> BuildCompatibilityGraph(Span<const Eigen::Vector3f> a, Span<const Eigen::Vector3f> b,
                                            double noise_bound_m) {
  if (a.size() != b.size()) return InvalidArgument("compatibility graph: the point sets differ in size");
  if (a.size() > static_cast<std::size_t>(kMaxCliqueVertices)) {
    return InvalidArgument("compatibility graph: " + std::to_string(a.size()) + " correspondences, at most " +
                           std::to_string(kMaxCliqueVertices));
  }
  const int n = static_cast<int>(a.size());
  auto graph = CliqueGraph::Create(n, /*with_edge_weights=*/false);
  if (!graph.ok()) return graph.status();
  // Structure-of-arrays copies so that the inner loop vectorises.
  std::vector<float> ax(a.size()), ay(a.size()), az(a.size()), bx(b.size()), by(b.size()), bz(b.size());
  for (std::size_t k = 0; k < a.size(); ++k) {
    ax[k] = a[k].x(), ay[k] = a[k].y(), az[k] = a[k].z();
    bx[k] = b[k].x(), by[k] = b[k].y(), bz[k] = b[k].z();
  }
  const auto eps = static_cast<float>(noise_bound_m);
  std::vector<float> diff(a.size());
  for (int k = 0; k < n; ++k) {
    const float pax = ax[k], pay = ay[k], paz = az[k], pbx = bx[k], pby = by[k], pbz = bz[k];
    for (int l = k + 1; l < n; ++l) {
      const float dax = ax[l] - pax, day = ay[l] - pay, daz = az[l] - paz;
      const float dbx = bx[l] - pbx, dby = by[l] - pby, dbz = bz[l] - pbz;
      diff[l] = std::fabs(std::sqrt(dbx * dbx + dby * dby + dbz * dbz) - std::sqrt(dax * dax + day * day + daz * daz));
    }
    for (int l = k + 1; l < n; ++l) {
      if (diff[l] <= eps) {
        const Status s = graph->AddEdge(k, l);
        if (!s.ok()) return s;
      }
    }
  }
  return graph;
}

std::vector<int> CoreNumbers(const CliqueGraph& graph) {
  const int n = graph.num_vertices();
  const std::size_t words = graph.words_per_row();
  std::vector<int> deg(static_cast<std::size_t>(n), 0);
  int max_deg = 0;
  for (int v = 0; v < n; ++v) {
    const std::uint64_t* row = graph.adjacency_row(v);
    int d = 0;
    for (std::size_t w = 0; w < words; ++w) d += PopCount(row[w]);
    deg[static_cast<std::size_t>(v)] = d;
    max_deg = std::max(max_deg, d);
  }
  // Bucket sort by degree: vert[] in ascending degree, pos[v] its position, bin[d] start of degree d.
  std::vector<int> bin(static_cast<std::size_t>(max_deg) + 1, 0), vert(static_cast<std::size_t>(n)),
      pos(static_cast<std::size_t>(n));
  for (int v = 0; v < n; ++v) ++bin[static_cast<std::size_t>(deg[static_cast<std::size_t>(v)])];
  int start = 0;
  for (int& b : bin) {
    const int count = b;
    b = start;
    start += count;
  }
  for (int v = 0; v < n; ++v) {
    const auto d = static_cast<std::size_t>(deg[static_cast<std::size_t>(v)]);
    pos[static_cast<std::size_t>(v)] = bin[d];
    vert[static_cast<std::size_t>(bin[d])] = v;
    ++bin[d];
  }
  for (int d = max_deg; d > 0; --d) bin[static_cast<std::size_t>(d)] = bin[static_cast<std::size_t>(d) - 1];
  if (!bin.empty()) bin[0] = 0;
  // Peel in ascending order of current degree; a neighbour with a larger degree moves down one bucket.
  for (int i = 0; i < n; ++i) {
    const int v = vert[static_cast<std::size_t>(i)];
    const int dv = deg[static_cast<std::size_t>(v)];
    const std::uint64_t* row = graph.adjacency_row(v);
    for (std::size_t w = 0; w < words; ++w) {
      for (std::uint64_t bits = row[w]; bits != 0; bits &= bits - 1) {
        const int u = static_cast<int>(w * 64) + LowestBit(bits);
        const auto su = static_cast<std::size_t>(u);
        const int du = deg[su];
        if (du > dv) {
          const int pu = pos[su];
          const int pw = bin[static_cast<std::size_t>(du)];
          const int wv = vert[static_cast<std::size_t>(pw)];
          if (u != wv) {
            pos[su] = pw;
            vert[static_cast<std::size_t>(pu)] = wv;
            pos[static_cast<std::size_t>(wv)] = pu;
            vert[static_cast<std::size_t>(pw)] = u;
          }
          ++bin[static_cast<std::size_t>(du)];
          --deg[su];
        }
      }
    }
  }
  return deg;  // after peeling, deg[v] is the core number of v
}

Result<PruningStats> PruneCorrespondences(Span<const Eigen::Vector3f> a, Span<const Eigen::Vector3f> b,
                                          const PruningParams& params, std::vector<std::uint32_t>* inliers) {
  inliers->clear();
  const Status valid = ValidatePruningParams(params);
  if (!valid.ok()) return valid;
  auto graph = BuildCompatibilityGraph(a, b, params.noise_bound_m);
  if (!graph.ok()) return graph.status();
  PruningStats stats;
  stats.num_edges = graph->num_edges();
  const int n = graph->num_vertices();
  if (n == 0) return stats;
  if (params.method == PruningMethod::kMaxCore) {
    const std::vector<int> core = CoreNumbers(*graph);
    stats.max_core = *std::max_element(core.begin(), core.end());
    for (int v = 0; v < n; ++v) {
      if (core[static_cast<std::size_t>(v)] == stats.max_core) inliers->push_back(static_cast<std::uint32_t>(v));
    }
    return stats;
  }
  CliqueSearchParams cp;
  cp.objective = CliqueObjective::kCardinality;
  cp.max_nodes = params.max_clique_nodes;
  cp.time_limit_s = params.max_clique_time_limit_s;
  auto clique = SolveMaxClique(*graph, cp);
  if (!clique.ok()) return clique.status();
  stats.max_core = static_cast<int>(clique->clique.size());
  stats.clique_optimal = clique->status != CliqueSearchStatus::kLimitReached;
  for (int v : clique->clique) inliers->push_back(static_cast<std::uint32_t>(v));
  return stats;
}

}  // namespace commerge
