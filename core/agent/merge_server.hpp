// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server as a transport-free agent (paper Fig. "main", (b)-(g)): a facade over its four modules,
// one entry per message kind and per step of a round.
//   keyframe database (keyframe_database.hpp): each robot's descriptors and poses, from batches and pose updates
//   scan inbox (scan_inbox.hpp): the scan chunks the robots answer with, bounded, de-duplicated, CRC-verified
//   exchange planner (exchange_planner.hpp): every pair's cascade, the place check, the plans and widening
//   pair registrar (pair_registrar.hpp): submaps, registration, the checks on a transform, one frame per robot
// Whether a pair is requested, widened and accepted is decided in one place: pair_decision.hpp.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

#include "core/agent/exchange_planner.hpp"
#include "core/agent/keyframe_database.hpp"
#include "core/agent/merge_server_params.hpp"
#include "core/agent/messages.hpp"
#include "core/agent/pair_decision.hpp"
#include "core/agent/pair_registrar.hpp"
#include "core/agent/scan_inbox.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"

namespace commerge {

class MergeServer {
 public:
  /// Robots 0..max_robots-1 (2..kMaxRobotId + 1), at most max_keyframes_per_robot keyframes each; the error names
  /// the parameter that is out of range (ValidateMergeServerParams).
  static Result<std::unique_ptr<MergeServer>> Create(int max_robots, std::size_t max_keyframes_per_robot,
                                                     const MergeServerParams& params);
  MergeServer(const MergeServer&) = delete;
  MergeServer& operator=(const MergeServer&) = delete;

  /// Message handlers. A malformed or foreign message is refused with a Status naming the field and counted in
  /// stats(); it never changes the state.
  Status OnKeyframeBatch(const KeyframeBatch& batch);
  Status OnPoseUpdate(const PoseUpdate& update);
  Status OnScanChunk(const ScanChunk& chunk);
  /// What the handlers above check, without counting or applying anything (KeyframeDatabase::CheckKeyframeBatch).
  /// ServerLink adopts a robot's newer session, which resets it, only for a message that passes.
  Status CheckKeyframeBatch(const KeyframeBatch& batch) const { return db_.CheckKeyframeBatch(batch); }
  Status CheckPoseUpdate(const PoseUpdate& update) const { return db_.CheckPoseUpdate(update); }

  /// Runs the cascade for every pair of robots that sent keyframes (ExchangePlanner::RunCascades).
  Status RunCascades();
  const std::vector<std::pair<int, int>>& incomparable_pairs() const noexcept { return planner_.incomparable_pairs(); }
  const ExchangeCascadeResult* cascade(int alpha, int beta) const { return planner_.cascade(alpha, beta); }
  const PairEvidence* evidence(int alpha, int beta) const { return planner_.evidence(alpha, beta); }
  /// ExchangePlanner::MeasurePlacementAgreement over this server's keyframes.
  Result<std::vector<PlacementAgreement>> MeasurePlacementAgreement(int alpha, int beta) const {
    return planner_.MeasurePlacementAgreement(db_, alpha, beta);
  }
  const StageCResult* stage_ac(int alpha, int beta) const { return planner_.stage_ac(alpha, beta); }

  /// The plan of one mode from the last RunCascades() (ExchangePlanner::Plan).
  Result<ExchangePlan> Plan(ExchangeMode mode) const { return planner_.Plan(mode, db_); }
  /// The next exchange for the pairs of `plan` whose registration was refused (`results`: MergePair's, matched by
  /// robot pair; ExchangePlanner::WidenPlan).
  Result<ExchangePlan> WidenPlan(const ExchangePlan& plan, Span<const PairMergeResult> results,
                                 std::int32_t first_request_id) const;
  /// The requests for registering `selections` (scans not held), ids from `first_request_id` upwards.
  ExchangePlan RequestsFor(Span<const PairSelection> selections, std::int32_t first_request_id) const {
    return planner_.RequestsFor(selections, first_request_id, db_, inbox_);
  }

