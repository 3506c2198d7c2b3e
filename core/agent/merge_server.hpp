// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server as a transport-free agent (paper Fig. "main", (b)-(g)). It keeps each robot's keyframe
// database (descriptors and poses from keyframe batches and pose updates), runs the exchange cascade for every
// robot pair (affinity + stage A, stage B, stage C, policy), turns a plan into scan requests, reassembles the
// scan chunks the robots answer with (bounded, de-duplicated, CRC-verified), builds the two submaps of a pair
// from the received scans (paper eqs. M_alpha, M_beta), registers them coarse to fine, and combines the
// pairwise transforms into one frame per robot, rejecting pairs inconsistent with the rest.
//
// Exchange modes (the paper's ablation, Table "ablation2"): which scans a pair's plan asks for.
//   send-all : every stored scan of both robots (the baseline); each pair registers the complete stored maps
//   A        : both endpoints of every loop of L_seq (stage A's best cluster)
//   A+B      : stage B's balanced vertex cover of L_seq
//   A+C      : the endpoints of the maximum edge-weighted clique over all of L_seq (no stage B)
//   A+B+C    : the full cascade's exchange policy (the endpoints of L_K)
// Every mode but send-all is padded to ExchangePolicyParams::min_scans_per_robot per robot with stage A's
// keyframes, and every mode but send-all is widened (MergeServerParams::max_widen_steps): one rule, so the
// modes compare; the plan counts selected and padded scans apart.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/messages.hpp"
#include "core/cloud/point.hpp"
#include "core/cloud/voxel_grid.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/exchange_cascade.hpp"
#include "core/exchange/transform_agreement.hpp"
#include "core/merge/frame_solver.hpp"
#include "core/registration/submap_registration.hpp"

