// SPDX-License-Identifier: BSD-3-Clause
// commerge: outlier pruning of putative correspondences (../shared/spec/REGISTRATION.md §1.2 "Pipeline", steps 9-10): a
// pairwise compatibility graph (two correspondences agree when they preserve their mutual distance, a test that is
// invariant to the unknown rotation and translation) and its maximum k-core (Batagelj-Zaversnik core decomposition) or,
// as an option, its maximum clique (core/solvers/max_clique).
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/solvers/max_clique.hpp"

namespace commerge {

enum class PruningMethod {
  kMaxCore,    ///< vertices whose core number is the maximum (spec default; fast, may keep several clusters)
  kMaxClique,  ///< the maximum clique (exact up to the node limit; slower)
};

struct PruningParams {
  /// Edge (k, l) iff | |b_k - b_l| - |a_k - a_l| | <= noise_bound_m (spec epsilon_R = 1 x voxel, <= 1 m).
  double noise_bound_m = 1.0;
  PruningMethod method = PruningMethod::kMaxCore;
  /// kMaxClique: branch-and-bound node limit (deterministic); the best clique so far is used at the limit.
  std::int64_t max_clique_nodes = 2'000'000;
  /// kMaxClique: wall-clock limit of the solver [s]; keep it generous so that the node limit decides.
  double max_clique_time_limit_s = 30.0;
};

/// InvalidArgument when noise_bound_m is not finite and > 0 or the clique limits are not positive.
Status ValidatePruningParams(const PruningParams& params);

struct PruningStats {
  std::size_t num_edges = 0;
  int max_core = 0;            ///< largest core number (kMaxCore), clique size (kMaxClique)
  bool clique_optimal = true;  ///< kMaxClique: false when a limit stopped the search
};

/// Builds the compatibility graph of correspondences (a_k in the source, b_k in the target): an edge joins
/// k and l when | |b_k - b_l| - |a_k - a_l| | <= noise_bound_m. Sizes must match and be <= kMaxCliqueVertices.
Result<CliqueGraph> BuildCompatibilityGraph(Span<const Eigen::Vector3f> a, Span<const Eigen::Vector3f> b,
                                            double noise_bound_m);

/// Core number of every vertex (the largest k such that the vertex belongs to the k-core, the maximal
/// subgraph whose vertices all have degree >= k), by Batagelj-Zaversnik bucket peeling in O(V + E).
std::vector<int> CoreNumbers(const CliqueGraph& graph);

/// Prunes the correspondences: *inliers receives the indices (into a and b, ascending, i.e. the input order)
/// of the maximum k-core or the maximum clique. Errors: sizes differ or exceed kMaxCliqueVertices; clique
/// solver errors. Deterministic for kMaxCore and for kMaxClique when the node limit (not the time limit)
/// stops the search.
Result<PruningStats> PruneCorrespondences(Span<const Eigen::Vector3f> a, Span<const Eigen::Vector3f> b,
                                          const PruningParams& params, std::vector<std::uint32_t>* inliers);

}  // namespace commerge