  /// Drops every received and partial scan (between modes of a comparison run).
  void ClearScans();
  /// Forgets one robot: its keyframes, its received and partial scans, its pairs (a new session of that robot).
  void ResetRobot(int robot);

  bool PartialScan(int robot, std::uint32_t keyframe, std::uint16_t* num_chunks,
                   const std::vector<std::uint8_t>** have) const {
    return inbox_.PartialScan(robot, keyframe, num_chunks, have);
  }

  /// Builds the two submaps of `pair` from the received scans, registers beta's onto alpha's and asks DecideAccept.
  Result<PairMergeResult> MergePair(const PairSelection& pair, RegistrationStageObserver* observer = nullptr);
  /// Combines accepted pairwise results into one frame per robot (world = robot 0's map frame).
  /// The final refinement of an accepted pair (PairRegistrar::RefinePair): `spread` holds the pair's registered
  /// selection plus the spread keyframes (spread_alpha and spread_beta of them).
  Status RefinePair(const PairSelection& spread, std::size_t spread_alpha, std::size_t spread_beta,
                    Span<const std::pair<std::uint32_t, std::uint32_t>> places, PairMergeResult* result) {
    return registrar_.RefinePair(db_, inbox_, spread, spread_alpha, spread_beta, places, result, note_memory_);
  }
  Result<FrameSolution> SolveFrames(Span<const PairMergeResult> pairs) const {
    return registrar_.SolveFrames(max_robots(), pairs);
  }
  /// Submap of one robot from received scans (PairRegistrar::BuildSubmap).
  std::size_t BuildSubmap(int robot, Span<const std::uint32_t> keyframes, double voxel_size_m,
                          std::vector<PointXYZI>* points, std::vector<Eigen::Vector3d>* sensor_origins,
                          std::size_t* missing);

  int max_robots() const noexcept { return db_.max_robots(); }
  const MergeServerParams& params() const noexcept { return params_; }
  const KeyframeDatabase& keyframes() const noexcept { return db_; }
  const RobotKeyframeDb& robot(int r) const { return db_.robot(r); }
  const MergeServerStats& stats() const noexcept { return stats_; }
  /// Complete, verified scans held, and their bytes.
  std::size_t scans_received() const noexcept { return inbox_.scans_received(); }
  std::uint64_t scan_bytes_held() const noexcept { return inbox_.scan_bytes_held(); }
  bool has_scan(int robot, std::uint32_t keyframe) const { return inbox_.has_scan(robot, keyframe); }
  const std::vector<std::uint8_t>* scan_bytes(int robot, std::uint32_t keyframe) const {
    return inbox_.scan_bytes(robot, keyframe);
  }

  /// Memory of the server's budget modules (core/memory/budget.hpp), named and ordered as in its budget table:
  /// descriptor_db (KeyframeDatabase), affinity and solvers (ExchangePlanner), scan_reassembly (ScanInbox),
  /// submaps and registration (PairRegistrar); budget_bytes 0 (the caller's table has them). Not here: merged_map
  /// and inbox (the process's) and runtime. Every figure is capacity x element size of the containers that hold the
  /// module's data now; the transient workspaces inside the cascade live and die within the call.
  /// high_water_bytes: the largest used_bytes at the end of any message handler, RunCascades, BuildSubmap,
  /// MergePair or MemoryUse call, and just before ClearScans, ResetRobot or RunCascades drop data.
  std::vector<ModuleMemory> MemoryUse() const;

 private:
  MergeServer(const MergeServerParams& params, KeyframeDatabase db, ScanInbox inbox);
  static constexpr std::size_t kMemoryModules = 6;
  std::array<std::int64_t, kMemoryModules> MeasureMemory() const;
  void NoteMemory() const;

  MergeServerParams params_;
  KeyframeDatabase db_;
  ScanInbox inbox_;
  ExchangePlanner planner_;
  PairRegistrar registrar_;
  MergeServerStats stats_;
  std::function<void()> note_memory_;
  mutable ModuleHighWater<kMemoryModules> memory_high_water_;
};

}  // namespace commerge
