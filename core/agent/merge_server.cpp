// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/merge_server.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <string>
#include <utility>

#include "core/cloud/scan_codec.hpp"
#include "core/common/number_text.hpp"
#include "core/geometry/se3.hpp"

namespace commerge {

SequentialMatchParams ServerStageADefaults() {
  SequentialMatchParams p;
  p.neighbour_rank = 1;
  p.sequence_half_window = 4;
  p.tau_area = 400;
  p.tau_area_fraction = 0.3;
  p.min_tau_area = 100;
  p.tau_inter = 0.5;
  return p;
}

ExchangeCascadeParams ServerCascadeDefaults() {
  ExchangeCascadeParams p;
  p.stage_a = ServerStageADefaults();
  p.verification_area_fraction = 0.5;
  p.max_ambiguous_fraction = 0.75;
  p.consensus_max_cells = kServerConsensusMaxCells;
  p.min_ambiguous_support = 40.0;
  return p;
}

PlaceConsensusParams ChainAgreementDefaults() {
  PlaceConsensusParams p;
  p.agree_m = 8.0;
  p.agree_per_m = 0.05;
  p.agree_deg = 20.0;
  return p;
}

namespace {

std::string RobotText(int robot) { return "robot " + std::to_string(robot); }

// Unique ascending keyframes of one side of a loop list.
std::vector<std::uint32_t> Endpoints(Span<const SequentialLoopCell> loops, bool alpha_side) {
  std::vector<std::uint32_t> out;
  out.reserve(loops.size());
  for (const SequentialLoopCell& l : loops) {
    out.push_back(static_cast<std::uint32_t>(alpha_side ? l.alpha_index : l.beta_index));
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

std::vector<std::uint32_t> ToKeyframes(const std::vector<int>& v) {
  std::vector<std::uint32_t> out(v.begin(), v.end());
  std::sort(out.begin(), out.end());
  return out;
}

bool IsFinitePose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

}  // namespace

const char* ExchangeModeName(ExchangeMode mode) noexcept {
  switch (mode) {
    case ExchangeMode::kSendAll: return "send-all";
    case ExchangeMode::kStageA: return "A";
    case ExchangeMode::kStageAB: return "A+B";
    case ExchangeMode::kStageAC: return "A+C";
    case ExchangeMode::kStageABC: return "A+B+C";
  }
  return "?";
}

Result<ExchangeMode> ExchangeModeFromName(const std::string& name) {
  std::string n;
  for (char c : name) n.push_back(static_cast<char>(std::tolower(static_cast<unsigned char>(c))));
  if (n == "send-all" || n == "all") return ExchangeMode::kSendAll;
  if (n == "a") return ExchangeMode::kStageA;
  if (n == "a+b" || n == "ab") return ExchangeMode::kStageAB;
  if (n == "a+c" || n == "ac") return ExchangeMode::kStageAC;
  if (n == "a+b+c" || n == "abc") return ExchangeMode::kStageABC;
  return InvalidArgument("unknown exchange mode '" + name + "' (send-all, A, A+B, A+C, A+B+C)");
}

const char* StageBCoverName(StageBCover cover) noexcept {
  switch (cover) {
    case StageBCover::kPairwise: return "pairwise";
    case StageBCover::kJoint: return "joint";
  }
  return "?";
}

Result<StageBCover> StageBCoverFromName(const std::string& name) {
  if (name == "pairwise") return StageBCover::kPairwise;
  if (name == "joint") return StageBCover::kJoint;
  return InvalidArgument("unknown stage B cover '" + name + "' (pairwise, joint)");
}

bool AmbiguousClusterConfirmed(const ExchangeCascadeResult& cascade, const MergeServerParams& params) {
  return cascade.ambiguous && params.widen_ambiguous_support > 0.0 && cascade.consensus_measured &&
         cascade.consensus_support_chosen >= params.widen_ambiguous_support;
}

bool RegistrationAtConfirmedPlace(const ExchangeCascadeResult& cascade, const MergeServerParams& params,
                                  const Eigen::Isometry3d& T_alpha_beta, PlacementGap* gap) {
  if (gap) *gap = PlacementGap{};
  if (!AmbiguousClusterConfirmed(cascade, params) || !cascade.consensus_placement.valid) return true;
  const PlacementGap measured = GapToPlacement(cascade.consensus_placement, T_alpha_beta);
  if (gap) *gap = measured;
  return measured.distance_m <= params.cascade.consensus.agree_m && measured.yaw_deg <= params.cascade.consensus.agree_deg;
}

Status ValidateMergeServerParams(const MergeServerParams& params) {
  if (!(params.submap_voxel_size_m >= 5e-3) || !std::isfinite(params.submap_voxel_size_m)) {
    return InvalidArgument("submap_voxel_size_m = " + std::to_string(params.submap_voxel_size_m) +
                           " must be finite and >= 0.005");
  }
  if (!(std::isfinite(params.min_submap_voxel_size_m) && params.min_submap_voxel_size_m >= 5e-3 &&
        params.min_submap_voxel_size_m <= params.submap_voxel_size_m)) {
    return InvalidArgument("min_submap_voxel_size_m = " + std::to_string(params.min_submap_voxel_size_m) +
                           " must be in [0.005, submap_voxel_size_m = " + std::to_string(params.submap_voxel_size_m) + "]");
  }
  if (!(std::isfinite(params.chain_check_support) && params.chain_check_support >= 0.0)) {
    return InvalidArgument("chain_check_support = " + std::to_string(params.chain_check_support) +
                           " must be finite and >= 0");
  }
  if (!(std::isfinite(params.widen_ambiguous_support) && params.widen_ambiguous_support >= 0.0)) {
    return InvalidArgument("widen_ambiguous_support = " + std::to_string(params.widen_ambiguous_support) +
                           " must be finite and >= 0");
  }
  if (Status s = ValidatePlaceConsensusParams(params.chain_agreement); !s.ok()) {
    return Status(s.code(), "chain_agreement: " + s.message());
  }
  if (!(params.max_colocated_chance >= 0.0) || params.max_colocated_chance > 1.0) {
    return InvalidArgument("max_colocated_chance = " + std::to_string(params.max_colocated_chance) +
                           " must be in [0, 1] (0 = off)");
  }
  if (Status s = ValidateTransformAgreementParams(params.colocation); !s.ok()) {
    return Status(s.code(), "colocation: " + s.message());
  }
  if (params.max_submap_points < 100) {
    return InvalidArgument("max_submap_points = " + std::to_string(params.max_submap_points) + " must be >= 100");
  }
  if (params.registration_hypotheses < 1 || params.registration_hypotheses > 8) {
    return InvalidArgument("registration_hypotheses = " + std::to_string(params.registration_hypotheses) +
                           " is outside 1..8");
  }
  if (params.max_scans_held < 1) return InvalidArgument("max_scans_held must be >= 1");
  if (params.max_scan_points < 1 || params.max_scan_points > kMaxEncodedScanPoints) {
    return InvalidArgument("max_scan_points = " + std::to_string(params.max_scan_points) + " is outside 1.." +
                           std::to_string(kMaxEncodedScanPoints));
  }
  if (params.max_widen_steps < 0 || params.max_widen_steps > 8) {
    return InvalidArgument("max_widen_steps = " + std::to_string(params.max_widen_steps) + " is outside 0..8");
  }
  if (params.max_scan_bytes < (1u << 16)) {
    return InvalidArgument("max_scan_bytes = " + std::to_string(params.max_scan_bytes) + " must be >= 65536");
  }
  if (Status st = ValidateSequentialMatchParams(params.cascade.stage_a); !st.ok()) return st;
  if (Status st = ValidateStageCParams(params.cascade.stage_c); !st.ok()) return st;
  if (Status st = ValidateExchangePolicyParams(params.cascade.policy); !st.ok()) return st;
  SubmapRegistrationParams reg = MakeSubmapRegistrationParams(params.submap_voxel_size_m);
  reg.gates = params.gates;
  reg.max_hypotheses = params.registration_hypotheses;
  if (Status st = ValidateSubmapRegistrationParams(reg); !st.ok()) return st;
  return ValidateFrameSolverParams(params.frames);
}

MergeServer::MergeServer(int max_robots, std::size_t max_keyframes_per_robot, const MergeServerParams& params)
    : params_(params), params_status_(ValidateMergeServerParams(params)), max_keyframes_(max_keyframes_per_robot) {
  if (params_status_.ok() && (max_robots < 2 || max_robots > kMaxRobotId + 1)) {
    params_status_ = InvalidArgument("max_robots = " + std::to_string(max_robots) + " is outside 2.." +
                                     std::to_string(kMaxRobotId + 1));
  }
  if (params_status_.ok() && (max_keyframes_per_robot < 1 || max_keyframes_per_robot > (1u << 31))) {
    params_status_ = InvalidArgument("max_keyframes_per_robot = " + std::to_string(max_keyframes_per_robot) +
                                     " is outside 1..2^31");
  }
  if (params_status_.ok() && KeyframeRecordDimOf(params.record_kind) == 0) {
    params_status_ = InvalidArgument("record_kind " + std::to_string(static_cast<int>(params.record_kind)) +
                                     " is not a keyframe record kind");
  }
  robots_.resize(params_status_.ok() ? static_cast<std::size_t>(max_robots) : 0);
  for (RobotKeyframeDb& db : robots_) db.dim = KeyframeRecordDimOf(params.record_kind);
  // The descriptors' distance follows from the records the server takes.
  params_.cascade.metric.kind = params.record_kind == KeyframeRecordKind::kScanContext
                                    ? DescriptorMetric::Kind::kScanContext
                                    : DescriptorMetric::Kind::kUnitL2;
  params_.cascade.metric.scan_context_rings = kScanContextWireRings;
  params_.cascade.metric.scan_context_sectors = kScanContextWireSectors;
  record_descriptor_.resize(KeyframeRecordDimOf(params.record_kind));
}

Status MergeServer::Reject(std::uint64_t* counter, Status status) {
  ++*counter;
  stats_.last_rejection = status.message();
  return status;
}

Status MergeServer::CapacityError(int robot, std::uint32_t keyframe) const {
  return ResourceExhausted(RobotText(robot) + " keyframe " + std::to_string(keyframe) +
                           " is beyond the server's capacity of " + std::to_string(max_keyframes_) +
                           " keyframes per robot (--max-keyframes)");
}

Status MergeServer::EnsureKeyframe(int robot, std::uint32_t keyframe) {
  if (keyframe >= max_keyframes_) return CapacityError(robot, keyframe);
  RobotKeyframeDb& db = robots_[static_cast<std::size_t>(robot)];
  if (keyframe < db.size()) return Status::Ok();
  const std::size_t n = static_cast<std::size_t>(keyframe) + 1;
  db.descriptors.resize(n * db.dim, 0.0f);
  db.valid.resize(n, 0);
  db.pose_known.resize(n, 0);
  db.no_descriptor.resize(n, 0);
  db.T_map_sensor.resize(n, Eigen::Isometry3d::Identity());
  db.stored_points.resize(n, 0);
  return Status::Ok();
}

namespace {

std::string HexId(std::uint32_t id) {
  static const char kDigits[] = "0123456789ABCDEF";
  std::string text = "0x00000000";
  for (int i = 0; i < 8; ++i) text[static_cast<std::size_t>(9 - i)] = kDigits[(id >> (4 * i)) & 0xFu];
  return text;
}

bool DescriptorIdsConflict(std::uint32_t a, std::uint32_t b) { return a != 0 && b != 0 && a != b; }

}  // namespace

Status MergeServer::DescriptorIdError(const KeyframeBatch& batch) const {
  const std::uint32_t held = robots_[static_cast<std::size_t>(batch.robot_id)].descriptor_id;
  if (!DescriptorIdsConflict(held, batch.descriptor_id)) return Status::Ok();
  return InvalidArgument("keyframe batch " + std::to_string(batch.sequence) + " of " + RobotText(batch.robot_id) +
                         ": descriptor parameter id " + HexId(batch.descriptor_id) + " differs from " + HexId(held) +
                         " of its earlier batches in this session");
}

Status MergeServer::RecordKindError(const KeyframeBatch& batch) const {
  if (batch.record_kind == params_.record_kind) return Status::Ok();
  return InvalidArgument("keyframe batch " + std::to_string(batch.sequence) + " of " + RobotText(batch.robot_id) +
                         " carries " + KeyframeRecordKindName(batch.record_kind) + " records; this server takes " +
                         KeyframeRecordKindName(params_.record_kind) +
                         " records (start the robots and the server with the same --descriptor)");
}

Status MergeServer::CheckKeyframeBatch(const KeyframeBatch& batch) const {
  if (!params_status_.ok()) return params_status_;
  if (batch.robot_id < 0 || batch.robot_id >= max_robots()) {
    return InvalidArgument("keyframe batch: robot_id " + std::to_string(batch.robot_id) + " is outside 0.." +
                           std::to_string(max_robots() - 1));
  }
  if (Status st = RecordKindError(batch); !st.ok()) return st;
  const std::size_t n = batch.num_records(), bytes = KeyframeRecordBytesOf(params_.record_kind);
  if (batch.records.size() != n * bytes || batch.stored_points.size() != n || n > kMaxRecordsPerBatch) {
    return InvalidArgument("keyframe batch of " + RobotText(batch.robot_id) + ": malformed record arrays");
  }
  Status first_error = InvalidArgument("keyframe batch of " + RobotText(batch.robot_id) + " has no record");
  std::vector<float> descriptor(KeyframeRecordDimOf(params_.record_kind));
  for (std::size_t i = 0; i < n; ++i) {
    auto record = DecodeRecordOfKind(params_.record_kind,
                                     Span<const std::uint8_t>(batch.records.data() + i * bytes, bytes),
                                     Span<float>(descriptor));
    if (record.ok() && record->keyframe_index < max_keyframes_) return Status::Ok();
    if (i == 0) first_error = record.ok() ? CapacityError(batch.robot_id, record->keyframe_index) : record.status();
  }
  return first_error;
}

Status MergeServer::OnKeyframeBatch(const KeyframeBatch& batch) {
  if (!params_status_.ok()) return params_status_;
  if (batch.robot_id < 0 || batch.robot_id >= max_robots()) {
    return Reject(&stats_.rejected_batches, InvalidArgument("keyframe batch: robot_id " + std::to_string(batch.robot_id) +
                                                            " is outside 0.." + std::to_string(max_robots() - 1)));
  }
  if (Status st = RecordKindError(batch); !st.ok()) return Reject(&stats_.rejected_batches, st);
  const std::size_t n = batch.num_records(), bytes = KeyframeRecordBytesOf(params_.record_kind);
  if (batch.records.size() != n * bytes || batch.stored_points.size() != n || n > kMaxRecordsPerBatch) {
    return Reject(&stats_.rejected_batches,
                  InvalidArgument("keyframe batch of " + RobotText(batch.robot_id) + ": " +
                                  std::to_string(batch.records.size()) + " record bytes and " +
                                  std::to_string(batch.stored_points.size()) +
                                  " point counts do not describe 1.." + std::to_string(kMaxRecordsPerBatch) +
                                  " records of " + std::to_string(bytes) + " bytes"));
  }
  if (Status st = DescriptorIdError(batch); !st.ok()) return Reject(&stats_.rejected_batches, st);
  ++stats_.batches;
  Status first_error;
  for (std::size_t i = 0; i < n; ++i) {
    auto record = DecodeRecordOfKind(params_.record_kind,
                                     Span<const std::uint8_t>(batch.records.data() + i * bytes, bytes),
                                     Span<float>(record_descriptor_));
    Status st = record.ok() ? EnsureKeyframe(batch.robot_id, record->keyframe_index) : record.status();
    if (!st.ok()) {
      Status named(st.code(), "keyframe batch " + std::to_string(batch.sequence) + " of " + RobotText(batch.robot_id) +
                                  ", record " + std::to_string(i) + ": " + st.message());
      Reject(&stats_.rejected_records, named);
      if (first_error.ok()) first_error = named;
      continue;
    }
    RobotKeyframeDb& db = robots_[static_cast<std::size_t>(batch.robot_id)];
    const std::size_t k = record->keyframe_index;
    if (db.valid[k]) ++stats_.records_repeated;
    std::copy(record_descriptor_.begin(), record_descriptor_.end(),
              db.descriptors.begin() + static_cast<std::ptrdiff_t>(k * db.dim));
    db.valid[k] = 1;
    db.pose_known[k] = 1;
    db.T_map_sensor[k] = record->T_map_sensor;
    db.stored_points[k] = batch.stored_points[i];
    // The robot's id is the one of its first batch that delivered a record.
    if (db.descriptor_id == 0) db.descriptor_id = batch.descriptor_id;
    ++stats_.records;
  }
  NoteMemory();
  return first_error;
}

Status MergeServer::CheckPoseUpdate(const PoseUpdate& update) const {
  if (!params_status_.ok()) return params_status_;
  if (update.robot_id < 0 || update.robot_id >= max_robots()) {
    return InvalidArgument("pose update: robot_id " + std::to_string(update.robot_id) + " is outside 0.." +
                           std::to_string(max_robots() - 1));
  }
  if (update.keyframes.size() != update.T_map_sensor.size() || update.keyframes.size() > kMaxPosesPerUpdate ||
      (!update.no_descriptor.empty() && update.no_descriptor.size() != update.keyframes.size())) {
    return InvalidArgument("pose update of " + RobotText(update.robot_id) + ": " +
                           std::to_string(update.keyframes.size()) + " keyframes but " +
                           std::to_string(update.T_map_sensor.size()) + " poses and " +
                           std::to_string(update.no_descriptor.size()) + " descriptor flags (at most " +
                           std::to_string(kMaxPosesPerUpdate) + ")");
  }
  for (std::size_t i = 0; i < update.keyframes.size(); ++i) {
    if (!IsFinitePose(update.T_map_sensor[i]) || !IsValidRigidTransform(update.T_map_sensor[i], 1e-3)) {
      return InvalidArgument("pose update " + std::to_string(update.sequence) + " of " + RobotText(update.robot_id) +
                             ": keyframe " + std::to_string(update.keyframes[i]) + " has a non-finite or non-rigid pose");
    }
    if (update.keyframes[i] >= max_keyframes_) return CapacityError(update.robot_id, update.keyframes[i]);
  }
  return Status::Ok();
}

Status MergeServer::OnPoseUpdate(const PoseUpdate& update) {
  // Validate everything first: a refused update changes nothing.
  if (Status st = CheckPoseUpdate(update); !st.ok()) {
    return params_status_.ok() ? Reject(&stats_.rejected_pose_updates, st) : st;
  }
  for (std::size_t i = 0; i < update.keyframes.size(); ++i) {
    const std::uint32_t k = update.keyframes[i];
    (void)EnsureKeyframe(update.robot_id, k);
    RobotKeyframeDb& db = robots_[static_cast<std::size_t>(update.robot_id)];
    db.T_map_sensor[k] = update.T_map_sensor[i];
    db.pose_known[k] = 1;
    if (!update.no_descriptor.empty() && update.no_descriptor[i]) db.no_descriptor[k] = 1;
  }
  ++stats_.pose_updates;
  NoteMemory();
  return Status::Ok();
}

bool MergeServer::has_scan(int robot, std::uint32_t keyframe) const {
  return scans_.count(Key(robot, keyframe)) != 0;
}

const std::vector<std::uint8_t>* MergeServer::scan_bytes(int robot, std::uint32_t keyframe) const {
  auto it = scans_.find(Key(robot, keyframe));
  return it == scans_.end() ? nullptr : &it->second;
}

Status MergeServer::OnScanChunk(const ScanChunk& chunk) {
  if (!params_status_.ok()) return params_status_;
  const std::string what = "scan chunk " + std::to_string(chunk.chunk_index) + "/" + std::to_string(chunk.num_chunks) +
                           " of " + RobotText(chunk.robot_id) + " keyframe " + std::to_string(chunk.keyframe);
  if (chunk.robot_id < 0 || chunk.robot_id >= max_robots()) {
    return Reject(&stats_.rejected_chunks, InvalidArgument(what + ": robot_id is outside 0.." +
                                                           std::to_string(max_robots() - 1)));
  }
  const std::uint64_t total = chunk.total_bytes;
  const std::uint64_t per_chunk = kMaxScanChunkPayloadBytes;
  if (chunk.num_chunks == 0 || chunk.num_chunks > kMaxChunksPerScan || chunk.chunk_index >= chunk.num_chunks ||
      total < kEncodedScanHeaderBytes || total > static_cast<std::uint64_t>(chunk.num_chunks) * per_chunk ||
      chunk.payload.empty() || chunk.payload.size() > per_chunk) {
    return Reject(&stats_.rejected_chunks,
                  InvalidArgument(what + ": inconsistent sizes (total " + std::to_string(total) + " bytes, payload " +
                                  std::to_string(chunk.payload.size()) + ")"));
  }
  if (total > EncodedScanBytes(params_.max_scan_points)) {
    return Reject(&stats_.rejected_chunks,
                  InvalidArgument(what + ": a scan of " + std::to_string(total) + " bytes holds more than the " +
                                  std::to_string(params_.max_scan_points) + " points a stored scan may (" +
                                  std::to_string(EncodedScanBytes(params_.max_scan_points)) + " bytes)"));
  }
  const std::uint64_t key = Key(chunk.robot_id, chunk.keyframe);
  if (scans_.count(key)) {
    ++stats_.duplicate_chunks;  // the scan is complete already: a retransmission
    return Status::Ok();
  }
  // Chunk i covers [i x size, min(total, (i + 1) x size)) with size = ceil(total / num_chunks) (ScanChunkRange).
  const ChunkRange range = ScanChunkRange(total, chunk.num_chunks, chunk.chunk_index);
  if (chunk.payload.size() != range.size) {
    return Reject(&stats_.rejected_chunks, InvalidArgument(what + ": payload of " + std::to_string(chunk.payload.size()) +
                                                           " bytes where the protocol expects " +
                                                           std::to_string(range.size)));
  }
  auto it = partial_.find(key);
  if (it == partial_.end()) {
    if (held_bytes_ + total > params_.max_scan_bytes || partial_.size() + scans_.size() >= params_.max_scans_held) {
      ++stats_.chunks_over_budget;
      return Reject(&stats_.rejected_chunks,
                    ResourceExhausted(what + ": the server already holds " + std::to_string(partial_.size() + scans_.size()) +
                                      " scans, " + std::to_string(held_bytes_) + " bytes (max_scans_held = " +
                                      std::to_string(params_.max_scans_held) + ", max_scan_bytes = " +
                                      std::to_string(params_.max_scan_bytes) + ")"));
    }
    Partial fresh;
    fresh.total_bytes = chunk.total_bytes;
    fresh.num_chunks = chunk.num_chunks;
    fresh.have.assign(chunk.num_chunks, 0);
    fresh.bytes.assign(chunk.total_bytes, 0);
    held_bytes_ += total;
    partial_flag_bytes_ += fresh.have.capacity();
    it = partial_.emplace(key, std::move(fresh)).first;
    NoteMemory();
  }
  Partial& p = it->second;
  if (p.total_bytes != chunk.total_bytes || p.num_chunks != chunk.num_chunks) {
    return Reject(&stats_.rejected_chunks, InvalidArgument(what + ": sizes differ from the scan's earlier chunks"));
  }
  const std::uint64_t offset = range.offset;
  if (p.have[chunk.chunk_index]) {
    ++stats_.duplicate_chunks;
    return Status::Ok();
  }
  std::copy(chunk.payload.begin(), chunk.payload.end(), p.bytes.begin() + static_cast<std::ptrdiff_t>(offset));
  p.have[chunk.chunk_index] = 1;
  ++p.received;
  ++stats_.chunks;
  if (p.received < p.num_chunks) return Status::Ok();
  // Complete: verify the scan before it is used.
  std::vector<std::uint8_t> bytes = std::move(p.bytes);
  partial_flag_bytes_ -= p.have.capacity();
  partial_.erase(it);
  if (auto header = VerifyEncodedScan(Span<const std::uint8_t>(bytes)); !header.ok() ||
      EncodedScanBytes(header->num_points) != bytes.size()) {
    held_bytes_ -= total;
    ++stats_.corrupt_scans;
    return Reject(&stats_.rejected_chunks,
                  DataLoss(RobotText(chunk.robot_id) + " keyframe " + std::to_string(chunk.keyframe) +
                           ": reassembled scan is corrupt (" +
                           (header.ok() ? std::string("size does not match its point count") : header.status().message()) +
                           "); it must be sent again"));
  }
  scans_.emplace(key, std::move(bytes));
  ++stats_.scans_completed;
  return Status::Ok();
}

void MergeServer::ClearScans() {
  NoteMemory();
  partial_.clear();
  scans_.clear();
  held_bytes_ = 0;
  partial_flag_bytes_ = 0;
}

void MergeServer::ResetRobot(int robot) {
  if (robot < 0 || robot >= max_robots()) return;
  NoteMemory();
  robots_[static_cast<std::size_t>(robot)] = RobotKeyframeDb();
  robots_[static_cast<std::size_t>(robot)].dim = KeyframeRecordDimOf(params_.record_kind);
  const std::uint64_t begin = Key(robot, 0), end = Key(robot + 1, 0);
  for (auto it = partial_.lower_bound(begin); it != partial_.end() && it->first < end;) {
    held_bytes_ -= it->second.total_bytes;
    partial_flag_bytes_ -= it->second.have.capacity();
    it = partial_.erase(it);
  }
  for (auto it = scans_.lower_bound(begin); it != scans_.end() && it->first < end;) {
    held_bytes_ -= it->second.size();
    it = scans_.erase(it);
  }
  pairs_.erase(std::remove_if(pairs_.begin(), pairs_.end(),
                              [robot](const PairState& p) { return p.alpha == robot || p.beta == robot; }),
               pairs_.end());
}

bool MergeServer::PartialScan(int robot, std::uint32_t keyframe, std::uint16_t* num_chunks,
                              const std::vector<std::uint8_t>** have) const {
  auto it = partial_.find(Key(robot, keyframe));
  if (it == partial_.end()) return false;
  *num_chunks = it->second.num_chunks;
  *have = &it->second.have;
  return true;
}

const MergeServer::PairState* MergeServer::FindPair(int alpha, int beta) const {
  for (const PairState& p : pairs_) {
    if (p.alpha == alpha && p.beta == beta) return &p;
  }
  return nullptr;
}

const ExchangeCascadeResult* MergeServer::cascade(int alpha, int beta) const {
  const PairState* p = FindPair(alpha, beta);
  return p ? &p->cascade : nullptr;
}

const StageCResult* MergeServer::stage_ac(int alpha, int beta) const {
  const PairState* p = FindPair(alpha, beta);
  return p && p->stage_ac_ran ? &p->stage_ac : nullptr;
}

Status MergeServer::RunCascades() {
  if (!params_status_.ok()) return params_status_;
  NoteMemory();
  pairs_.clear();
  incomparable_pairs_.clear();
  std::vector<std::vector<Eigen::Vector3d>>& positions = positions_;
  positions.resize(robots_.size());
  for (std::size_t r = 0; r < robots_.size(); ++r) {
    positions[r].resize(robots_[r].size());
    for (std::size_t k = 0; k < robots_[r].size(); ++k) positions[r][k] = robots_[r].T_map_sensor[k].translation();
  }
  const auto input = [&](int r) {
    const RobotKeyframeDb& db = robots_[static_cast<std::size_t>(r)];
    return CascadeRobotInput{{Span<const float>(db.descriptors), db.dim, Span<const std::uint8_t>(db.valid)},
                             Span<const Eigen::Vector3d>(positions[static_cast<std::size_t>(r)]),
                             Span<const std::uint32_t>(db.stored_points)};
  };
  const auto named = [](int a, int b, const Status& st) {
    return Status(st.code(), "cascade of robots " + std::to_string(a) + " and " + std::to_string(b) + ": " + st.message());
  };
  const bool joint = params_.cover == StageBCover::kJoint;
  for (int a = 0; a < max_robots(); ++a) {
    for (int b = a + 1; b < max_robots(); ++b) {
      const RobotKeyframeDb& A = robots_[static_cast<std::size_t>(a)];
      const RobotKeyframeDb& B = robots_[static_cast<std::size_t>(b)];
      if (A.size() == 0 || B.size() == 0) continue;
      if (DescriptorIdsConflict(A.descriptor_id, B.descriptor_id)) {
        incomparable_pairs_.emplace_back(a, b);
        continue;
      }
      // Pairwise: the whole cascade. Joint: up to stage B here, stage B over every pair below.
      auto result = joint ? RunCascadeStageA(input(a), input(b), params_.cascade)
                          : RunExchangeCascade(input(a), input(b), params_.cascade);
      if (!result.ok()) return named(a, b, result.status());
      PairState state;
      state.alpha = a;
      state.beta = b;
      state.cascade = std::move(*result);
      const auto& l_seq = state.cascade.stage_a.cells;
      if (!l_seq.empty() && params_.stage_ac_ablation) {
        // The A+C ablation: stage C over every loop of L_seq (both endpoints "selected").
        std::vector<int> all_a, all_b;
        for (std::uint32_t k : Endpoints(Span<const SequentialLoopCell>(l_seq), true)) all_a.push_back(static_cast<int>(k));
        for (std::uint32_t k : Endpoints(Span<const SequentialLoopCell>(l_seq), false)) all_b.push_back(static_cast<int>(k));
        StageCParams c = params_.cascade.stage_c;
        c.loop_set = StageCLoopSet::kBothEndpointsSelected;
        auto ac = RunStageC(Span<const SequentialLoopCell>(l_seq), Span<const int>(all_a), Span<const int>(all_b),
                            Span<const Eigen::Vector3d>(positions[static_cast<std::size_t>(a)]),
                            Span<const Eigen::Vector3d>(positions[static_cast<std::size_t>(b)]), c);
        if (!ac.ok()) return ac.status();
        state.stage_ac = std::move(*ac);
        state.stage_ac_ran = true;
      }
      pairs_.push_back(std::move(state));
    }
  }
  if (joint) {
    // One balanced cover over the loops of every pair that stage A passed on, then stage C and the policy per pair.
    std::vector<JointCoverPair> waiting;
    std::vector<std::size_t> index;
    for (std::size_t i = 0; i < pairs_.size(); ++i) {
      if (!CascadeAwaitsStageB(pairs_[i].cascade)) continue;
      waiting.push_back({pairs_[i].alpha, pairs_[i].beta, Span<const SequentialLoopCell>(pairs_[i].cascade.stage_a.cells)});
      index.push_back(i);
    }
    if (waiting.size() == 1) {  // one pair: its own cover is the joint one
      PairState& state = pairs_[index[0]];
      Status st = RunCascadeFromStageB(input(state.alpha), input(state.beta), params_.cascade, nullptr, 0, &state.cascade);
      if (!st.ok()) return named(state.alpha, state.beta, st);
    } else if (waiting.size() > 1) {
      auto cover = SolveJointStageB(Span<const JointCoverPair>(waiting), params_.cascade.stage_b);
      if (!cover.ok()) return Status(cover.status().code(), "joint stage B: " + cover.status().message());
      const int robots = static_cast<int>(cover->robots.size());
      for (std::size_t w = 0; w < index.size(); ++w) {
        PairState& state = pairs_[index[w]];
        Status st = RunCascadeFromStageB(input(state.alpha), input(state.beta), params_.cascade, &cover->pairs[w],
                                         robots, &state.cascade);
        if (!st.ok()) return named(state.alpha, state.beta, st);
        state.cascade.stage_b_s += cover->seconds;  // the one joint solve, in every pair's time
      }
    }
  }
  ApplyPlaceCheck();
  NoteMemory();
  return Status::Ok();
}

void MergeServer::ApplyPlaceCheck() {
  const double min_support = params_.chain_check_support;
  if (min_support <= 0.0) return;
  std::vector<PairPlacement> places;
  places.reserve(pairs_.size());
  for (const PairState& p : pairs_) {
    const ExchangeCascadeResult& c = p.cascade;
    places.push_back({p.alpha, p.beta, c.outcome == CascadeOutcome::kPolicy && c.consensus_measured,
                      c.consensus_support_chosen, c.consensus_placement});
  }
  const std::vector<PlaceCheckVerdict> verdicts = commerge::CheckPlacesAcrossPairs(
      Span<const PairPlacement>(places), max_robots(), min_support, params_.chain_agreement);
  for (std::size_t i = 0; i < pairs_.size(); ++i) {
    const PlaceCheckVerdict& v = verdicts[i];
    if (!v.refused()) continue;
    std::string via;
    for (int c : v.via) via += (via.empty() ? "" : ", ") + std::to_string(c);
    PairState& p = pairs_[i];
    p.place_check_refused = true;
    p.cascade.outcome = CascadeOutcome::kNoCandidate;
    p.cascade.no_candidate_reason =
        "place check: stage A's place (consensus support " + FormatNumber(places[i].support, 4) + " keyframes < " +
        FormatNumber(min_support, 4) + ") disagrees with where robot" + (v.chains > 1 ? "s " : " ") + via + " place" +
        (v.chains > 1 ? "" : "s") + " the two maps (--chain-check-support)";
    p.cascade.policy = ExchangePolicy{};
  }
}

std::vector<std::uint32_t> MergeServer::StoredKeyframes(int robot) const {
  std::vector<std::uint32_t> out;
  const RobotKeyframeDb& db = robots_[static_cast<std::size_t>(robot)];
  for (std::size_t k = 0; k < db.size(); ++k) {
    if (db.stored_points[k] > 0 || db.pose_known[k]) out.push_back(static_cast<std::uint32_t>(k));
  }
  return out;
}

Result<ExchangePlan> MergeServer::Plan(ExchangeMode mode) const {
  if (!params_status_.ok()) return params_status_;
  if (mode == ExchangeMode::kStageAC && !params_.stage_ac_ablation) {
    return InvalidArgument("mode A+C needs the A+C ablation's stage C (MergeServerParams::stage_ac_ablation), "
                           "which this server does not run");
  }
  ExchangePlan plan;
  plan.mode = mode;
  std::vector<std::vector<std::uint32_t>> wanted(robots_.size()), own(robots_.size());
  for (const PairState& p : pairs_) {
    PairSelection s;
    s.alpha = p.alpha;
    s.beta = p.beta;
    const auto& l_seq = p.cascade.stage_a.cells;
    if (p.place_check_refused && mode != ExchangeMode::kSendAll) {
      s.no_selection_reason = p.cascade.no_candidate_reason;
      plan.pairs.push_back(std::move(s));
      continue;
    }
    switch (mode) {
      case ExchangeMode::kSendAll:
        // The baseline of shipping everything: each pair registers the two robots' complete stored maps
        // (map-level global registration), whatever stage A found.
        s.alpha_keyframes = StoredKeyframes(p.alpha);
        s.beta_keyframes = StoredKeyframes(p.beta);
        s.loops = l_seq.size();
        break;
      case ExchangeMode::kStageA:
        s.alpha_keyframes = Endpoints(Span<const SequentialLoopCell>(l_seq), true);
        s.beta_keyframes = Endpoints(Span<const SequentialLoopCell>(l_seq), false);
        s.loops = l_seq.size();
        break;
      case ExchangeMode::kStageAB:
        s.alpha_keyframes = ToKeyframes(p.cascade.stage_b.selected_left);
        s.beta_keyframes = ToKeyframes(p.cascade.stage_b.selected_right);
        s.loops = l_seq.size();
        break;
      case ExchangeMode::kStageAC:
        if (p.stage_ac_ran) {
          s.alpha_keyframes = Endpoints(Span<const SequentialLoopCell>(p.stage_ac.selected_loops), true);
          s.beta_keyframes = Endpoints(Span<const SequentialLoopCell>(p.stage_ac.selected_loops), false);
          s.loops = p.stage_ac.selected_loops.size();
          if (s.loops == 0) s.no_selection_reason = "stage C (over L_seq): " + p.stage_ac.no_candidate_reason;
        }
        break;
      case ExchangeMode::kStageABC:
        s.alpha_keyframes = p.cascade.policy.alpha.keyframes;
        s.beta_keyframes = p.cascade.policy.beta.keyframes;
        s.loops = p.cascade.policy.loops;
        break;
    }
    if (s.alpha_keyframes.empty() && s.beta_keyframes.empty() && s.no_selection_reason.empty()) {
      s.no_selection_reason = p.cascade.no_candidate_reason.empty() ? "nothing selected" : p.cascade.no_candidate_reason;
    }
    if (mode != ExchangeMode::kSendAll) {
      // One rule for every mode: a robot's selection of the pair is padded to min_scans_per_robot with keyframes
      // that stage A matched to the other robot (ExchangePolicyParams::min_scans_per_robot; A+B+C's policy has
      // done it already, with the same pool and order). What the mode selected and what padding added are
      // counted apart.
      std::vector<std::uint32_t> own_a = s.alpha_keyframes, own_b = s.beta_keyframes;
      if (mode == ExchangeMode::kStageABC) {
        own_a = Endpoints(Span<const SequentialLoopCell>(p.cascade.stage_c.selected_loops), true);
        own_b = Endpoints(Span<const SequentialLoopCell>(p.cascade.stage_c.selected_loops), false);
      } else {
        const std::uint32_t min_scans = params_.cascade.policy.min_scans_per_robot;
        PadKeyframesFromPool(&s.alpha_keyframes, Endpoints(Span<const SequentialLoopCell>(l_seq), true), min_scans);
        PadKeyframesFromPool(&s.beta_keyframes, Endpoints(Span<const SequentialLoopCell>(l_seq), false), min_scans);
      }
      auto& oa = own[static_cast<std::size_t>(p.alpha)];
      auto& ob = own[static_cast<std::size_t>(p.beta)];
      oa.insert(oa.end(), own_a.begin(), own_a.end());
      ob.insert(ob.end(), own_b.begin(), own_b.end());
      auto& wa = wanted[static_cast<std::size_t>(p.alpha)];
      auto& wb = wanted[static_cast<std::size_t>(p.beta)];
      wa.insert(wa.end(), s.alpha_keyframes.begin(), s.alpha_keyframes.end());
      wb.insert(wb.end(), s.beta_keyframes.begin(), s.beta_keyframes.end());
    }
    plan.pairs.push_back(std::move(s));
  }
  if (mode == ExchangeMode::kSendAll) {
    for (std::size_t r = 0; r < robots_.size(); ++r) wanted[r] = StoredKeyframes(static_cast<int>(r));
    own = wanted;
  }
  AddRequests(&wanted, 1, /*skip_held=*/false, &plan);
  for (std::size_t r = 0; r < robots_.size(); ++r) {  // wanted[r] is sorted and unique now
    std::vector<std::uint32_t>& o = own[r];
    std::sort(o.begin(), o.end());
    o.erase(std::unique(o.begin(), o.end()), o.end());
    plan.selected_scans += o.size();
    plan.padded_scans += wanted[r].size() - o.size();
  }
  return plan;
}

void MergeServer::AddRequests(std::vector<std::vector<std::uint32_t>>* wanted, std::int32_t request_id,
                              bool skip_held, ExchangePlan* plan) const {
  for (std::size_t r = 0; r < wanted->size(); ++r) {
    auto& w = (*wanted)[r];
    std::sort(w.begin(), w.end());
    w.erase(std::unique(w.begin(), w.end()), w.end());
    if (skip_held) {
      w.erase(std::remove_if(w.begin(), w.end(), [&](std::uint32_t k) { return has_scan(static_cast<int>(r), k); }),
              w.end());
    }
    if (w.empty()) continue;
    ScanRequest req;
    req.robot_id = static_cast<int>(r);
    req.request_id = request_id++;
    req.keyframes = w;
    for (std::uint32_t k : w) {
      const std::uint32_t n = k < robots_[r].size() ? robots_[r].stored_points[k] : 0;
      plan->predicted_scan_bytes += EncodedScanBytes(n > 0 ? n : params_.cascade.policy.assumed_points_per_scan);
    }
    plan->requests.push_back(std::move(req));
  }
}

ExchangePlan MergeServer::RequestsFor(Span<const PairSelection> selections, std::int32_t first_request_id) const {
  ExchangePlan plan;
  std::vector<std::vector<std::uint32_t>> wanted(robots_.size());
  for (const PairSelection& s : selections) {
    for (const auto& [robot, keyframes] : {std::make_pair(s.alpha, &s.alpha_keyframes), std::make_pair(s.beta, &s.beta_keyframes)}) {
      if (robot < 0 || robot >= max_robots()) continue;
      auto& w = wanted[static_cast<std::size_t>(robot)];
      w.insert(w.end(), keyframes->begin(), keyframes->end());
    }
  }
  AddRequests(&wanted, first_request_id, /*skip_held=*/true, &plan);
  return plan;
}

void AdoptSelections(Span<const PairSelection> adopted, std::vector<PairSelection>* pairs) {
  for (const PairSelection& a : adopted) {
    for (PairSelection& p : *pairs) {
      if (p.alpha == a.alpha && p.beta == a.beta) p = a;
    }
  }
}

Result<ExchangePlan> MergeServer::WidenPlan(const ExchangePlan& plan, Span<const PairMergeResult> results,
                                            std::int32_t first_request_id) const {
  if (!params_status_.ok()) return params_status_;
  ExchangePlan wider;
  wider.mode = plan.mode;
  if (plan.mode == ExchangeMode::kSendAll) return wider;
  // Robots already joined by merged pairs (union-find): a refused pair between them is not widened.
  std::vector<int> root(robots_.size());
  for (std::size_t r = 0; r < root.size(); ++r) root[r] = static_cast<int>(r);
  const auto find = [&root](int r) {
    while (root[static_cast<std::size_t>(r)] != r) r = root[static_cast<std::size_t>(r)];
    return r;
  };
  for (const PairMergeResult& r : results) {
    if (r.attempted && r.registration.success() && r.alpha >= 0 && r.beta >= 0 && r.alpha < max_robots() &&
        r.beta < max_robots()) {
      root[static_cast<std::size_t>(find(r.alpha))] = find(r.beta);
    }
  }
  std::vector<std::vector<std::uint32_t>> wanted(robots_.size());
  for (const PairSelection& sel : plan.pairs) {
    if (sel.alpha < 0 || sel.beta < 0 || sel.alpha >= max_robots() || sel.beta >= max_robots() ||
        find(sel.alpha) == find(sel.beta)) {
      continue;
    }
    const PairMergeResult* result = nullptr;
    for (const PairMergeResult& r : results) {
      if (r.alpha == sel.alpha && r.beta == sel.beta) result = &r;
    }
    if (!result || !result->attempted || result->registration.success()) continue;
    const PairState* p = FindPair(sel.alpha, sel.beta);
    if (!p || sel.alpha_keyframes.empty() || sel.beta_keyframes.empty()) continue;
    // A cluster below tau_area (the cascade's `verification`) or at an ambiguous place gets one registration and
    // no more scans: asking again until something aligns is how a repeated structure (an aliased corridor) got
    // merged. An ambiguous cluster that the place consensus confirms strongly is widened all the same.
    if (p->cascade.verification) continue;
    if (p->cascade.ambiguous && !AmbiguousClusterConfirmed(p->cascade, params_)) continue;
    const Span<const SequentialLoopCell> l_seq(p->cascade.stage_a.cells);
    PairSelection w = sel;
    const auto grow = [](std::vector<std::uint32_t>* keyframes, std::vector<std::uint32_t> pool) {
      const std::size_t target = std::min<std::size_t>(2 * keyframes->size(), std::numeric_limits<std::uint32_t>::max());
      return PadKeyframesFromPool(keyframes, std::move(pool), static_cast<std::uint32_t>(target));
    };
    const std::size_t added = grow(&w.alpha_keyframes, Endpoints(l_seq, true)) +
                              grow(&w.beta_keyframes, Endpoints(l_seq, false));
    if (added == 0) continue;
    auto& wa = wanted[static_cast<std::size_t>(w.alpha)];
    auto& wb = wanted[static_cast<std::size_t>(w.beta)];
    wa.insert(wa.end(), w.alpha_keyframes.begin(), w.alpha_keyframes.end());
    wb.insert(wb.end(), w.beta_keyframes.begin(), w.beta_keyframes.end());
    wider.pairs.push_back(std::move(w));
  }
  AddRequests(&wanted, first_request_id, /*skip_held=*/true, &wider);
  return wider;
}

std::size_t MergeServer::BuildSubmap(int robot, Span<const std::uint32_t> keyframes, double voxel_size_m,
                                     std::vector<PointXYZI>* points, std::vector<Eigen::Vector3d>* sensor_origins,
                                     std::size_t* missing) {
  points->clear();
  sensor_origins->clear();
  union_points_.clear();
  std::size_t used = 0;
  *missing = 0;
  VoxelGridParams v;
  v.voxel_size_m = voxel_size_m;
  // The union is voxelised once it holds more than this many submaps' worth of points: it never holds more than
  // that plus one scan (max_scan_points), and neither do the grid's workspace and the voxelised output. Reserved
  // once, so none of them grows past the submaps budget module (MakeBudgetTable).
  constexpr std::size_t kUnionPointsPerSubmap = BudgetRecordSizes::kSubmapUnionFactor;
  const std::size_t union_capacity = kUnionPointsPerSubmap * params_.max_submap_points + params_.max_scan_points;
  if (union_points_.capacity() < union_capacity) {
    union_points_.reserve(union_capacity);
    voxel_grid_.Reserve(union_capacity);
    scan_points_.reserve(params_.max_scan_points);
  }
  sensor_origins->reserve(keyframes.size());
  const RobotKeyframeDb& db = robots_[static_cast<std::size_t>(robot)];
  for (std::uint32_t k : keyframes) {
    auto it = scans_.find(Key(robot, k));
    if (it == scans_.end() || k >= db.size() || !db.pose_known[k]) {
      ++*missing;
      continue;
    }
    if (!DecodeScan(Span<const std::uint8_t>(it->second), &scan_points_).ok()) {
      ++*missing;
      continue;
    }
    // Paper eq. M_alpha: every point of the scan placed with the keyframe's pose in the robot's map frame.
    const Eigen::Isometry3f T = db.T_map_sensor[k].cast<float>();
    for (const PointXYZI& p : scan_points_) {
      const Eigen::Vector3f q = T * Eigen::Vector3f(p.x, p.y, p.z);
      union_points_.push_back({q.x(), q.y(), q.z(), p.intensity});
    }
    sensor_origins->push_back(db.T_map_sensor[k].translation());
    ++used;
    // A large selection (send-all's complete maps) is voxelised as it grows, so the union stays within a few
    // submaps' worth of points whatever the number of scans.
    if (union_points_.size() > kUnionPointsPerSubmap * params_.max_submap_points) {
      if (!voxel_grid_.Downsample(Span<const PointXYZI>(union_points_), v, points).ok()) points->clear();
      union_points_.assign(points->begin(), points->end());
      // Still more than that once voxelised: at this voxel size the submap cannot fit max_submap_points (the
      // union's voxels only grow as scans are added), so the caller will voxelise coarser. Stop adding scans, so
      // the union, the grid and the submaps stay within their module (a last, coarsest attempt that still does
      // not fit registers the scans taken so far).
      if (union_points_.size() > kUnionPointsPerSubmap * params_.max_submap_points) break;
    }
  }
  if (!voxel_grid_.Downsample(Span<const PointXYZI>(union_points_), v, points).ok()) points->clear();
  NoteMemory();
  return used;
}

Result<PairMergeResult> MergeServer::MergePair(const PairSelection& pair, RegistrationStageObserver* observer) {
  if (!params_status_.ok()) return params_status_;
  if (pair.alpha < 0 || pair.beta < 0 || pair.alpha >= max_robots() || pair.beta >= max_robots() ||
      pair.alpha == pair.beta) {
    return InvalidArgument("pair (" + std::to_string(pair.alpha) + ", " + std::to_string(pair.beta) +
                           ") is not two different robots of 0.." + std::to_string(max_robots() - 1));
  }
  PairMergeResult out;
  out.alpha = pair.alpha;
  out.beta = pair.beta;
  if (pair.alpha_keyframes.empty() || pair.beta_keyframes.empty()) {
    out.reason = pair.no_selection_reason.empty() ? "no scans selected" : pair.no_selection_reason;
    return out;
  }
  // Both submaps at one voxel size; grown until both fit max_submap_points.
  auto build_both = [&](double voxel_size_m) {
    out.alpha_scans = BuildSubmap(pair.alpha, Span<const std::uint32_t>(pair.alpha_keyframes), voxel_size_m,
                                  &alpha_points_, &alpha_origins_, &out.alpha_missing);
    out.beta_scans = BuildSubmap(pair.beta, Span<const std::uint32_t>(pair.beta_keyframes), voxel_size_m,
                                 &beta_points_, &beta_origins_, &out.beta_missing);
    return alpha_points_.size() <= params_.max_submap_points && beta_points_.size() <= params_.max_submap_points;
  };
  double voxel = params_.submap_voxel_size_m;
  bool grown = false;
  for (int attempt = 0;; ++attempt) {
    if (build_both(voxel) || attempt == 8) break;
    voxel *= 1.25;
    grown = true;
  }
  if (!grown && params_.min_submap_points > 0) {
    // Small scene: finer while the smaller submap gains (the scans may be stored no finer than the grid).
    std::size_t smaller = std::min(alpha_points_.size(), beta_points_.size());
    for (int k = 1; smaller < params_.min_submap_points; ++k) {
      const double finer = AdaptiveVoxelStep(params_.submap_voxel_size_m, k);
      if (finer < params_.min_submap_voxel_size_m * (1.0 - 1e-9)) break;
      const bool fits = build_both(finer);
      const std::size_t now = std::min(alpha_points_.size(), beta_points_.size());
      if (!fits || 10 * now < 11 * smaller) {
        build_both(voxel);  // back to the last size taken
        break;
      }
      voxel = finer;
      smaller = now;
    }
  }
  out.alpha_submap_points = alpha_points_.size();
  out.beta_submap_points = beta_points_.size();
  out.voxel_size_m = voxel;
  if (out.alpha_scans == 0 || out.beta_scans == 0) {
    out.reason = "no selected scan was received (" + std::to_string(out.alpha_missing) + " of robot " +
                 std::to_string(pair.alpha) + " and " + std::to_string(out.beta_missing) + " of robot " +
                 std::to_string(pair.beta) + " missing)";
    return out;
  }
  SubmapRegistrationParams reg = MakeSubmapRegistrationParams(voxel);
  reg.gates = params_.gates;
  reg.gates.max_points = std::max(reg.gates.max_points, params_.max_submap_points);
  reg.max_hypotheses = params_.registration_hypotheses;
  SubmapView source{Span<const PointXYZI>(beta_points_), Span<const Eigen::Vector3d>(beta_origins_)};
  SubmapView target{Span<const PointXYZI>(alpha_points_), Span<const Eigen::Vector3d>(alpha_origins_)};
  auto result = registration_.Register(source, target, reg, observer);
  NoteMemory();
  if (!result.ok()) return result.status();
  out.attempted = true;
  out.registration = *result;
  if (!result->success()) {
    out.reason = RegistrationVerdictName(result->verdict);
    return out;
  }
  // A pair at a confirmed ambiguous place may have been widened until something aligned: it merges only where
  // its place consensus places it. The transform stays in the result for the report.
  const PairState* state = FindPair(pair.alpha, pair.beta);
  PlacementGap gap;
  if (state && !RegistrationAtConfirmedPlace(state->cascade, params_, result->T_target_source, &gap)) {
    out.registration.verdict = RegistrationVerdict::kOffConfirmedPlace;
    out.reason = std::string(RegistrationVerdictName(out.registration.verdict)) + " (" + FormatNumber(gap.distance_m, 3) +
                 " m and " + FormatNumber(gap.yaw_deg, 3) + " deg from the place consensus's placement, tolerance " +
                 FormatNumber(params_.cascade.consensus.agree_m, 3) + " m and " +
                 FormatNumber(params_.cascade.consensus.agree_deg, 3) + " deg)";
    return out;
  }
  if (state) MeasureColocation(*state, &out);
  if (params_.max_colocated_chance > 0.0 && out.colocated_keyframes >= params_.min_colocated_keyframes &&
      out.colocated_chance >= params_.max_colocated_chance) {
    out.registration.verdict = RegistrationVerdict::kDescriptorsDisagree;
    out.reason = std::string(RegistrationVerdictName(out.registration.verdict)) + " (" +
                 std::to_string(out.colocated_keyframes) + " keyframes of robot " + std::to_string(pair.beta) +
                 " placed on robot " + std::to_string(pair.alpha) + "'s away from stage A's cluster, median chance " +
                 FormatNumber(out.colocated_chance, 3) + " >= " + FormatNumber(params_.max_colocated_chance, 3) + ")";
  }
  return out;
}

void MergeServer::MeasureColocation(const PairState& state, PairMergeResult* result) const {
  const RobotKeyframeDb& A = robots_[static_cast<std::size_t>(result->alpha)];
  const RobotKeyframeDb& B = robots_[static_cast<std::size_t>(result->beta)];
  // Stage A's cluster is where the descriptors chose the place: only the rest of the co-located keyframes is
  // independent evidence.
  const SequentialMatchResult& a = state.cascade.stage_a;
  const std::uint32_t from = a.found ? static_cast<std::uint32_t>(a.best.col_min) : 1;
  const std::uint32_t to = a.found ? static_cast<std::uint32_t>(a.best.col_max) : 0;
  std::size_t colocated_keyframes = 0;
  auto colocated = ColocatedKeyframes(
      {Span<const float>(A.descriptors), Span<const std::uint8_t>(A.valid), Span<const Eigen::Isometry3d>(A.T_map_sensor)},
      {Span<const float>(B.descriptors), Span<const std::uint8_t>(B.valid), Span<const Eigen::Isometry3d>(B.T_map_sensor)},
      A.dim, result->registration.T_target_source, params_.colocation, from, to, &colocated_keyframes,
      params_.cascade.metric);
  if (!colocated.ok()) return;
  result->colocated_keyframes = colocated_keyframes;
  result->colocated_chance = MedianChance(Span<const ColocatedKeyframe>(*colocated), 1, 0, nullptr);
}

Result<FrameSolution> MergeServer::SolveFrames(Span<const PairMergeResult> pairs) const {
  if (!params_status_.ok()) return params_status_;
  std::vector<FrameMeasurement> measurements;
  for (const PairMergeResult& p : pairs) {
    if (!p.attempted || !p.registration.success()) continue;
    FrameMeasurement m;
    m.robot_a = p.alpha;
    m.robot_b = p.beta;
    m.T_a_b = p.registration.T_target_source;
    m.weight = static_cast<double>(std::max<std::size_t>(1, p.registration.num_fine_inliers));
    measurements.push_back(m);
  }
  return SolveRobotFrames(max_robots(), Span<const FrameMeasurement>(measurements), params_.frames);
}

namespace {
constexpr const char* kServerMemoryModules[] = {"descriptor_db",   "affinity", "solvers",
                                                "scan_reassembly", "submaps",  "registration"};
}  // namespace

std::array<std::int64_t, MergeServer::kMemoryModules> MergeServer::MeasureMemory() const {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t descriptor_db = held(robots_);
  for (const RobotKeyframeDb& db : robots_) {
    descriptor_db += held(db.descriptors) + held(db.valid) + held(db.pose_known) + held(db.no_descriptor) +
                     held(db.T_map_sensor) + held(db.stored_points);
  }
  std::size_t affinity = held(positions_);
  for (const std::vector<Eigen::Vector3d>& p : positions_) affinity += held(p);
  std::size_t solvers = held(pairs_);
  for (const PairState& p : pairs_) {
    affinity += held(p.cascade.stage_a.cells);
    const ExchangeCascadeResult& c = p.cascade;
    solvers += held(c.stage_b.selected_left) + held(c.stage_b.selected_right) + held(c.stage_c.candidate_loops) +
               held(c.stage_c.selected_loops) + held(c.stage_c.clique.clique) + held(c.policy.alpha.keyframes) +
               held(c.policy.beta.keyframes) + held(p.stage_ac.candidate_loops) + held(p.stage_ac.selected_loops) +
               held(p.stage_ac.clique.clique);
  }
  // Scan bytes are allocated exactly (assign of total_bytes, moved when complete): held_bytes_ is their sum.
  const std::size_t scan_reassembly =
      static_cast<std::size_t>(held_bytes_ + partial_flag_bytes_) +
      partial_.size() * sizeof(decltype(partial_)::value_type) + scans_.size() * sizeof(decltype(scans_)::value_type);
  const std::size_t submaps = held(scan_points_) + held(union_points_) + held(alpha_points_) + held(beta_points_) +
                              held(alpha_origins_) + held(beta_origins_) + voxel_grid_.workspace_capacity_bytes();
  return {static_cast<std::int64_t>(descriptor_db), static_cast<std::int64_t>(affinity),
          static_cast<std::int64_t>(solvers),       static_cast<std::int64_t>(scan_reassembly),
          static_cast<std::int64_t>(submaps),       static_cast<std::int64_t>(registration_.workspace_bytes())};
}

void MergeServer::NoteMemory() const {
  memory_high_water_.Note(MeasureMemory());
}

std::vector<ModuleMemory> MergeServer::MemoryUse() const {
  std::vector<ModuleMemory> out = memory_high_water_.Report(kServerMemoryModules, MeasureMemory());
  return out;
}

}  // namespace commerge