namespace commerge {

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

/// The server's stage A (ours; measured by profiling/bench_recall.sh, profiling/RESULTS.md "Merge recall"):
/// neighbour rank 1 (a cell is a candidate when it is the nearest keyframe of its row or column,
/// neighbour_rank.hpp) on the sequence-smoothed matrix (half window 4), tau_area 400 cells (20 x 20 keyframes:
/// about 20 m of shared path; chance chains in a matrix of noise stay below 200), scaled down for short missions
/// to (0.3 x the shorter robot's keyframes)^2 but not below 100 cells, tau_inter 0.5 as a loose cap.
/// The paper's stage A is SequentialMatchParams{} (--neighbour-rank 0 --sequence-half-window 0 --tau-area 10000
/// --tau-area-fraction 0 --tau-inter 0.1).
SequentialMatchParams ServerStageADefaults();
ExchangeCascadeParams ServerCascadeDefaults();
/// Tolerances of the place check across pairs (MergeServerParams::chain_check_support): a chain of two
/// placements carries the keyframe-position error of both, so 8 m plus 5 % of the distance between the places
/// and 20 deg of yaw (a look-alike place in the generated worlds was 35-94 m and 90 deg off).
PlaceConsensusParams ChainAgreementDefaults();

struct MergeServerParams {
  ExchangeCascadeParams cascade = ServerCascadeDefaults();
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
  /// max_submap_points). Useful only when the robots store such scenes finer too (RobotMapperParams::voxel).
  /// 4 000 would leave ten street scans of a spinning sensor at 1 m (8 000 points and more) and take a courtyard
  /// seen by a forward-looking sensor (1 000-2 500 at 1 m) finer; profiling/RESULTS.md "Scene-scaled voxels" has
  /// what that did.
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
  /// Widening (ours, not in the paper; WidenPlan): when registration refuses a pair, the server may ask again for
  /// up to twice the pair's scans per robot, taken from stage A's loops next to the selected keyframes, and register
  /// once more; at most this many times per pair and round (0 = the paper's single exchange). A refused pair costs
  /// the extra scans; a pair that merged costs nothing. A pair whose cluster is below tau_area (the cascade's
  /// verification) or at an ambiguous place (the cascade's `ambiguous`) is never widened: its one registration
  /// decides, unless widen_ambiguous_support allows it.
  int max_widen_steps = 2;
  /// The A+C ablation (Plan(kStageAC)): stage C over every loop of L_seq, run with each pair's cascade. Off
  /// when no one plans mode A+C (`commerge server` in any other mode, `run` without A+C in --modes): it costs a
  /// clique solve per pair and round (a tenth of a 5-robot round at 3 000 keyframes, profiling/bench_round).
  bool stage_ac_ablation = true;
  /// Ours; 0 = off (an ambiguous cluster is never widened). [keyframes] An ambiguous cluster whose place
  /// consensus support (ExchangeCascadeResult::consensus_support_chosen) reaches this is widened like any other:
  /// corridors and rooms that repeat make true clusters ambiguous too, and a cluster that a hundred keyframes of
  /// other clusters place the same way is not a look-alike. Look-alike clusters in the recall benchmark had a
  /// support of 22-49 (those below 40 end at stage A, ExchangeCascadeParams::min_ambiguous_support); 100 is twice
  /// the top. Such a pair is merged only where its consensus places it (RegistrationAtConfirmedPlace): widened
  /// twice, a true cluster once passed registration's gates with the corridor turned 180 deg
  /// (profiling/RESULTS.md "Widening confirmed ambiguous places"; with the check, "Confirmed ambiguous places
  /// checked against their placement").
  double widen_ambiguous_support = 100.0;
  /// Place check across pairs (ours; 0 = off, the paper). [keyframes] A pair whose stage A cluster has a place
  /// consensus support below this is weakly supported. Through every third robot c whose pairs with both robots
  /// are supported at least this much, the two placements compose into where c says robot beta's map lies in
  /// robot alpha's; when at least one such chain exists and none agrees with the pair's own placement
  /// (chain_agreement tolerances), the pair is not passed on ("place check" in its reason) and no scans are
  /// asked for. A look-alike place is confirmed by nothing; a true one by every true chain.
  double chain_check_support = 40.0;
  PlaceConsensusParams chain_agreement = ChainAgreementDefaults();
  /// Descriptor agreement under the registered transform (ours, not in the paper; transform_agreement.hpp): a
  /// registration that places at least min_colocated_keyframes of robot beta's keyframes outside stage A's
  /// cluster on top of robot alpha's (colocation: within near_m, headings within the sensor's field of view),
  /// where the median chance that the best of them ranks as well by descriptor among all of alpha's keyframes
  /// is max_colocated_chance or more, is refused (RegistrationVerdict::kDescriptorsDisagree). 0 = off. In the
  /// recall benchmark right merges measured 0.00-0.17 (the highest indoors, where corridors repeat and robots
  /// drift), merges at look-alike places 0.23-0.60 (0.5 = strangers): profiling/RESULTS.md "Descriptor agreement
  /// under the registered transform".
  double max_colocated_chance = 0.2;
  std::size_t min_colocated_keyframes = 20;
  TransformAgreementParams colocation;
};

Status ValidateMergeServerParams(const MergeServerParams& params);

/// The cascade flagged the pair's cluster ambiguous and the place consensus confirms it with at least
/// widen_ambiguous_support keyframes (> 0): the server may widen it like any other pair.
bool AmbiguousClusterConfirmed(const ExchangeCascadeResult& cascade, const MergeServerParams& params);

/// The place check of a confirmed ambiguous pair (ours): when AmbiguousClusterConfirmed holds and the chosen
/// cluster has a valid placement, a registered T_alpha_beta (p_alpha = T p_beta) is accepted only within
/// cascade.consensus.agree_m of the placement at its place and agree_deg of its yaw (GapToPlacement), the
/// tolerances by which two clusters agree; otherwise MergePair refuses it (RegistrationVerdict::kOffConfirmedPlace).
/// True for every other pair. `gap`, when given, gets the gap if one was measured (else zeros).
bool RegistrationAtConfirmedPlace(const ExchangeCascadeResult& cascade, const MergeServerParams& params,
                                  const Eigen::Isometry3d& T_alpha_beta, PlacementGap* gap = nullptr);

/// The server's copy of one robot's keyframes.
struct RobotKeyframeDb {
  std::size_t dim = kKeyframeDescriptorDim;  ///< floats per descriptor (KeyframeRecordDimOf the server's kind)
  std::vector<float> descriptors;          ///< keyframe x dim (zeros where invalid)
  std::vector<std::uint8_t> valid;         ///< descriptor received
  std::vector<std::uint8_t> pose_known;    ///< pose received (record or pose update)
  std::vector<std::uint8_t> no_descriptor; ///< the robot said the keyframe has no valid descriptor (pose only)
  std::vector<Eigen::Isometry3d> T_map_sensor;
  std::vector<std::uint32_t> stored_points;
  /// Descriptor parameter id of the robot's batches (that of the first batch that delivered a record; 0 = none
  /// yet or unknown). Batches of another non-zero id are refused, and robots of different ids are not compared.
  std::uint32_t descriptor_id = 0;
  std::size_t size() const noexcept { return valid.size(); }
  /// Everything the robot will ever send of keyframe k has arrived: its record, or its pose when it has no
  /// valid descriptor.
  bool delivered(std::size_t k) const { return k < size() && (valid[k] || (no_descriptor[k] && pose_known[k])); }
};

/// Scans one pair asks for in one mode.
struct PairSelection {
  int alpha = 0, beta = 0;
  std::vector<std::uint32_t> alpha_keyframes, beta_keyframes;  ///< ascending
  std::size_t loops = 0;           ///< loops behind the selection (|L_seq|, |L_K|, ...)
  std::string no_selection_reason; ///< why it is empty (the cascade's reason)
};

struct ExchangePlan {
  ExchangeMode mode = ExchangeMode::kStageABC;
  std::vector<PairSelection> pairs;
  /// One request per robot with something to send (the union over its pairs), request ids from 1 upwards.
  std::vector<ScanRequest> requests;
  std::uint64_t predicted_scan_bytes = 0;  ///< 12 + 6 n per requested scan, n as the robots reported
  /// Scans of `requests` by origin (Plan; 0 in a WidenPlan): the mode's own selection (send-all: every stored
  /// scan; A: L_seq's endpoints; A+B: the cover; A+C: the clique's endpoints; A+B+C: L_K's endpoints), and the
  /// keyframes padding added on top (ExchangePolicyParams::min_scans_per_robot, the same rule in every mode).
  std::size_t selected_scans = 0;
  std::size_t padded_scans = 0;
};

/// What registering one pair produced.
struct PairMergeResult {
  int alpha = 0, beta = 0;
  bool attempted = false;           ///< false: nothing selected or no scan received (see reason)
  std::string reason;               ///< why it was not attempted, or the failed verdict
  std::size_t alpha_scans = 0, beta_scans = 0;        ///< received scans used
  std::size_t alpha_missing = 0, beta_missing = 0;    ///< selected but not received
  std::size_t alpha_submap_points = 0, beta_submap_points = 0;
  double voxel_size_m = 0.0;        ///< of the submaps
  RegistrationResult registration;  ///< T_target_source = T_alpha_beta (p_alpha = T p_beta)
  /// > 0: this round could not register the pair for missing scans (reason says why); the result is the one
  /// that round verified for the same two robot sessions (ServerLink keeps it; see KeepVerifiedPairs).
  int kept_from_round = 0;
  /// Descriptor agreement of a registered transform (max_colocated_chance): beta keyframes outside stage A's
  /// cluster it places on top of alpha's, and their median chance (-1 when not measured).
  std::size_t colocated_keyframes = 0;
  double colocated_chance = -1.0;
};

/// Replaces the selection of every pair in `pairs` that `adopted` has (matched by robot pair) with that one.
void AdoptSelections(Span<const PairSelection> adopted, std::vector<PairSelection>* pairs);

struct MergeServerStats {
  std::uint64_t batches = 0, records = 0, pose_updates = 0, chunks = 0, scans_completed = 0;
  /// Of `records`, those for keyframes whose record the server held already (re-announcements).
  std::uint64_t records_repeated = 0;
  std::uint64_t rejected_batches = 0, rejected_records = 0, rejected_pose_updates = 0;
  std::uint64_t rejected_chunks = 0, duplicate_chunks = 0, corrupt_scans = 0;
  std::uint64_t chunks_over_budget = 0;
  std::string last_rejection;  ///< the most recent rejection, in words
};

class MergeServer {
 public:
  /// Robots 0..max_robots-1 (2..kMaxRobotId + 1), at most max_keyframes_per_robot keyframes each.
  MergeServer(int max_robots, std::size_t max_keyframes_per_robot, const MergeServerParams& params);

