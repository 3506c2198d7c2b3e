// SPDX-License-Identifier: BSD-3-Clause
// commerge: stage C, maximum edge-weighted clique selection (paper "Maximum Edge-Weighted Clique Selection in
// Exchange Graph"), with the compatibility graph it searches (the clique search itself is core/solvers/max_clique).
// The loops that survive stage B become the vertices of that compatibility graph; two loops t1 = (c1, q1),
// t2 = (c2, q2) are compatible when their positional consistency
//     kappa = | ||t^alpha_c1 - t^alpha_c2|| - ||t^beta_q1 - t^beta_q2|| |   (metres, each robot in its own frame)
// is below tau_con (mask M), and the edge weighs xi = exp(-w1 * kappa * w2), where w = the loop's descriptor
// distance f_sim (the perceptual consistency). The maximum edge-weighted clique of that graph is L_K.
//
// Which loops enter stage C (the paper's eq. "balanced_loop" is ambiguous in practice):
//  - kBothEndpointsSelected (default): loops of L_seq whose alpha AND beta keyframes were both selected by
//    stage B. Only these loops can be registered from the scans stage B chose, and the set is a strict
//    reduction of L_seq, which keeps the clique search small (the point of the cascade).
//  - kAnyEndpointSelected: the paper's literal set {(c, q) in L_seq | c selected OR q selected}. Because stage B
//    returns a vertex COVER, every loop has a selected endpoint, so this set is all of L_seq: stage B then
//    removes nothing. Available for comparison (profiling/bench_cascade shows both).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/sequential_matching.hpp"
#include "core/solvers/max_clique.hpp"

namespace commerge {

enum class StageCLoopSet {
  kBothEndpointsSelected,  ///< both keyframes of the loop selected by stage B
  kAnyEndpointSelected,    ///< the paper's literal set (equals L_seq for a vertex cover)
  /// Default: both endpoints; when no loop has both (a thin revisit band, whose minimum cover alternates
  /// between the robots), the fallback_max_loops loops of the paper's any-endpoint set with the smallest
  /// descriptor distance (StageCResult::any_endpoint_fallback): a few candidates for registration to verify,
  /// not the whole band.
  kBothEndpointsElseAny,
};

const char* StageCLoopSetName(StageCLoopSet set) noexcept;

struct StageCParams {
  StageCLoopSet loop_set = StageCLoopSet::kBothEndpointsElseAny;
  double tau_con_m = 5.0;   ///< feasibility mask: compatible when kappa < tau_con_m (paper: 5 m); > 0
  /// Most loops the compatibility graph takes (dense graph: bitsets + a float weight matrix, about
  /// max_loops^2 x 4.1 bytes: 2048 -> 17 MiB). Beyond it, the loops with the smallest descriptor distance are
  /// kept and the rest are counted in StageCResult::loops_dropped (never silently).
  int max_loops = 2048;
  /// kBothEndpointsElseAny: most loops the fallback set takes (>= 1).
  int fallback_max_loops = 10;
  /// Clique search: objective is always the edge weight; node and time limits apply (best-so-far + gap). The node
  /// limit normally binds (the same clique on every machine); the time limit is a safety cap
  /// (core/agent/decisions/023-solver-node-limits.md).
  double time_limit_s = 30.0;
  std::int64_t max_nodes = 2'000'000;
};

/// Errors for tau_con_m <= 0 or not finite, max_loops outside 1..kMaxEdgeWeightedCliqueVertices, bad limits.
Status ValidateStageCParams(const StageCParams& params);

struct StageCResult {
  std::vector<SequentialLoopCell> candidate_loops;  ///< vertices of the compatibility graph, in L_seq order
  std::size_t loops_in_set = 0;       ///< size of the chosen loop set before the max_loops cap
  bool any_endpoint_fallback = false; ///< kBothEndpointsElseAny found no loop with both: the any-endpoint set
  std::size_t loops_dropped = 0;      ///< loops_in_set - candidate_loops.size()
  std::size_t compatible_pairs = 0;   ///< edges of the compatibility graph (mask M)
  std::vector<SequentialLoopCell> selected_loops;  ///< L_K, in L_seq order
  CliqueSearchResult clique;          ///< objective = f_K(L_K), upper bound, status, nodes
  std::string no_candidate_reason;    ///< non-empty when no loop entered stage C
};

/// Positional consistency kappa of two loops (see the file comment); positions are keyframe translations of
/// each robot in its own map frame (p_map_keyframe).
double PositionalConsistency(const Eigen::Vector3d& alpha_c1, const Eigen::Vector3d& alpha_c2,
                             const Eigen::Vector3d& beta_q1, const Eigen::Vector3d& beta_q2) noexcept;

/// Compatibility score xi = exp(-w1 * kappa * w2).
double CompatibilityScore(double w1, double kappa, double w2) noexcept;

/// Builds the compatibility graph over `loops` (vertex i = loops[i]; an edge when kappa < tau_con with weight xi).
/// InvalidArgument when a loop index is outside the position spans, a position or distance is not finite, or
/// there are more loops than kMaxEdgeWeightedCliqueVertices.
Result<CliqueGraph> BuildCompatibilityGraph(Span<const SequentialLoopCell> loops,
                                            Span<const Eigen::Vector3d> alpha_positions_m,
                                            Span<const Eigen::Vector3d> beta_positions_m, double tau_con_m);

/// Stage C. `l_seq` = stage A's loops; `alpha_selected` / `beta_selected` = stage B's sorted keyframe indices;
/// positions are indexed by keyframe index. No loop in the chosen set gives an OK result with an empty
/// selection and no_candidate_reason set. Errors: bad params, indices outside the position spans.
Result<StageCResult> RunStageC(Span<const SequentialLoopCell> l_seq, Span<const int> alpha_selected,
                               Span<const int> beta_selected, Span<const Eigen::Vector3d> alpha_positions_m,
                               Span<const Eigen::Vector3d> beta_positions_m, const StageCParams& params);

}  // namespace commerge
