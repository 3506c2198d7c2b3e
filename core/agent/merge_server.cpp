// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/merge_server.hpp"

#include <string>
#include <utility>

namespace commerge {

Result<std::unique_ptr<MergeServer>> MergeServer::Create(int max_robots, std::size_t max_keyframes_per_robot,
                                                         const MergeServerParams& params) {
  if (Status st = ValidateMergeServerParams(params); !st.ok()) return st;
  auto db = KeyframeDatabase::Create(max_robots, max_keyframes_per_robot, params.record_kind);
  if (!db.ok()) return db.status();
  auto inbox = ScanInbox::Create(max_robots, {params.max_scan_points, params.max_scan_bytes, params.max_scans_held});
  if (!inbox.ok()) return inbox.status();
  MergeServerParams held = params;
  // The descriptors' distance follows from the records the server takes.
  held.cascade.metric.kind = params.record_kind == KeyframeRecordKind::kScanContext ? DescriptorMetric::Kind::kScanContext
                                                                                   : DescriptorMetric::Kind::kUnitL2;
  held.cascade.metric.scan_context_rings = kScanContextWireRings;
  held.cascade.metric.scan_context_sectors = kScanContextWireSectors;
  return std::unique_ptr<MergeServer>(new MergeServer(held, std::move(*db), std::move(*inbox)));
}

MergeServer::MergeServer(const MergeServerParams& params, KeyframeDatabase db, ScanInbox inbox)
    : params_(params),
      db_(std::move(db)),
      inbox_(std::move(inbox)),
      planner_(params),
      registrar_(params),
      note_memory_([this] { NoteMemory(); }) {}

Status MergeServer::OnKeyframeBatch(const KeyframeBatch& batch) {
  Status st = db_.OnKeyframeBatch(batch, &stats_);
  NoteMemory();
  return st;
}

Status MergeServer::OnPoseUpdate(const PoseUpdate& update) {
  Status st = db_.OnPoseUpdate(update, &stats_);
  NoteMemory();
  return st;
}

Status MergeServer::OnScanChunk(const ScanChunk& chunk) { return inbox_.OnScanChunk(chunk, &stats_, note_memory_); }

Status MergeServer::RunCascades() {
  NoteMemory();
  Status st = planner_.RunCascades(db_);
  NoteMemory();
  return st;
}

Result<ExchangePlan> MergeServer::WidenPlan(const ExchangePlan& plan, Span<const PairMergeResult> results,
                                            std::int32_t first_request_id) const {
  std::vector<PairOutcome> outcomes;
  outcomes.reserve(results.size());
  for (const PairMergeResult& r : results) outcomes.push_back({r.alpha, r.beta, r.attempted, r.merged()});
  return planner_.WidenPlan(plan, Span<const PairOutcome>(outcomes), first_request_id, db_, inbox_);
}

void MergeServer::ClearScans() {
  NoteMemory();
  inbox_.Clear();
}

void MergeServer::ResetRobot(int robot) {
  if (robot < 0 || robot >= max_robots()) return;
  NoteMemory();
  db_.ResetRobot(robot);
  inbox_.ResetRobot(robot);
  planner_.ForgetRobot(robot);
}

Result<PairMergeResult> MergeServer::MergePair(const PairSelection& pair, RegistrationStageObserver* observer) {
  if (pair.alpha < 0 || pair.beta < 0 || pair.alpha >= max_robots() || pair.beta >= max_robots() ||
      pair.alpha == pair.beta) {
    return InvalidArgument("pair (" + std::to_string(pair.alpha) + ", " + std::to_string(pair.beta) +
                           ") is not two different robots of 0.." + std::to_string(max_robots() - 1));
  }
  return registrar_.MergePair(db_, inbox_, pair, planner_.cascade(pair.alpha, pair.beta),
                              planner_.evidence(pair.alpha, pair.beta), observer, note_memory_);
}

std::size_t MergeServer::BuildSubmap(int robot, Span<const std::uint32_t> keyframes, double voxel_size_m,
                                     std::vector<PointXYZI>* points, std::vector<Eigen::Vector3d>* sensor_origins,
                                     std::size_t* missing) {
  return registrar_.BuildSubmap(db_, inbox_, robot, keyframes, voxel_size_m, points, sensor_origins, missing,
                                note_memory_);
}

namespace {
constexpr const char* kServerMemoryModules[] = {"descriptor_db",   "affinity", "solvers",
                                                "scan_reassembly", "submaps",  "registration"};
}  // namespace

std::array<std::int64_t, MergeServer::kMemoryModules> MergeServer::MeasureMemory() const {
  return {static_cast<std::int64_t>(db_.MemoryBytes()),        static_cast<std::int64_t>(planner_.AffinityBytes()),
          static_cast<std::int64_t>(planner_.SolverBytes()),   static_cast<std::int64_t>(inbox_.MemoryBytes()),
          static_cast<std::int64_t>(registrar_.SubmapBytes()), static_cast<std::int64_t>(registrar_.RegistrationBytes())};
}

void MergeServer::NoteMemory() const { memory_high_water_.Note(MeasureMemory()); }

std::vector<ModuleMemory> MergeServer::MemoryUse() const {
  return memory_high_water_.Report(kServerMemoryModules, MeasureMemory());
}

}  // namespace commerge