  /// Message handlers. A malformed or foreign message is refused with a Status naming the field and counted in
  /// stats(); it never changes the state.
  Status OnKeyframeBatch(const KeyframeBatch& batch);
  Status OnPoseUpdate(const PoseUpdate& update);
  Status OnScanChunk(const ScanChunk& chunk);
  /// What the handlers above check, without counting or applying anything: OK when OnKeyframeBatch would apply
  /// at least one record, and when OnPoseUpdate would accept the update, for a robot reset by ResetRobot: the
  /// batch's descriptor id is not held against the robot's earlier batches. (ServerLink adopts a robot's newer
  /// session, which resets it, only for a message that passes; a robot restarted with another --lidar is one.)
  Status CheckKeyframeBatch(const KeyframeBatch& batch) const;
  Status CheckPoseUpdate(const PoseUpdate& update) const;

  /// Runs the cascade for every pair of robots that sent keyframes (alpha < beta). Results stay until the next
  /// call; errors: bad parameters, malformed descriptor sets.
  Status RunCascades();
  /// Pairs (alpha < beta) the last RunCascades() left out because their robots' descriptor ids differ (a robot
  /// started with another sensor preset or SOLiD setting): their descriptors are not comparable.
  const std::vector<std::pair<int, int>>& incomparable_pairs() const noexcept { return incomparable_pairs_; }
  /// Cascade of pair (alpha, beta) from the last RunCascades(); nullptr when it did not run.
  const ExchangeCascadeResult* cascade(int alpha, int beta) const;
  /// Stage C over all of L_seq (the A+C ablation) of the pair; nullptr when it did not run.
  const StageCResult* stage_ac(int alpha, int beta) const;

