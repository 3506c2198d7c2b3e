// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/exchange_cascade.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "core/common/number_text.hpp"
#include "core/exchange/scan_context_affinity.hpp"

namespace commerge {
namespace {

// Distinct values of `indices`, ascending.
std::vector<std::size_t> Distinct(std::vector<std::size_t> indices) {
  std::sort(indices.begin(), indices.end());
  indices.erase(std::unique(indices.begin(), indices.end()), indices.end());
  return indices;
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int CompactIndex(const std::vector<std::size_t>& sorted, std::size_t value) {
  return static_cast<int>(std::lower_bound(sorted.begin(), sorted.end(), value) - sorted.begin());
}

}  // namespace

namespace {

// Index of stage A's S* in its cluster set (same span and cell count), or the set's size.
std::size_t IndexOfBest(const SequentialMatchResult& a) {
  const SequentialCluster& b = a.best;
  for (std::size_t k = 0; k < a.clusters.clusters.size(); ++k) {
    const SequentialCluster& c = a.clusters.clusters[k];
    if (c.row_min == b.row_min && c.row_max == b.row_max && c.col_min == b.col_min && c.col_max == b.col_max &&
        c.cell_count == b.cell_count) {
      return k;
    }
  }
  return a.clusters.clusters.size();
}

// The cluster passed on (`passed`, or none when it is the set's size), then the valid others by support, weight,
// index, max_placed in all.
void KeepPlacedClusters(const SequentialClusterSet& set, const PlaceConsensus& consensus, std::size_t passed,
                        std::size_t max_placed, ExchangeCascadeResult* result) {
  std::vector<std::size_t> order;
  for (std::size_t k = 0; k < set.clusters.size(); ++k) {
    if (k != passed && consensus.placements[k].valid) order.push_back(k);
  }
  const auto better = [&](std::size_t x, std::size_t y) {
    if (consensus.support[x] != consensus.support[y]) return consensus.support[x] > consensus.support[y];
    if (consensus.placements[x].weight != consensus.placements[y].weight) {
      return consensus.placements[x].weight > consensus.placements[y].weight;
    }
    return x < y;
  };
  const bool has_passed = passed < set.clusters.size();
  const std::size_t others = std::min(order.size(), has_passed ? max_placed - 1 : max_placed);
  std::partial_sort(order.begin(), order.begin() + static_cast<std::ptrdiff_t>(others), order.end(), better);
  order.resize(others);
  if (has_passed) order.insert(order.begin(), passed);
  result->placed_clusters.clear();
  for (const std::size_t k : order) {
    result->placed_clusters.push_back({set.clusters[k], consensus.placements[k], consensus.support[k], k == passed});
  }
}

// Stage A passed nothing on: its clusters are still placed and kept, as evidence.
Status PlaceClustersWithoutChoice(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                                  const PlaceConsensusParams& params, std::size_t max_placed,
                                  ExchangeCascadeResult* result) {
  const SequentialClusterSet& set = result->stage_a.clusters;
  auto consensus = RunPlaceConsensus(set, 0, std::numeric_limits<std::uint64_t>::max(), alpha.positions_m,
                                     beta.positions_m, params);
  if (!consensus.ok()) return consensus.status();
  KeepPlacedClusters(set, *consensus, set.clusters.size(), max_placed, result);
  return Status::Ok();
}

// Runs the place consensus over stage A's cluster set and, when it switches, makes the chosen cluster S*.
Status ApplyPlaceConsensus(const CascadeRobotInput& alpha, const CascadeRobotInput& beta, std::uint64_t min_span_area,
                           const PlaceConsensusParams& params, std::size_t max_placed, ExchangeCascadeResult* result) {
  SequentialMatchResult& a = result->stage_a;
  const std::size_t preferred = IndexOfBest(a);
  if (preferred == a.clusters.clusters.size()) {
    return Status(StatusCode::kInternal, "cascade: stage A's chosen cluster is not in its cluster set");
  }
  auto consensus = RunPlaceConsensus(a.clusters, preferred, min_span_area, alpha.positions_m, beta.positions_m, params);
  if (!consensus.ok()) return consensus.status();
  result->consensus_measured = true;
  result->consensus_support_lowest_mean = consensus->support[preferred];
  result->consensus_support_chosen = consensus->support[consensus->chosen];
  result->consensus_placement = consensus->placements[consensus->chosen];
  for (const ClusterPlacement& p : consensus->placements) result->consensus_clusters_placed += p.valid ? 1 : 0;
  KeepPlacedClusters(a.clusters, *consensus, consensus->chosen, max_placed, result);
  if (!consensus->switched) return Status::Ok();
  result->consensus_switched = true;
  result->consensus_reason = consensus->reason;
  a.best = a.clusters.clusters[consensus->chosen];
  const Span<const SequentialLoopCell> cells = a.clusters.CellsOf(consensus->chosen);
  a.cells.assign(cells.begin(), cells.end());
  return Status::Ok();
}

// Stage A had more cells below threshold than the consensus may hold (consensus_max_cells): its cluster set was not
// collected, so no other cluster can vote. The cluster passed on is placed alone: its support is its own weight,
// the least the consensus could have found, and the reason says why.
Status PlaceCappedCluster(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                          const ExchangeCascadeParams& params, ExchangeCascadeResult* result) {
  const SequentialMatchResult& a = result->stage_a;
  auto placement = PlaceCluster(Span<const SequentialLoopCell>(a.cells), a.best, alpha.positions_m, beta.positions_m,
                                params.consensus);
  if (!placement.ok()) return placement.status();
  result->consensus_measured = true;
  result->consensus_capped = true;
  result->consensus_support_lowest_mean = placement->valid ? placement->weight : 0.0;
  result->consensus_support_chosen = result->consensus_support_lowest_mean;
  result->consensus_placement = *placement;
  result->consensus_clusters_placed = placement->valid ? 1 : 0;
  result->consensus_reason = "place consensus skipped: " + std::to_string(a.num_cells_below_threshold) +
                             " cells below threshold > " + std::to_string(params.consensus_max_cells) +
                             " (--consensus-max-cells); the cluster's own weight is its support";
  result->placed_clusters.assign(1, PlacedCluster{a.best, *placement, result->consensus_support_chosen, true});
  return Status::Ok();
}

}  // namespace

const char* CascadeOutcomeName(CascadeOutcome outcome) noexcept {
  switch (outcome) {
    case CascadeOutcome::kPolicy: return "policy";
    case CascadeOutcome::kNoCandidate: return "no-candidate";
    case CascadeOutcome::kSolverFailure: return "solver-failure";
  }
  return "unknown";
}

namespace {

double RelativeGap(double incumbent, double bound) {
  const double scale = std::max({std::fabs(incumbent), std::fabs(bound), 1e-12});
  return std::fabs(bound - incumbent) / scale;
}

std::string Number(double x) { return FormatNumber(x, x == std::floor(x) && std::fabs(x) < 1e15 ? 15 : 4); }

}  // namespace

StageSolverOutcome StageBOutcome(const ExchangeCascadeResult& result) {
  StageSolverOutcome o;
  const BalancedCoverResult& b = result.stage_b;
  // Stage B ran when stage A passed loops on: its graph then has vertices (kNoCandidates is not possible there).
  o.ran = result.stage_b_vertices_alpha + result.stage_b_vertices_beta > 0;
  if (!o.ran) return o;
  o.status = BalancedCoverStatusName(b.status);
  o.proven = b.status == BalancedCoverStatus::kOptimal || b.status == BalancedCoverStatus::kNoCandidates ||
             b.status == BalancedCoverStatus::kInfeasible;
  o.limit_hit = b.status == BalancedCoverStatus::kFeasibleWithGap ||
                b.status == BalancedCoverStatus::kLimitWithoutSolution;
  o.no_selection = b.status == BalancedCoverStatus::kLimitWithoutSolution ||
                   b.status == BalancedCoverStatus::kInfeasible;
  o.incumbent = b.objective_weight;
  o.bound = b.lower_bound_weight;
  o.gap = o.proven || b.status == BalancedCoverStatus::kLimitWithoutSolution ? 0.0 : RelativeGap(o.incumbent, o.bound);
  o.nodes = b.nodes_explored;
  o.lp_solves = b.lp_solves;
  o.joint_robots = result.stage_b_joint_robots;
  return o;
}

StageSolverOutcome StageCOutcome(const ExchangeCascadeResult& result) {
  StageSolverOutcome o;
  const StageCResult& c = result.stage_c;
  o.ran = !c.candidate_loops.empty();
  o.loops_dropped = c.loops_dropped;
  if (!o.ran) return o;
  o.status = CliqueSearchStatusName(c.clique.status);
  o.proven = c.clique.status != CliqueSearchStatus::kLimitReached;
  o.limit_hit = !o.proven;
  o.incumbent = c.clique.objective;
  o.bound = c.clique.upper_bound;
  o.gap = o.proven ? 0.0 : RelativeGap(o.incumbent, o.bound);
  o.nodes = c.clique.nodes;
  o.lp_solves = c.clique.lp_solves;
  return o;
}

std::string FormatStageSolverOutcome(const StageSolverOutcome& o) {
  if (!o.ran) return o.loops_dropped > 0 ? "not run, " + std::to_string(o.loops_dropped) + " loops dropped" : "not run";
  std::string text = o.joint_robots > 0 ? "joint cover of " + std::to_string(o.joint_robots) + " robots, " : "";
  text += std::string(o.status) + ": " + Number(o.incumbent);
  if (o.proven) {
    text += " (bound " + Number(o.bound) + ")";
  } else {
    text += " against bound " + Number(o.bound) + " (gap " + FormatFixed(100.0 * o.gap, 2) + " %), node or time limit";
  }
  text += ", " + std::to_string(o.nodes) + (o.nodes == 1 ? " node, " : " nodes, ") + std::to_string(o.lp_solves) +
          (o.lp_solves == 1 ? " LP" : " LPs");
  if (o.loops_dropped > 0) text += ", " + std::to_string(o.loops_dropped) + " loops dropped (max_loops)";
  return text;
}

Status ValidateExchangeCascadeParams(const ExchangeCascadeParams& params) {
  if (Status s = ValidateSequentialMatchParams(params.stage_a); !s.ok()) return s;
  if (Status s = ValidateStageCParams(params.stage_c); !s.ok()) return s;
  if (Status s = ValidateExchangePolicyParams(params.policy); !s.ok()) return s;
  if (!(params.max_ambiguous_fraction >= 0.0 && params.max_ambiguous_fraction <= 1.0)) {
    return InvalidArgument("cascade max_ambiguous_fraction must be in [0, 1], got " +
                           std::to_string(params.max_ambiguous_fraction));
  }
  if (!(std::isfinite(params.ambiguity_far_m) && params.ambiguity_far_m >= 0.0)) {
    return InvalidArgument("cascade ambiguity_far_m must be finite and >= 0, got " +
                           std::to_string(params.ambiguity_far_m));
  }
  if (params.consensus_max_cells > 0) {
    if (Status s = ValidatePlaceConsensusParams(params.consensus); !s.ok()) return s;
    if (params.max_placed_clusters == 0) return InvalidArgument("cascade max_placed_clusters must be >= 1, got 0");
  }
  if (!(params.verification_area_fraction >= 0.0 && params.verification_area_fraction <= 1.0)) {
    return InvalidArgument("cascade verification_area_fraction must be in [0, 1], got " +
                           std::to_string(params.verification_area_fraction));
  }
  return Status::Ok();
}

namespace {

// Stage A on the metric's affinity: the unit-L2 tile kernel, or Scan Context distances (sector-key shifts).
Result<SequentialMatchResult> StageA(const DescriptorSetView& alpha, const DescriptorSetView& beta,
                                     const SequentialMatchParams& params, const DescriptorMetric& metric) {
  if (metric.kind == DescriptorMetric::Kind::kUnitL2) return RunSequentialMatching(alpha, beta, params);
  if (Status s = ValidateSequentialMatchParams(params); !s.ok()) return s;
  ScanContextAffinityParams sc;
  sc.num_rings = metric.scan_context_rings;
  sc.num_sectors = metric.scan_context_sectors;
  const std::size_t halo = SequentialMatchTileHalo(params);
  auto source = ScanContextTileSource::Create(alpha, beta, sc, params.tile_rows + halo, params.tile_cols + halo);
  if (!source.ok()) return source.status();
  return RunSequentialMatching(*source, params);
}

Status ValidateCascadeInputs(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                             const ExchangeCascadeParams& params) {
  if (Status s = ValidateExchangeCascadeParams(params); !s.ok()) return s;
  if (Status s = ValidateDescriptorSet(alpha.descriptors, "alpha"); !s.ok()) return s;
  if (Status s = ValidateDescriptorSet(beta.descriptors, "beta"); !s.ok()) return s;
  if (alpha.positions_m.size() != alpha.descriptors.count() || beta.positions_m.size() != beta.descriptors.count()) {
    return InvalidArgument("cascade: positions per robot must match its descriptors (alpha " +
                           std::to_string(alpha.positions_m.size()) + " vs " +
                           std::to_string(alpha.descriptors.count()) + ", beta " +
                           std::to_string(beta.positions_m.size()) + " vs " + std::to_string(beta.descriptors.count()) +
                           ")");
  }
  return Status::Ok();
}

}  // namespace

Result<ExchangeCascadeResult> RunExchangeCascade(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                                                 const ExchangeCascadeParams& params) {
  auto result = RunCascadeStageA(alpha, beta, params);
  if (!result.ok() || !CascadeAwaitsStageB(*result)) return result;
  if (Status s = RunCascadeFromStageB(alpha, beta, params, nullptr, 0, &*result); !s.ok()) return s;
  return result;
}

bool CascadeAwaitsStageB(const ExchangeCascadeResult& result) noexcept {
  return result.stage_a.found && !result.stage_a.cells.empty() && result.no_candidate_reason.empty() &&
         result.stage_b_vertices_alpha + result.stage_b_vertices_beta == 0 && result.outcome != CascadeOutcome::kPolicy;
}

Result<ExchangeCascadeResult> RunCascadeStageA(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                                               const ExchangeCascadeParams& params) {
  if (Status s = ValidateCascadeInputs(alpha, beta, params); !s.ok()) return s;
  ExchangeCascadeResult result;

  // Stage A: L_seq.
  auto t0 = std::chrono::steady_clock::now();
  SequentialMatchParams stage_a_params = params.stage_a;
  stage_a_params.all_clusters_max_cells = params.consensus_max_cells;
  auto stage_a = StageA(alpha.descriptors, beta.descriptors, stage_a_params, params.metric);
  if (!stage_a.ok()) return stage_a.status();
  result.stage_a = std::move(*stage_a);
  const std::uint64_t asked =
      EffectiveTauArea(params.stage_a, alpha.descriptors.count(), beta.descriptors.count());
  std::uint64_t candidate_area = asked;
  const std::uint64_t largest = result.stage_a.largest_span_area;
  if (!result.stage_a.found && largest > 0 && params.verification_area_fraction > 0.0 &&
      static_cast<double>(largest) >= params.verification_area_fraction * static_cast<double>(asked)) {
    SequentialMatchParams retry = stage_a_params;
    retry.tau_area = largest;
    retry.tau_area_fraction = 0.0;
    auto again = StageA(alpha.descriptors, beta.descriptors, retry, params.metric);
    if (!again.ok()) return again.status();
    if (again->found) {
      result.verification = true;
      result.verification_reason = "largest cluster spans " + std::to_string(largest) + " of the " +
                                   std::to_string(asked) + " cells asked";
      result.stage_a = std::move(*again);
      candidate_area = largest;
    }
  }
  if (result.stage_a.found && !result.stage_a.clusters.clusters.empty()) {
    Status s = ApplyPlaceConsensus(alpha, beta, candidate_area, params.consensus, params.max_placed_clusters, &result);
    if (!s.ok()) return s;
  } else if (result.stage_a.found && params.consensus_max_cells > 0 && !result.stage_a.cells.empty()) {
    if (Status s = PlaceCappedCluster(alpha, beta, params, &result); !s.ok()) return s;
  } else if (!result.stage_a.clusters.clusters.empty()) {
    Status s = PlaceClustersWithoutChoice(alpha, beta, params.consensus, params.max_placed_clusters, &result);
    if (!s.ok()) return s;
  }
  result.stage_a.clusters = SequentialClusterSet{};
  result.stage_a_s = SecondsSince(t0);
  if (!result.stage_a.found) {
    result.no_candidate_reason = "stage A: " + result.stage_a.no_candidate_reason;
    return result;
  }
  if (params.max_ambiguous_fraction < 1.0) {
    auto ambiguity = MeasurePlaceAmbiguity(alpha.descriptors, alpha.positions_m, beta.descriptors, beta.positions_m,
                                           Span<const SequentialLoopCell>(result.stage_a.cells), params.ambiguity_far_m,
                                           params.metric);
    if (!ambiguity.ok()) return ambiguity.status();
    result.ambiguity_measured = true;
    result.ambiguity = *ambiguity;
    if (result.ambiguity.max_fraction() > params.max_ambiguous_fraction) {
      const bool alpha_worse = result.ambiguity.alpha_fraction() >= result.ambiguity.beta_fraction();
      result.ambiguous = true;
      result.ambiguity_reason =
          std::to_string(alpha_worse ? result.ambiguity.alpha_ambiguous : result.ambiguity.beta_ambiguous) + " of " +
          std::to_string(alpha_worse ? result.ambiguity.alpha_keyframes : result.ambiguity.beta_keyframes) +
          " of robot " + (alpha_worse ? "alpha" : "beta") + "'s keyframes in the cluster look as alike to a place of " +
          "its own map more than " + FormatNumber(params.ambiguity_far_m, 3) + " m away";
    }
  }
  return result;
}

namespace {

// A joint cover's part for one pair must be a cover of its L_seq by keyframes of its L_seq (unless it has no
// selection at all).
Status CheckJointCover(const BalancedCoverResult& cover, const std::vector<SequentialLoopCell>& l_seq,
                       const std::vector<std::size_t>& alpha_ids, const std::vector<std::size_t>& beta_ids) {
  if (cover.status == BalancedCoverStatus::kInfeasible || cover.status == BalancedCoverStatus::kLimitWithoutSolution) {
    return Status::Ok();
  }
  const auto within = [](const std::vector<int>& selected, const std::vector<std::size_t>& ids) {
    return std::is_sorted(selected.begin(), selected.end()) &&
           std::all_of(selected.begin(), selected.end(), [&](int k) {
             return k >= 0 && std::binary_search(ids.begin(), ids.end(), static_cast<std::size_t>(k));
           });
  };
  if (!within(cover.selected_left, alpha_ids) || !within(cover.selected_right, beta_ids)) {
    return InvalidArgument("cascade: the joint cover selects keyframes outside the pair's L_seq (or unsorted)");
  }
  for (const SequentialLoopCell& l : l_seq) {
    const bool covered =
        std::binary_search(cover.selected_left.begin(), cover.selected_left.end(), static_cast<int>(l.alpha_index)) ||
        std::binary_search(cover.selected_right.begin(), cover.selected_right.end(), static_cast<int>(l.beta_index));
    if (!covered) {
      return InvalidArgument("cascade: the joint cover leaves loop (" + std::to_string(l.alpha_index) + ", " +
                             std::to_string(l.beta_index) + ") of L_seq uncovered");
    }
  }
  return Status::Ok();
}

}  // namespace

Status RunCascadeFromStageB(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                            const ExchangeCascadeParams& params, const BalancedCoverResult* joint_cover,
                            int joint_robots, ExchangeCascadeResult* result_out) {
  if (Status s = ValidateCascadeInputs(alpha, beta, params); !s.ok()) return s;
  if (joint_cover != nullptr && joint_robots < 2) {
    return InvalidArgument("cascade: a joint cover spans at least 2 robots, got " + std::to_string(joint_robots));
  }
  if (!CascadeAwaitsStageB(*result_out)) {
    return InvalidArgument("cascade: stage B needs a result of RunCascadeStageA that passed loops on");
  }
  ExchangeCascadeResult& result = *result_out;
  // Stage B on the exchange graph of L_seq: vertices = distinct keyframes, compacted to 0..n-1 per robot.
  auto t0 = std::chrono::steady_clock::now();
  const std::vector<SequentialLoopCell>& l_seq = result.stage_a.cells;
  std::vector<std::size_t> alpha_ids, beta_ids;
  alpha_ids.reserve(l_seq.size());
  beta_ids.reserve(l_seq.size());
  for (const SequentialLoopCell& l : l_seq) {
    alpha_ids.push_back(l.alpha_index);
    beta_ids.push_back(l.beta_index);
  }
  alpha_ids = Distinct(std::move(alpha_ids));
  beta_ids = Distinct(std::move(beta_ids));
  result.stage_b_vertices_alpha = alpha_ids.size();
  result.stage_b_vertices_beta = beta_ids.size();
  std::vector<BipartiteEdge> edges;
  edges.reserve(l_seq.size());
  for (const SequentialLoopCell& l : l_seq) {
    edges.push_back({CompactIndex(alpha_ids, l.alpha_index), CompactIndex(beta_ids, l.beta_index)});
  }
  if (joint_cover != nullptr) {
    if (Status s = CheckJointCover(*joint_cover, l_seq, alpha_ids, beta_ids); !s.ok()) return s;
    result.stage_b = *joint_cover;
    result.stage_b_joint_robots = joint_robots;
  } else {
    auto graph = BipartiteGraph::Create(static_cast<int>(alpha_ids.size()), static_cast<int>(beta_ids.size()),
                                        std::move(edges));
    if (!graph.ok()) return graph.status();
    auto stage_b = SolveBalancedVertexCover(*graph, params.stage_b);
    if (!stage_b.ok()) return stage_b.status();
    result.stage_b = std::move(*stage_b);
    // Back to keyframe indices (the compaction is monotone, so the lists stay sorted).
    for (int& v : result.stage_b.selected_left) v = static_cast<int>(alpha_ids[static_cast<std::size_t>(v)]);
    for (int& v : result.stage_b.selected_right) v = static_cast<int>(beta_ids[static_cast<std::size_t>(v)]);
  }
  result.stage_b_s = SecondsSince(t0);
  if (result.stage_b.status == BalancedCoverStatus::kInfeasible ||
      result.stage_b.status == BalancedCoverStatus::kLimitWithoutSolution) {
    result.outcome = CascadeOutcome::kSolverFailure;
    result.no_candidate_reason = std::string(result.stage_b_joint_robots > 0 ? "stage B (joint cover): " : "stage B: ") +
                                 BalancedCoverStatusName(result.stage_b.status);
    return Status::Ok();
  }

  // Stage C: L_K.
  t0 = std::chrono::steady_clock::now();
  auto stage_c = RunStageC(l_seq, result.stage_b.selected_left, result.stage_b.selected_right, alpha.positions_m,
                           beta.positions_m, params.stage_c);
  if (!stage_c.ok()) return stage_c.status();
  result.stage_c = std::move(*stage_c);
  result.stage_c_s = SecondsSince(t0);
  if (result.stage_c.selected_loops.empty()) {
    result.no_candidate_reason = "stage C: " + result.stage_c.no_candidate_reason;
    return Status::Ok();
  }

  // Exchange policy.
  t0 = std::chrono::steady_clock::now();
  auto policy = MakeExchangePolicy(result.stage_c.selected_loops, l_seq, alpha.stored_points, beta.stored_points,
                                   params.policy);
  if (!policy.ok()) return policy.status();
  result.policy = std::move(*policy);
  result.policy_s = SecondsSince(t0);
  result.outcome = CascadeOutcome::kPolicy;
  return Status::Ok();
}

Result<JointCoverResult> SolveJointStageB(Span<const JointCoverPair> pairs, const BalancedCoverParams& params) {
  if (!params.vertex_weights.empty()) {
    return InvalidArgument("joint stage B: unit weights only (vertex_weights must be empty, got " +
                           std::to_string(params.vertex_weights.size()) + ")");
  }
  const auto t0 = std::chrono::steady_clock::now();
  JointCoverResult out;
  std::vector<std::pair<int, int>> seen;
  for (const JointCoverPair& p : pairs) {
    if (p.alpha_robot < 0 || p.beta_robot < 0 || p.alpha_robot == p.beta_robot) {
      return InvalidArgument("joint stage B: pair of robots " + std::to_string(p.alpha_robot) + " and " +
                             std::to_string(p.beta_robot) + " (ids must be >= 0 and differ)");
    }
    const std::pair<int, int> key = std::minmax(p.alpha_robot, p.beta_robot);
    if (std::find(seen.begin(), seen.end(), key) != seen.end()) {
      return InvalidArgument("joint stage B: robots " + std::to_string(key.first) + " and " +
                             std::to_string(key.second) + " given twice");
    }
    seen.push_back(key);
    out.robots.push_back(p.alpha_robot);
    out.robots.push_back(p.beta_robot);
  }
  std::sort(out.robots.begin(), out.robots.end());
  out.robots.erase(std::unique(out.robots.begin(), out.robots.end()), out.robots.end());
  const auto slot = [&](int robot) {
    return static_cast<std::size_t>(std::lower_bound(out.robots.begin(), out.robots.end(), robot) - out.robots.begin());
  };
  // Vertices: each robot's distinct keyframes over every pair's L_seq, in ascending order.
  std::vector<std::vector<std::size_t>> keyframes(out.robots.size());
  for (const JointCoverPair& p : pairs) {
    for (const SequentialLoopCell& l : p.l_seq) {
      keyframes[slot(p.alpha_robot)].push_back(l.alpha_index);
      keyframes[slot(p.beta_robot)].push_back(l.beta_index);
    }
  }
  std::vector<int> counts, begins;
  int total = 0;
  for (auto& k : keyframes) {
    k = Distinct(std::move(k));
    begins.push_back(total);
    counts.push_back(static_cast<int>(k.size()));
    total += static_cast<int>(k.size());
  }
  std::vector<ExchangeEdge> edges;
  for (const JointCoverPair& p : pairs) {
    const std::size_t a = slot(p.alpha_robot), b = slot(p.beta_robot);
    for (const SequentialLoopCell& l : p.l_seq) {
      edges.push_back({begins[a] + CompactIndex(keyframes[a], l.alpha_index),
                       begins[b] + CompactIndex(keyframes[b], l.beta_index)});
    }
  }
  auto graph = ExchangeGraph::Create(counts, std::move(edges));
  if (!graph.ok()) return graph.status();
  auto cover = SolveMultiRobotBalancedCover(*graph, params);
  if (!cover.ok()) return cover.status();
  out.cover = std::move(*cover);
  // Back to keyframe indices per robot (ascending: the vertex ids are).
  std::vector<std::vector<int>> selected(out.robots.size());
  for (int v : out.cover.selected) {
    const auto r = static_cast<std::size_t>(graph->robot_of(v));
    selected[r].push_back(static_cast<int>(keyframes[r][static_cast<std::size_t>(v - begins[r])]));
  }
  for (const JointCoverPair& p : pairs) {
    BalancedCoverResult b;
    b.status = out.cover.status;
    b.objective_scans = out.cover.objective_scans;
    b.objective_weight = out.cover.objective_weight;
    b.lower_bound_weight = out.cover.lower_bound_weight;
    b.lower_bound_scans = static_cast<int>(std::ceil(out.cover.lower_bound_weight - 1e-9));
    b.max_matching_size = out.cover.max_matching_size;
    b.min_share_per_robot = out.cover.min_share_per_robot;
    b.nodes_explored = out.cover.nodes_explored;
    b.lp_solves = out.cover.lp_solves;
    b.min_cut_solves = out.cover.min_cut_solves;
    b.simplex_iterations = out.cover.simplex_iterations;
    b.lp_basis_rebuilds = out.cover.lp_basis_rebuilds;
    std::vector<std::size_t> mine_a, mine_b;
    for (const SequentialLoopCell& l : p.l_seq) {
      mine_a.push_back(l.alpha_index);
      mine_b.push_back(l.beta_index);
    }
    mine_a = Distinct(std::move(mine_a));
    mine_b = Distinct(std::move(mine_b));
    for (int k : selected[slot(p.alpha_robot)]) {
      if (std::binary_search(mine_a.begin(), mine_a.end(), static_cast<std::size_t>(k))) b.selected_left.push_back(k);
    }
    for (int k : selected[slot(p.beta_robot)]) {
      if (std::binary_search(mine_b.begin(), mine_b.end(), static_cast<std::size_t>(k))) b.selected_right.push_back(k);
    }
    out.pairs.push_back(std::move(b));
  }
  out.seconds = SecondsSince(t0);
  return out;
}

}  // namespace commerge
