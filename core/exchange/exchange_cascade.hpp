// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's three-stage cascade for one robot pair, read like the paper: affinity + stage A
// (sequential matching) -> stage B (balanced vertex cover) -> stage C (maximum edge-weighted clique) -> exchange
// policy. Nested by construction: L_K subset of L_V subset of L_seq subset of L. Every stage's outcome, size and
// optimality is kept in the result so a report (and a field engineer) can see where the candidates went.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/affinity.hpp"
#include "core/exchange/balanced_vertex_cover.hpp"
#include "core/exchange/edge_weighted_clique.hpp"
#include "core/exchange/exchange_policy.hpp"
#include "core/exchange/place_ambiguity.hpp"
#include "core/exchange/place_consensus.hpp"
#include "core/exchange/sequential_matching.hpp"

namespace commerge {

struct ExchangeCascadeParams {
  SequentialMatchParams stage_a;
  BalancedCoverParams stage_b;
  StageCParams stage_c;
  ExchangePolicyParams policy;
  /// Ours; 0 = off (the paper). When no cluster of stage A spans the area asked (EffectiveTauArea) but the
  /// largest spans at least this fraction of it, stage A takes that largest cluster (a second pass asking for
  /// exactly its span area) and the cascade goes on, flagged `verification`: the few scans its policy names
  /// are registered, and the registration gates decide as for every candidate. In [0, 1]
  /// (core/agent/decisions/002-verification-below-tau-area.md).
  double verification_area_fraction = 0.0;
  /// Ours; 1 = off (the paper). When more than this fraction of the chosen cluster's keyframes of either robot are
  /// ambiguous (the robot's own map has a keyframe more than ambiguity_far_m away whose descriptor is as close as
  /// the other robot's match, place_ambiguity.hpp), the result is flagged `ambiguous` (evidence for the server's
  /// decisions, core/agent/pair_decision.hpp). In [0, 1] (core/agent/decisions/003-ambiguous-places.md).
  double max_ambiguous_fraction = 1.0;
  /// [m], >= 0: how far a keyframe of the robot's own map must be to count as another place.
  double ambiguity_far_m = 20.0;
  /// Ours; 0 = off (the paper). c > 0: when stage A has at most c cells below threshold, every cluster is placed
  /// from the robots' keyframe positions and S* gives way to the qualifying cluster the other clusters confirm
  /// (place_consensus.hpp; core/agent/decisions/004-place-consensus.md).
  std::size_t consensus_max_cells = 0;
  PlaceConsensusParams consensus;
  /// At most this many placed clusters are kept in the result (ExchangeCascadeResult::placed_clusters); >= 1.
  std::size_t max_placed_clusters = 16;
  /// How descriptors are compared: unit L2 (SOLiD, the ring descriptor; the tile kernel) or the Scan Context
  /// distance (ScanContextTileSource, sector-key shifts). The server derives it from the records it takes.
  DescriptorMetric metric;
};

/// Checks every stage's parameters and verification_area_fraction; InvalidArgument naming the field.
Status ValidateExchangeCascadeParams(const ExchangeCascadeParams& params);

/// One robot's side of the cascade input: descriptors (rows = keyframe index), keyframe positions in the robot's
/// own map frame (same count), and optionally the stored point count per keyframe (empty = unknown).
struct CascadeRobotInput {
  DescriptorSetView descriptors;
  Span<const Eigen::Vector3d> positions_m;
  Span<const std::uint32_t> stored_points;
};

enum class CascadeOutcome {
  kPolicy,         ///< a non-empty exchange policy was produced
  kNoCandidate,    ///< a stage found nothing to pass on (reason in no_candidate_reason)
  kSolverFailure,  ///< stage B hit a limit without any feasible cover, or proved infeasibility (reason given)
};

const char* CascadeOutcomeName(CascadeOutcome outcome) noexcept;

/// One of stage A's clusters with where it places robot beta's map in robot alpha's.
struct PlacedCluster {
  SequentialCluster cluster;
  ClusterPlacement placement;  ///< invalid when its keyframes span less than the consensus' min_extent_m
  double support = 0.0;        ///< summed weight of the valid clusters agreeing with it (itself included)
  bool passed_on = false;      ///< the cluster stage A passed on (S*, or the one the consensus switched to)
};

struct ExchangeCascadeResult {
  CascadeOutcome outcome = CascadeOutcome::kNoCandidate;
  std::string no_candidate_reason;   ///< empty for kPolicy
  /// Stage A found no cluster of the asked span area and passed on its largest one instead
  /// (ExchangeCascadeParams::verification_area_fraction); verification_reason says what it found.
  bool verification = false;
  std::string verification_reason;
  /// Of stage A's chosen cluster (measured when max_ambiguous_fraction < 1 and a cluster was found); `ambiguous`
  /// when it exceeds max_ambiguous_fraction, ambiguity_reason says how.
  bool ambiguity_measured = false;
  PlaceAmbiguity ambiguity;
  bool ambiguous = false;
  std::string ambiguity_reason;
  /// Place consensus (consensus_max_cells > 0 and stage A's clusters collected): the support of S* and of the
  /// cluster passed on; `consensus_switched` when that is not S* (consensus_reason says why).
  bool consensus_measured = false;
  bool consensus_switched = false;
  /// Stage A had more cells below threshold than consensus_max_cells: no other cluster voted, the cluster passed on
  /// was placed alone and its support is its own weight (consensus_reason says so).
  bool consensus_capped = false;
  double consensus_support_lowest_mean = 0.0;
  double consensus_support_chosen = 0.0;
  /// Where the cluster passed on places robot beta's map in robot alpha's (from the keyframe positions).
  ClusterPlacement consensus_placement;
  std::size_t consensus_clusters_placed = 0;  ///< clusters with a placement (the voters)
  std::string consensus_reason;
  /// The clusters placed from stage A's cluster set (collected when consensus_max_cells > 0 and no more cells are
  /// below threshold), at most ExchangeCascadeParams::max_placed_clusters: the one passed on first (none when
  /// stage A passed nothing on), then the valid ones of most support (ties: more weight, then lower index).
  /// Evidence about the places other than the one passed on (core/agent/pair_decision.hpp); nothing decides on
  /// it yet.
  std::vector<PlacedCluster> placed_clusters;
  SequentialMatchResult stage_a;     ///< L_seq = stage_a.cells (its cluster set is released after the consensus)
  BalancedCoverResult stage_b;       ///< selected keyframes (indices of the robots, not of the compacted graph)
  StageCResult stage_c;              ///< candidate loops (L_V as used) and L_K = stage_c.selected_loops
  ExchangePolicy policy;
  std::size_t stage_b_vertices_alpha = 0;  ///< distinct alpha keyframes in L_seq
  std::size_t stage_b_vertices_beta = 0;   ///< distinct beta keyframes in L_seq
  /// > 0: stage_b is this pair's part of one joint cover over this many robots (SolveJointStageB): its selection
  /// is the joint selection's keyframes of the pair's L_seq; status, objective, bound and counters are the joint
  /// solve's. 0: the pair's own cover.
  int stage_b_joint_robots = 0;
  /// Wall-clock seconds (steady clock) of stage A (affinity + labelling), B, C and the policy (B of a joint cover:
  /// the whole joint solve, in each of its pairs).
  double stage_a_s = 0.0, stage_b_s = 0.0, stage_c_s = 0.0, policy_s = 0.0;
};

/// One solver stage's outcome as reports and messages carry it: stage B (balanced cover, a minimisation of
/// scans or weight) or stage C (maximum edge-weighted clique, a maximisation of f_K).
struct StageSolverOutcome {
  bool ran = false;           ///< the stage was reached (false: an earlier stage stopped the cascade)
  const char* status = "not run";  ///< the solver's status name ("optimal", "feasible-with-gap", "limit", ...)
  bool proven = false;        ///< the incumbent is proven optimal (or nothing had to be solved)
  bool limit_hit = false;     ///< a node or time limit stopped the search
  bool no_selection = false;  ///< B: no cover (a limit before any, or shares that cannot be met)
  double incumbent = 0.0;     ///< objective of the selection: B scans (unit weights) or weight; C f_K
  double bound = 0.0;         ///< proven bound on the optimum: B lower, C upper
  double gap = 0.0;           ///< |bound - incumbent| / max(|bound|, |incumbent|, 1e-12); 0 when proven
  std::int64_t nodes = 0;     ///< branch-and-bound nodes
  std::int64_t lp_solves = 0; ///< LP relaxations solved (B: master LPs; C: GLPK bounds)
  std::size_t loops_dropped = 0;  ///< C only: loops beyond StageCParams::max_loops left out of the graph
  int joint_robots = 0;       ///< B only: > 0 when the figures are those of one joint cover over this many robots
};

/// Stage B's and stage C's outcome of a cascade result.
StageSolverOutcome StageBOutcome(const ExchangeCascadeResult& result);
StageSolverOutcome StageCOutcome(const ExchangeCascadeResult& result);
/// One line for a person: "optimal: 12 (bound 12), 3 nodes, 5 LPs" or "feasible-with-gap: 14 >= 12 (gap 14.3 %),
/// node or time limit, ..." ("not run" when the stage was not reached); a joint cover's line starts with
/// "joint cover of N robots, ".
std::string FormatStageSolverOutcome(const StageSolverOutcome& outcome);

/// Runs the cascade. Errors: malformed inputs (descriptor sets, positions count != descriptor count, bad params).
/// Degenerate inputs (no cluster, nothing selected) give an OK result with outcome kNoCandidate and the reason.
/// The same as RunCascadeStageA followed, when it awaits stage B, by RunCascadeFromStageB with the pair's own
/// cover.
Result<ExchangeCascadeResult> RunExchangeCascade(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                                                 const ExchangeCascadeParams& params);

/// The cascade up to stage B: affinity and stage A, the verification retry, the place consensus and the
/// ambiguity measure. The result either ends there (kNoCandidate with its reason) or awaits stage B.
Result<ExchangeCascadeResult> RunCascadeStageA(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                                               const ExchangeCascadeParams& params);
/// Stage A passed L_seq on: stage B, C and the policy are still to run.
bool CascadeAwaitsStageB(const ExchangeCascadeResult& result) noexcept;

/// Stages B, C and the policy of a result that awaits stage B (same inputs as its RunCascadeStageA).
/// `joint_cover` = nullptr: stage B solves the pair's own balanced cover of L_seq. Otherwise it is the pair's part
/// of a joint cover over `joint_robots` (>= 2) robots (SolveJointStageB; selections are keyframe indices) and
/// becomes stage_b as it is: it must cover every loop of L_seq with keyframes of L_seq (InvalidArgument
/// otherwise) unless its status says it has no selection.
Status RunCascadeFromStageB(const CascadeRobotInput& alpha, const CascadeRobotInput& beta,
                            const ExchangeCascadeParams& params, const BalancedCoverResult* joint_cover,
                            int joint_robots, ExchangeCascadeResult* result);

/// One robot pair's input to the joint stage B: the robots' ids and the pair's L_seq.
struct JointCoverPair {
  int alpha_robot = 0, beta_robot = 0;
  Span<const SequentialLoopCell> l_seq;
};

struct JointCoverResult {
  MultiRobotCoverResult cover;  ///< over the robots of the pairs, in ascending id order
  std::vector<int> robots;      ///< those robot ids
  /// Per input pair: the joint selection's keyframes within the pair's L_seq (selected_left = alpha's,
  /// selected_right = beta's, ascending keyframe indices), with the joint solve's status, objective, bound,
  /// N_MM, share and counters (the pairs share one solve).
  std::vector<BalancedCoverResult> pairs;
  double seconds = 0.0;  ///< wall clock (steady) of the whole call
};

/// Stage B over several robot pairs at once (ours, not the paper's per-pair cascade): one N-robot exchange graph
/// whose vertices are each robot's keyframes that appear in any pair's L_seq (a keyframe shared by two pairs is
/// one vertex) and whose edges are every pair's loops, solved by SolveMultiRobotBalancedCover with a share of
/// ceil(N_MM / 2^H(p)) per robot (p uniform over the robots of the pairs unless params.participation has one
/// entry per such robot). A scan that serves two pairs is paid for once. Unit weights only (params.vertex_weights
/// must be empty). Errors: robots out of range or equal in a pair, a pair of robots given twice, bad params.
Result<JointCoverResult> SolveJointStageB(Span<const JointCoverPair> pairs, const BalancedCoverParams& params);

}  // namespace commerge