  /// The plan of one mode from the last RunCascades().
  Result<ExchangePlan> Plan(ExchangeMode mode) const;

  /// The next exchange for the pairs of `plan` whose registration was refused (`results`: MergePair's results,
  /// matched by robot pair; pairs not attempted, or merged, are left out). Each robot's keyframes of such a pair
  /// grow to twice their number with endpoints of the pair's stage A loops (L_seq), nearest in index to the
  /// keyframes already selected (PadKeyframesFromPool). Left out as well: a pair where neither robot can grow
  /// (every L_seq endpoint is selected already: send-all, A), and a pair whose robots the merged pairs of
  /// `results` already join through other robots (widening is for connecting robots; its scans cost bytes).
  /// The returned plan's pairs are the widened selections (register them with MergePair; AdoptSelections copies
  /// them into the caller's list); its requests name, per robot, only the keyframes whose scans the server
  /// does not hold, with request ids from `first_request_id` upwards. An empty plan: nothing to widen.
  Result<ExchangePlan> WidenPlan(const ExchangePlan& plan, Span<const PairMergeResult> results,
                                 std::int32_t first_request_id) const;

  /// The requests for registering `selections`: one per robot with the union of its keyframes in them whose
  /// scans the server does not hold, request ids from `first_request_id` upwards, and their predicted bytes
  /// (ExchangePlan::requests and predicted_scan_bytes; its pairs are empty).
  ExchangePlan RequestsFor(Span<const PairSelection> selections, std::int32_t first_request_id) const;

  /// Drops every received and partial scan (between modes of a comparison run).
  void ClearScans();
  /// Forgets one robot: its keyframes, and its received and partial scans (a new session of that robot).
  void ResetRobot(int robot);

  /// Chunks of keyframe k's scan received so far: false when no chunk arrived (or the scan is complete; see
  /// has_scan); otherwise `*num_chunks` and `*have` (one flag per chunk).
  bool PartialScan(int robot, std::uint32_t keyframe, std::uint16_t* num_chunks,
                   const std::vector<std::uint8_t>** have) const;

  /// Builds the two submaps of `pair` from the received scans and registers beta's onto alpha's.
  Result<PairMergeResult> MergePair(const PairSelection& pair, RegistrationStageObserver* observer = nullptr);

  /// Combines successful pairwise results into one frame per robot (world = robot 0's map frame).
  Result<FrameSolution> SolveFrames(Span<const PairMergeResult> pairs) const;

  /// Submap of one robot (map frame points) from received scans of `keyframes`, voxelised at voxel_size_m.
  /// Returns the number of scans used; missing ones are counted in *missing.
  std::size_t BuildSubmap(int robot, Span<const std::uint32_t> keyframes, double voxel_size_m,
                          std::vector<PointXYZI>* points, std::vector<Eigen::Vector3d>* sensor_origins,
                          std::size_t* missing);

  int max_robots() const noexcept { return static_cast<int>(robots_.size()); }
  const MergeServerParams& params() const noexcept { return params_; }
  const RobotKeyframeDb& robot(int r) const { return robots_[static_cast<std::size_t>(r)]; }
  const MergeServerStats& stats() const noexcept { return stats_; }
  /// Complete, verified scans held, and their bytes.
  std::size_t scans_received() const noexcept { return scans_.size(); }
  std::uint64_t scan_bytes_held() const noexcept { return held_bytes_; }
  bool has_scan(int robot, std::uint32_t keyframe) const;
  /// The complete, verified encoded scan of keyframe k (nullptr when not held).
  const std::vector<std::uint8_t>* scan_bytes(int robot, std::uint32_t keyframe) const;

