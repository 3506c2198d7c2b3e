// SPDX-License-Identifier: BSD-3-Clause
// commerge: the merge server's parameters, their defaults and their check (MergeServer and its modules:
// keyframe_database, scan_inbox, exchange_planner, pair_registrar). Why each default: core/agent/decisions/.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "core/agent/pair_decision.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/exchange/exchange_cascade.hpp"
#include "core/exchange/transform_agreement.hpp"
#include "core/merge/frame_solver.hpp"
#include "core/registration/submap_registration.hpp"

namespace commerge {

/// Exchange modes (the paper's ablation, Table "ablation2"): which scans a pair's plan asks for.
///   send-all : every stored scan of both robots (the baseline); each pair registers the complete stored maps
///   A        : both endpoints of every loop of L_seq (stage A's best cluster)
///   A+B      : stage B's balanced vertex cover of L_seq
///   A+C      : the endpoints of the maximum edge-weighted clique over all of L_seq (no stage B)
///   A+B+C    : the full cascade's exchange policy (the endpoints of L_K)
/// Every mode but send-all is padded to ExchangePolicyParams::min_scans_per_robot per robot with stage A's
/// keyframes, and widened (MergeServerParams::max_widen_steps): one rule, so the modes compare.
enum class ExchangeMode : std::uint8_t { kSendAll, kStageA, kStageAB, kStageAC, kStageABC };
inline constexpr int kNumExchangeModes = 5;
/// "send-all", "A", "A+B", "A+C", "A+B+C".
const char* ExchangeModeName(ExchangeMode mode) noexcept;
/// Parses the names above (also "all", "a", "ab", "ac", "abc"); the error lists them.
Result<ExchangeMode> ExchangeModeFromName(const std::string& name);

/// How stage B covers the loops of several robot pairs (MergeServerParams::cover).
enum class StageBCover : std::uint8_t {
  kPairwise,  ///< the paper: one balanced cover per pair (share ceil(N_MM / 2) per robot); a robot sends the
              ///< union of its pairs' selections
  kJoint,     ///< ours: one balanced cover of every pair's loops over all robots (SolveJointStageB; share
              ///< ceil(N_MM / 2^H(p)), p uniform); a scan that serves two pairs is paid for once
};
/// "pairwise", "joint".
const char* StageBCoverName(StageBCover cover) noexcept;
/// Parses the names above; the error lists them.
Result<StageBCover> StageBCoverFromName(const std::string& name);

/// The server's stage A (ours): neighbour rank 1 (neighbour_rank.hpp) on the sequence-smoothed matrix (half window
/// 4), tau_area 400 cells, scaled down for short missions to (0.3 x the shorter robot's keyframes)^2 but not below
/// 100 cells, tau_inter 0.5 as a loose cap. The paper's stage A is SequentialMatchParams{}
/// (core/agent/decisions/001-server-stage-a-defaults.md).
SequentialMatchParams ServerStageADefaults();
/// ServerStageADefaults, verification from half of tau_area, ambiguity above 75 % of a cluster's keyframes, the
/// place consensus over at most kServerConsensusMaxCells cells.
ExchangeCascadeParams ServerCascadeDefaults();
/// Tolerances of the place check across pairs: 8 m plus 5 % of the distance between the places and 20 deg of yaw
/// (a chain of two placements carries the keyframe-position error of both;
/// core/agent/decisions/006-place-check-across-pairs.md).
PlaceConsensusParams ChainAgreementDefaults();

/// The final refinement of an accepted pair (ours; core/agent/pair_refinement.hpp).
struct RefinementParams {
  /// Spread scans asked for per robot and accepted pair, beside the anchor (0 = off: the pair keeps its
  /// registration, the paper; MergeProfileParams sets 0 for a sensor narrower than 360 deg;
  /// decisions/031-final-refinement-on-spread-scans.md).
  std::size_t scans_per_robot = 2;
  /// A keyframe of beta placed by the transform within this of a keyframe of alpha is on the shared path [m].
  double shared_path_m = 5.0;
  /// Spread scans are at least this far from each other and from the anchor (the held scan nearest the middle of
  /// those the pair was registered with) [m].
  double min_spacing_m = 10.0;
  /// The refined transform is taken when it moved the accepted one at most this much (beta's map origin moved,
  /// and the rotation between the two) [m, deg].
  double max_correction_m = 1.0;
  double max_correction_deg = 2.0;
};

/// InvalidArgument naming the field: scans_per_robot above 64, a length or angle not finite or not > 0.
Status ValidateRefinementParams(const RefinementParams& params);

struct MergeServerParams {
  ExchangeCascadeParams cascade = ServerCascadeDefaults();
  /// The thresholds of the three decisions about a pair (pair_decision.hpp).
  PairDecisionParams decision;
  /// The keyframe records this server takes (--descriptor: SOLiD and the ring descriptor send kUnit40, Scan
  /// Context kScanContext); a batch of another kind is refused and counted. Stage A, the place ambiguity and the
  /// descriptor agreement compare descriptors by the kind's distance (unit L2, or the Scan Context distance).
  KeyframeRecordKind record_kind = KeyframeRecordKind::kUnit40;
  /// Stage B per pair or one joint cover over every pair that stage A passed on (with one such pair both are the
  /// pair's own cover).
  StageBCover cover = StageBCover::kPairwise;
  /// Voxel size of the submaps [m] (the robots' scans already are 1 m voxels; the union is voxelised again).
  double submap_voxel_size_m = 1.0;
  /// When a submap has more points, its voxel size grows by 25 % steps (at most 8) until it fits.
  std::size_t max_submap_points = 60000;
  /// Small scenes (ours; 0 = the paper's one voxel size, the default): when the smaller submap of a pair keeps
  /// fewer points than this at submap_voxel_size_m, both are voxelised finer by the ladder of AdaptiveVoxelParams
  /// (steps of 1/sqrt(2), down to min_submap_voxel_size_m, while the smaller gains at least 10 % and both fit
  /// max_submap_points). Useful only when the robots store such scenes finer too (RobotMapperParams::voxel;
  /// core/agent/decisions/012-scene-scaled-voxels.md).
  std::size_t min_submap_points = 0;
  double min_submap_voxel_size_m = 0.25;
  /// Registration parameters are MakeSubmapRegistrationParams(voxel size used) with these gates.
  RegistrationGates gates;
  int registration_hypotheses = 2;
  FrameSolverParams frames;
  /// Points of the largest scan a robot may send (its stored scans: MemoryConfig::max_points_per_stored_scan);
  /// a larger scan is refused at its first chunk. Bounds the submaps' workspace (budget module "submaps").
  std::size_t max_scan_points = 8192;
  /// Bytes of scans (complete and partial) the server holds at once; chunks beyond are refused and counted.
  std::uint64_t max_scan_bytes = 512ull << 20;
  /// Scans (complete and partial) held at once: bounds the bookkeeping whatever the scans' sizes.
  std::size_t max_scans_held = 200000;
  /// Widening (ours, not in the paper; ExchangePlanner::WidenPlan): when registration refuses a pair that
  /// DecideWiden allows, the server asks again for up to twice the pair's scans per robot, taken from stage A's
  /// loops next to the selected keyframes, and registers once more; at most this many times per pair and round
  /// (0 = the paper's single exchange; core/agent/decisions/007-widening.md).
  int max_widen_steps = 2;
  /// Once a pair is accepted, a few scans spread along the path its robots share refine its transform.
  RefinementParams refine;
  /// The A+C ablation (Plan(kStageAC)): stage C over every loop of L_seq, run with each pair's cascade. Off
  /// when no one plans mode A+C: it costs a clique solve per pair and round.
  bool stage_ac_ablation = true;
  /// The place check across pairs: which chains through a third robot agree with a pair's placement (the
  /// support below which a pair is checked is decision.chain_check_support).
  PlaceConsensusParams chain_agreement = ChainAgreementDefaults();
  /// Colocation of keyframes under a registered transform (transform_agreement.hpp), for the descriptor check
  /// (decision.max_colocated_chance).
  TransformAgreementParams colocation;
};

/// InvalidArgument naming the field.
Status ValidateMergeServerParams(const MergeServerParams& params);

/// Named sets of the server's parameters (`--profile` of `commerge run` and `commerge server`; a flag given on the
/// command line wins over its profile).
enum class MergeProfile : std::uint8_t {
  kCommerge,  ///< MergeServerParams{}: our stage A, checks and widening
  kPaper,     ///< the paper's cascade: its stage A (B_ij = [A_ij <= tau_inter], tau_area 10 000 cells, tau_inter of
              ///< the sensor's scan pattern), exactly the scans of L_K, one registration, none of our checks
};
/// "commerge", "paper".
const char* MergeProfileName(MergeProfile profile) noexcept;
/// Parses the names above; the error lists them.
Result<MergeProfile> MergeProfileFromName(const std::string& name);
/// The parameters of `profile` for a sensor of `traits` (the paper's tau_inter depends on its scan pattern; ours
/// refines accepted pairs on spread scans only for a 360 deg sensor: decisions/031).
MergeServerParams MergeProfileParams(MergeProfile profile, const LidarScanTraits& traits);

/// Counters of every message the server took or refused.
struct MergeServerStats {
  std::uint64_t batches = 0, records = 0, pose_updates = 0, chunks = 0, scans_completed = 0;
  /// Of `records`, those for keyframes whose record the server held already (re-announcements).
  std::uint64_t records_repeated = 0;
  std::uint64_t rejected_batches = 0, rejected_records = 0, rejected_pose_updates = 0;
  std::uint64_t rejected_chunks = 0, duplicate_chunks = 0, corrupt_scans = 0;
  std::uint64_t chunks_over_budget = 0;
  std::string last_rejection;  ///< the most recent rejection, in words
};

}  // namespace commerge
