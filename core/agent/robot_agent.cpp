// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/robot_agent.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "core/cloud/scan_codec.hpp"
#include "core/geometry/angles.hpp"

namespace commerge {

Status ValidateRobotAgentParams(const RobotAgentParams& params) {
  if (params.max_records_per_batch < 1 || params.max_records_per_batch > kMaxRecordsPerBatch) {
    return InvalidArgument("max_records_per_batch = " + std::to_string(params.max_records_per_batch) +
                           " is outside 1.." + std::to_string(kMaxRecordsPerBatch));
  }
  if (params.max_poses_per_update < 1 || params.max_poses_per_update > kMaxPosesPerUpdate) {
    return InvalidArgument("max_poses_per_update = " + std::to_string(params.max_poses_per_update) +
                           " is outside 1.." + std::to_string(kMaxPosesPerUpdate));
  }
  if (params.chunk_payload_bytes < 1 || params.chunk_payload_bytes > kMaxScanChunkPayloadBytes) {
    return InvalidArgument("chunk_payload_bytes = " + std::to_string(params.chunk_payload_bytes) +
                           " is outside 1.." + std::to_string(kMaxScanChunkPayloadBytes));
  }
  if (params.record_descriptor_bits != 0 && (params.record_descriptor_bits < kCompactMinDescriptorBits ||
                                             params.record_descriptor_bits > kCompactMaxDescriptorBits)) {
    return InvalidArgument("record_descriptor_bits = " + std::to_string(params.record_descriptor_bits) +
                           " is neither 0 (92-byte records) nor in " + std::to_string(kCompactMinDescriptorBits) +
                           ".." + std::to_string(kCompactMaxDescriptorBits));
  }
  if (!(params.pose_update_min_translation_m >= 0.0) || !(params.pose_update_min_rotation_deg >= 0.0) ||
      !(params.scan_pose_min_translation_m >= 0.0) || !(params.scan_pose_min_rotation_deg >= 0.0) ||
      !(params.request_pose_min_translation_m >= 0.0) || !(params.request_pose_min_rotation_deg >= 0.0)) {
    return InvalidArgument("pose_update_min_*, scan_pose_min_* and request_pose_min_* must be >= 0");
  }
  return ValidateRobotMapperParams(params.mapper);
}

RobotAgent::RobotAgent(int robot_id, const RobotAgentParams& params, const RobotMapperCapacity& capacity,
                       PlaceDescriptor* descriptor, ScanStore* store)
    : robot_id_(robot_id),
      params_(params),
      params_status_(ValidateRobotAgentParams(params)),
      store_(store),
      mapper_(params.mapper, capacity, descriptor, store) {
  if (params_status_.ok() && (robot_id < 0 || robot_id > kMaxRobotId)) {
    params_status_ = InvalidArgument("robot id " + std::to_string(robot_id) + " is outside 0.." +
                                     std::to_string(kMaxRobotId));
  }
  if (params_status_.ok() && descriptor != nullptr) {
    // The record that carries the descriptor: 40 unit values (SOLiD, ring occupancy) or the Scan Context grid.
    record_kind_ = RobotRecordKind(descriptor->kind(), params.record_descriptor_bits);
    if (descriptor->dimension() != KeyframeRecordDimOf(record_kind_)) {
      params_status_ = InvalidArgument("the place descriptor has " + std::to_string(descriptor->dimension()) +
                                       " values; its keyframe record (" + KeyframeRecordKindName(record_kind_) +
                                       ") carries " + std::to_string(KeyframeRecordDimOf(record_kind_)));
    }
  }
  pose_dirty_.assign(capacity.max_keyframes, 0);
  scan_requested_.assign(capacity.max_keyframes, 0);
  resend_.assign(capacity.max_keyframes, 0);
  resend_from_ = resend_.size();
  last_sent_us_.assign(capacity.max_keyframes, -1);
  sent_pose_.assign(capacity.max_keyframes, std::array<float, 7>{});
  dirty_scan_from_ = pose_dirty_.size();
  encoded_.reserve(EncodedScanBytes(capacity.max_points_per_stored_scan));
  if (record_kind_ == KeyframeRecordKind::kCompact40) compact_.reserve(params.max_records_per_batch);
}

void RobotAgent::RememberSent(std::size_t k) {
  const Eigen::Isometry3d& T = mapper_.pose(k);
  const Eigen::Quaterniond q(T.linear());
  sent_pose_[k] = {static_cast<float>(T.translation().x()), static_cast<float>(T.translation().y()),
                   static_cast<float>(T.translation().z()), static_cast<float>(q.w()), static_cast<float>(q.x()),
                   static_cast<float>(q.y()), static_cast<float>(q.z())};
}

bool RobotAgent::MovedSinceSent(std::size_t k, double min_translation_m, double min_rotation_deg) const {
  const Eigen::Isometry3d& T = mapper_.pose(k);
  const std::array<float, 7>& s = sent_pose_[k];
  const Eigen::Vector3d t(static_cast<double>(s[0]), static_cast<double>(s[1]), static_cast<double>(s[2]));
  if ((T.translation() - t).norm() > min_translation_m) return true;
  const Eigen::Quaterniond q_sent(static_cast<double>(s[3]), static_cast<double>(s[4]), static_cast<double>(s[5]),
                                  static_cast<double>(s[6]));
  const double angle_rad = Eigen::Quaterniond(T.linear()).angularDistance(q_sent.normalized());
  return angle_rad * kRadToDeg > min_rotation_deg;
}

void RobotAgent::MarkPoseDirty(std::size_t k) {
  if (k >= pose_dirty_.size() || pose_dirty_[k]) return;
  pose_dirty_[k] = 1;
  ++dirty_count_;
  dirty_scan_from_ = std::min(dirty_scan_from_, k);
}

void RobotAgent::RequeueKeyframe(std::size_t k) {
  if (k >= sent_upto_ || k >= resend_.size()) return;
  if (!mapper_.descriptor_valid(k)) {
    MarkPoseDirty(k);
    return;
  }
  if (resend_[k]) return;
  resend_[k] = 1;
  ++resend_count_;
  resend_from_ = std::min(resend_from_, k);
}

void RobotAgent::RequeueAllSent() {
  for (std::size_t k = 0; k < sent_upto_; ++k) RequeueKeyframe(k);
}

void RobotAgent::RequeuePoses(Span<const std::uint32_t> keyframes) {
  for (std::uint32_t k : keyframes) {
    if (k < sent_upto_) MarkPoseDirty(k);
  }
}

void RobotAgent::QueuePoses(Span<const std::uint32_t> keyframes) {
  for (std::uint32_t k : keyframes) {
    // Keyframes not yet sent go out with their current pose anyway.
    if (k >= sent_upto_ || k >= pose_dirty_.size() || pose_dirty_[k]) continue;
    // Keyframes without a valid descriptor are queued when passed; the others only when they moved enough.
    if (!StreamPoseStale(k)) continue;
    MarkPoseDirty(k);
  }
}

bool RobotAgent::StreamPoseStale(std::size_t k) const {
  return scan_requested_[k] ? MovedSinceSent(k, params_.scan_pose_min_translation_m, params_.scan_pose_min_rotation_deg)
                            : MovedSinceSent(k, params_.pose_update_min_translation_m, params_.pose_update_min_rotation_deg);
}

Result<KeyframeStep> RobotAgent::AddScan(Span<const PointXYZI> raw_scan, const Eigen::Isometry3d& T_odom_sensor) {
  if (!params_status_.ok()) return params_status_;
  auto step = mapper_.AddScan(raw_scan, T_odom_sensor);
  if (step.ok()) QueuePoses(Span<const std::uint32_t>(step->changed_keyframes));
  NoteMemory();
  return step;
}

namespace {
constexpr const char* kRobotMemoryModules[] = {"descriptor_db", "pose_graph",   "scan_store",
                                               "scan_workspace", "loop_closure", "outbox"};
}  // namespace

std::array<std::int64_t, RobotAgent::kMemoryModules> RobotAgent::MeasureMemory() const {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  const DescriptorDatabase& db = mapper_.descriptor_db();
  const PoseGraph& graph = mapper_.graph();
  const std::size_t descriptor_db = db.size() * (db.dimension() * sizeof(float) + sizeof(std::uint8_t));
  // Nodes, edges, the solver's workspace and the mapper's odometry pose per keyframe.
  const std::size_t pose_graph = 2 * graph.num_nodes() * sizeof(Eigen::Isometry3d) +
                                 graph.num_edges() * sizeof(PoseGraphEdge) + graph.workspace_bytes();
  const std::size_t scan_store = store_ != nullptr ? store_->stats().used_bytes : 0;
  const std::size_t outbox =
      held(pose_dirty_) + held(scan_requested_) + held(resend_) + held(last_sent_us_) + held(sent_pose_) +
      held(encoded_) + held(compact_);
  return {static_cast<std::int64_t>(descriptor_db), static_cast<std::int64_t>(pose_graph),
          static_cast<std::int64_t>(scan_store), static_cast<std::int64_t>(mapper_.scan_workspace_bytes()),
          static_cast<std::int64_t>(mapper_.loop_closure_workspace_bytes()), static_cast<std::int64_t>(outbox)};
}

void RobotAgent::NoteMemory() const {
  memory_high_water_.Note(MeasureMemory());
}

std::vector<ModuleMemory> RobotAgent::MemoryUse() const {
  std::vector<ModuleMemory> out = memory_high_water_.Report(kRobotMemoryModules, MeasureMemory());
  // The scan store keeps its own mark (its used bytes fall when it evicts between two calls here).
  if (store_ != nullptr) {
    out[2].high_water_bytes = std::max(out[2].high_water_bytes, static_cast<std::int64_t>(store_->stats().high_water_bytes));
  }
  return out;
}

Status RobotAgent::Finish() {
  if (!params_status_.ok()) return params_status_;
  auto moved = mapper_.OptimizePending();
  if (!moved.ok()) return moved.status();
  QueuePoses(Span<const std::uint32_t>(*moved));
  NoteMemory();
  // Poses that crept away in steps below the threshold: the server ends within it of the final poses.
  for (std::size_t k = 0; k < sent_upto_; ++k) {
    if (!pose_dirty_[k] && StreamPoseStale(k)) MarkPoseDirty(k);
  }
  return Status::Ok();
}

Result<bool> RobotAgent::TakeKeyframeBatch(std::int64_t utime_us, KeyframeBatch* batch) {
  if (!params_status_.ok()) return params_status_;
  batch->utime_us = utime_us;
  batch->robot_id = robot_id_;
  batch->session = session_;
  batch->descriptor_id = mapper_.descriptor_parameter_id();
  batch->record_kind = record_kind_;
  batch->records.clear();
  batch->stored_points.clear();
  batch->num_compact_records = 0;
  compact_.clear();
  std::size_t records = 0;
  // Re-announcements first, in a batch of their own (the caller counts its bytes as resent).
  if (resend_count_ > 0) {
    for (std::size_t k = resend_from_; k < sent_upto_ && records < params_.max_records_per_batch; ++k) {
      if (!resend_[k]) continue;
      resend_[k] = 0;
      --resend_count_;
      resend_from_ = k + 1;
      if (Status st = AppendRecord(k, utime_us, batch); !st.ok()) return st;
      ++records;
    }
    if (resend_count_ == 0) resend_from_ = resend_.size();
    if (records > 0) return FinishBatch(batch);
  }
  const std::size_t n = mapper_.num_keyframes();
  while (sent_upto_ < n && records < params_.max_records_per_batch) {
    const std::size_t k = sent_upto_++;
    if (!mapper_.descriptor_valid(k)) {
      // Its pose still matters (submaps, trajectories): it travels in the next pose update.
      MarkPoseDirty(k);
      continue;
    }
    if (Status st = AppendRecord(k, utime_us, batch); !st.ok()) return st;
    ++records;
  }
  if (records == 0) return false;
  return FinishBatch(batch);
}

Result<bool> RobotAgent::FinishBatch(KeyframeBatch* batch) {
  if (record_kind_ == KeyframeRecordKind::kCompact40) {
    if (Status st = EncodeCompactBatch(Span<const CompactKeyframe>(compact_), params_.record_descriptor_bits,
                                       &batch->records);
        !st.ok()) {
      return Status(st.code(), "robot " + std::to_string(robot_id_) + ": " + st.message());
    }
  }
  batch->sequence = batch_sequence_++;
  return true;
}

Status RobotAgent::AppendRecord(std::size_t k, std::int64_t utime_us, KeyframeBatch* batch) {
  {
    const KeyframePose pose{static_cast<std::uint32_t>(k), mapper_.pose(k)};
    std::uint32_t points = 0;
    if (auto view = store_->View(static_cast<std::uint32_t>(k)); view.ok()) {
      if (auto header = ParseScanHeader(*view); header.ok()) points = header->num_points;
    }
    if (record_kind_ == KeyframeRecordKind::kCompact40) {
      compact_.push_back(MakeCompactKeyframe(pose, mapper_.descriptor(k), points));  // coded in FinishBatch
      batch->num_compact_records = compact_.size();
    } else {
      const std::size_t offset = batch->records.size(), bytes = KeyframeRecordBytesOf(record_kind_);
      batch->records.resize(offset + bytes);
      if (Status st = EncodeRecordOfKind(record_kind_, pose, mapper_.descriptor(k),
                                         Span<std::uint8_t>(batch->records.data() + offset, bytes));
          !st.ok()) {
        batch->records.resize(offset);
        return Status(st.code(), "robot " + std::to_string(robot_id_) + " keyframe " + std::to_string(k) + ": " +
                                     st.message());
      }
      batch->stored_points.push_back(points);
    }
    RememberSent(k);
    last_sent_us_[k] = utime_us;
  }
  return Status::Ok();
}

bool RobotAgent::TakePoseUpdate(std::int64_t utime_us, PoseUpdate* update) {
  update->utime_us = utime_us;
  update->robot_id = robot_id_;
  update->session = session_;
  update->keyframes.clear();
  update->T_map_sensor.clear();
  update->no_descriptor.clear();
  if (dirty_count_ == 0) return false;
  for (std::size_t k = dirty_scan_from_; k < sent_upto_ && update->keyframes.size() < params_.max_poses_per_update;
       ++k) {
    if (!pose_dirty_[k]) continue;
    pose_dirty_[k] = 0;
    --dirty_count_;
    update->keyframes.push_back(static_cast<std::uint32_t>(k));
    update->T_map_sensor.push_back(mapper_.pose(k));
    update->no_descriptor.push_back(mapper_.descriptor_valid(k) ? 0 : 1);
    RememberSent(k);
    last_sent_us_[k] = utime_us;
    dirty_scan_from_ = k + 1;
  }
  if (dirty_count_ == 0) dirty_scan_from_ = pose_dirty_.size();
  update->sequence = pose_sequence_++;
  return true;
}

bool RobotAgent::TakeRequestPoses(const ScanRequest& request, std::int64_t utime_us, PoseUpdate* poses,
                                  bool remember_poses) {
  poses->utime_us = utime_us;
  poses->robot_id = robot_id_;
  poses->session = session_;
  poses->keyframes.clear();
  poses->T_map_sensor.clear();
  poses->no_descriptor.clear();
  for (std::uint32_t k : request.keyframes) {
    if (k >= sent_upto_ || poses->keyframes.size() >= kMaxPosesPerUpdate) continue;
    if (remember_poses) scan_requested_[k] = 1;
    if (!MovedSinceSent(k, params_.request_pose_min_translation_m, params_.request_pose_min_rotation_deg)) continue;
    poses->keyframes.push_back(k);
    poses->T_map_sensor.push_back(mapper_.pose(k));
    poses->no_descriptor.push_back(mapper_.descriptor_valid(k) ? 0 : 1);
    if (!remember_poses) continue;
    RememberSent(k);
    last_sent_us_[k] = utime_us;
    if (pose_dirty_[k]) {  // sent now: no longer pending for the stream
      pose_dirty_[k] = 0;
      --dirty_count_;
    }
  }
  if (poses->keyframes.empty()) return false;
  poses->sequence = pose_sequence_++;
  return true;
}

Status RobotAgent::MakeScanChunk(std::uint32_t k, std::uint16_t chunk_index, std::int32_t request_id,
                                 std::int64_t utime_us, ScanChunk* chunk, std::uint16_t* num_chunks) {
  if (!params_status_.ok()) return params_status_;
  if (encoded_keyframe_ != static_cast<std::int64_t>(k)) {
    encoded_keyframe_ = -1;
    if (Status st = store_->CopyEncoded(k, &encoded_); !st.ok()) return st;
    encoded_keyframe_ = k;
    NoteMemory();
  }
  const std::size_t total = encoded_.size();
  const std::uint64_t count = ScanChunkCount(total, params_.chunk_payload_bytes);
  if (count > kMaxChunksPerScan) {
    return ResourceExhausted("keyframe " + std::to_string(k) + ": " + std::to_string(total) +
                             " encoded bytes need more than " + std::to_string(kMaxChunksPerScan) + " chunks");
  }
  *num_chunks = static_cast<std::uint16_t>(count);
  if (chunk_index >= count) {
    return InvalidArgument("keyframe " + std::to_string(k) + " has " + std::to_string(count) + " chunks, not chunk " +
                      std::to_string(chunk_index));
  }
  chunk->utime_us = utime_us;
  chunk->robot_id = robot_id_;
  chunk->request_id = request_id;
  chunk->keyframe = k;
  chunk->total_bytes = static_cast<std::uint32_t>(total);
  chunk->chunk_index = chunk_index;
  chunk->num_chunks = static_cast<std::uint16_t>(count);
  const ChunkRange range = ScanChunkRange(total, count, chunk_index);
  chunk->payload.assign(encoded_.begin() + static_cast<std::ptrdiff_t>(range.offset),
                        encoded_.begin() + static_cast<std::ptrdiff_t>(range.offset + range.size));
  return Status::Ok();
}

Result<ScanAnswer> RobotAgent::AnswerRequest(const ScanRequest& request, std::int64_t utime_us,
                                             std::vector<ScanChunk>* chunks, PoseUpdate* poses,
                                             bool remember_poses) {
  if (!params_status_.ok()) return params_status_;
  if (request.robot_id != robot_id_) {
    return InvalidArgument("scan request for robot " + std::to_string(request.robot_id) + " reached robot " +
                           std::to_string(robot_id_));
  }
  ScanAnswer answer;
  TakeRequestPoses(request, utime_us, poses, remember_poses);
  for (std::uint32_t k : request.keyframes) {
    ScanChunk chunk;
    std::uint16_t num_chunks = 0;
    if (Status st = MakeScanChunk(k, 0, request.request_id, utime_us, &chunk, &num_chunks); !st.ok()) {
      answer.missing.push_back(k);
      continue;
    }
    answer.scan_bytes += chunk.total_bytes;
    chunks->push_back(std::move(chunk));
    for (std::uint16_t c = 1; c < num_chunks; ++c) {
      chunks->emplace_back();
      (void)MakeScanChunk(k, c, request.request_id, utime_us, &chunks->back(), &num_chunks);
    }
    answer.chunks += num_chunks;
    ++answer.scans_sent;
  }
  return answer;
}

}  // namespace commerge