  /// Memory of the server's budget modules (core/memory/budget.hpp), named and ordered as in its budget table:
  /// descriptor_db, affinity, solvers, scan_reassembly, submaps, registration (budget_bytes 0: the caller's table
  /// has them). Not here: merged_map and inbox (the process builds the map file and owns the message queue) and
  /// runtime (the process's peak RSS minus the pools). Every figure is capacity x element size of the containers
  /// that hold the module's data now (they grow on demand and keep their capacity):
  ///   descriptor_db    per robot: descriptors, flags, poses, point counts (RobotKeyframeDb)
  ///   affinity         the cascade's inputs built here (keyframe positions) and each pair's L_seq (stage A)
  ///   solvers          each pair's stage B cover, stage C candidate and selected loops, clique, policy, and the
  ///                    A+C run; the transient workspaces inside RunExchangeCascade (affinity tiles, labelling,
  ///                    LP and branch-and-bound buffers) live and die within the call and are not counted
  ///   scan_reassembly  complete and partial scans (bytes, chunk flags) plus one map entry (value_type) each
  ///   submaps          decoded scan, union and both submaps, sensor origins, the voxel grid's workspace
  ///   registration     SubmapRegistration::workspace_bytes (features, k-d trees, matcher, GICP, global search)
  /// high_water_bytes: the largest used_bytes at the end of any message handler, RunCascades, BuildSubmap,
  /// MergePair or MemoryUse call, and just before ClearScans, ResetRobot or RunCascades drop data (it stays
  /// after the data is gone).
  std::vector<ModuleMemory> MemoryUse() const;

 private:
  /// The keyframes of `robot` that have a stored scan (or a known pose): what send-all asks for.
  std::vector<std::uint32_t> StoredKeyframes(int robot) const;
  static constexpr std::size_t kMemoryModules = 6;
  std::array<std::int64_t, kMemoryModules> MeasureMemory() const;
  void NoteMemory() const;

  struct Partial {
    std::uint32_t total_bytes = 0;
    std::uint16_t num_chunks = 0;
    std::uint16_t received = 0;
    std::vector<std::uint8_t> have;
    std::vector<std::uint8_t> bytes;
  };
  struct PairState {
    int alpha = 0, beta = 0;
    ExchangeCascadeResult cascade;
    StageCResult stage_ac;
    bool stage_ac_ran = false;
    bool place_check_refused = false;  ///< the place check across pairs refused it (cascade's reason says why)
  };
  static std::uint64_t Key(int robot, std::uint32_t keyframe) {
    return (static_cast<std::uint64_t>(robot) << 32) | keyframe;
  }
  Status Reject(std::uint64_t* counter, Status status);
  // InvalidArgument when the batch's descriptor id conflicts with the one its robot's earlier batches set.
  Status DescriptorIdError(const KeyframeBatch& batch) const;
  // InvalidArgument when the batch's records are not of the kind this server takes (params.record_kind).
  Status RecordKindError(const KeyframeBatch& batch) const;
  Status CapacityError(int robot, std::uint32_t keyframe) const;
  Status EnsureKeyframe(int robot, std::uint32_t keyframe);
  const PairState* FindPair(int alpha, int beta) const;
  /// Fills result's colocated_keyframes / colocated_chance for its registered transform (max_colocated_chance).
  void MeasureColocation(const PairState& state, PairMergeResult* result) const;
  /// The place check across pairs (chain_check_support) over pairs_, after every cascade of the round.
  void ApplyPlaceCheck();
  /// One request per robot with the keyframes of `wanted[r]` (sorted and de-duplicated here; without the scans
  /// held when skip_held), ids from `request_id` upwards; adds their predicted bytes to the plan.
  void AddRequests(std::vector<std::vector<std::uint32_t>>* wanted, std::int32_t request_id, bool skip_held,
                   ExchangePlan* plan) const;

  MergeServerParams params_;
  Status params_status_;
  std::size_t max_keyframes_;
  std::vector<RobotKeyframeDb> robots_;
  std::vector<PairState> pairs_;
  std::vector<std::pair<int, int>> incomparable_pairs_;
  std::map<std::uint64_t, Partial> partial_;
  std::map<std::uint64_t, std::vector<std::uint8_t>> scans_;
  std::uint64_t held_bytes_ = 0;
  MergeServerStats stats_;
  SubmapRegistration registration_;
  VoxelGrid voxel_grid_;
  std::vector<PointXYZI> scan_points_, union_points_, alpha_points_, beta_points_;
  std::vector<float> record_descriptor_;  ///< one decoded record's descriptor
  std::vector<Eigen::Vector3d> alpha_origins_, beta_origins_;
  std::vector<std::vector<Eigen::Vector3d>> positions_;  ///< per robot, the cascade's keyframe positions
  std::uint64_t partial_flag_bytes_ = 0;                 ///< chunk flags of the partial scans
  mutable ModuleHighWater<kMemoryModules> memory_high_water_;
};

}  // namespace commerge
