// SPDX-License-Identifier: BSD-3-Clause
#include "core/agent/keyframe_database.hpp"

#include <algorithm>
#include <string>
#include <utility>

#include "core/agent/server_rejection.hpp"
#include "core/descriptor/compact_batch_codec.hpp"
#include "core/geometry/se3.hpp"
#include "core/memory/budget.hpp"

namespace commerge {

static_assert(kMaxRecordsPerBatch * sizeof(CompactKeyframe) <= BudgetRecordSizes::kCompactBatchScratchBytes,
              "the descriptor_db budget counts one decoded compact batch");

bool DescriptorIdsConflict(std::uint32_t a, std::uint32_t b) noexcept { return a != 0 && b != 0 && a != b; }

Result<KeyframeDatabase> KeyframeDatabase::Create(int max_robots, std::size_t max_keyframes_per_robot,
                                                  KeyframeRecordKind kind) {
  if (max_robots < 2 || max_robots > kMaxRobotId + 1) {
    return InvalidArgument("max_robots = " + std::to_string(max_robots) + " is outside 2.." +
                           std::to_string(kMaxRobotId + 1));
  }
  if (max_keyframes_per_robot < 1 || max_keyframes_per_robot > (1u << 31)) {
    return InvalidArgument("max_keyframes_per_robot = " + std::to_string(max_keyframes_per_robot) +
                           " is outside 1..2^31");
  }
  if (KeyframeRecordDimOf(kind) == 0 || KeyframeRecordBytesOf(kind) == 0) {  // kCompact40 is held as kUnit40
    return InvalidArgument("record_kind " + std::to_string(static_cast<int>(kind)) +
                           " is not a kind of held records (unit-40, scan-context)");
  }
  KeyframeDatabase db;
  db.kind_ = kind;
  db.max_keyframes_ = max_keyframes_per_robot;
  db.robots_.resize(static_cast<std::size_t>(max_robots));
  for (RobotKeyframeDb& r : db.robots_) r.dim = KeyframeRecordDimOf(kind);
  db.record_descriptor_.resize(KeyframeRecordDimOf(kind));
  if (kind == KeyframeRecordKind::kUnit40) db.compact_.reserve(kMaxRecordsPerBatch);  // at start-up, not per batch
  return db;
}

namespace {

bool IsFiniteKeyframePose(const Eigen::Isometry3d& T) { return T.matrix().allFinite(); }

std::string DescriptorIdHex(std::uint32_t id) {
  static const char kDigits[] = "0123456789ABCDEF";
  std::string text = "0x00000000";
  for (int i = 0; i < 8; ++i) text[static_cast<std::size_t>(9 - i)] = kDigits[(id >> (4 * i)) & 0xFu];
  return text;
}

}  // namespace

Status KeyframeDatabase::CapacityError(int robot, std::uint32_t keyframe) const {
  return ResourceExhausted(ServerRobotText(robot) + " keyframe " + std::to_string(keyframe) +
                           " is beyond the server's capacity of " + std::to_string(max_keyframes_) +
                           " keyframes per robot (--max-keyframes)");
}

Status KeyframeDatabase::EnsureKeyframe(int robot, std::uint32_t keyframe) {
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

Status KeyframeDatabase::DescriptorIdError(const KeyframeBatch& batch) const {
  const std::uint32_t held = robots_[static_cast<std::size_t>(batch.robot_id)].descriptor_id;
  if (!DescriptorIdsConflict(held, batch.descriptor_id)) return Status::Ok();
  return InvalidArgument("keyframe batch " + std::to_string(batch.sequence) + " of " + ServerRobotText(batch.robot_id) +
                         ": descriptor parameter id " + DescriptorIdHex(batch.descriptor_id) + " differs from " + DescriptorIdHex(held) +
                         " of its earlier batches in this session");
}

Status KeyframeDatabase::RecordKindError(const KeyframeBatch& batch) const {
  if (HeldRecordKind(batch.record_kind) == kind_) return Status::Ok();
  return InvalidArgument("keyframe batch " + std::to_string(batch.sequence) + " of " + ServerRobotText(batch.robot_id) +
                         " carries " + KeyframeRecordKindName(batch.record_kind) + " records; this server takes " +
                         KeyframeRecordKindName(kind_) +
                         " records (start the robots and the server with the same --descriptor)");
}

Status KeyframeDatabase::CheckKeyframeBatch(const KeyframeBatch& batch) const {
  if (batch.robot_id < 0 || batch.robot_id >= max_robots()) {
    return InvalidArgument("keyframe batch: robot_id " + std::to_string(batch.robot_id) + " is outside 0.." +
                           std::to_string(max_robots() - 1));
  }
  if (Status st = RecordKindError(batch); !st.ok()) return st;
  const std::size_t n = batch.num_records();
  if (!batch.RecordArraysConsistent()) {
    return InvalidArgument("keyframe batch of " + ServerRobotText(batch.robot_id) + ": malformed record arrays");
  }
  std::vector<CompactKeyframe> compact;
  if (batch.record_kind == KeyframeRecordKind::kCompact40) {
    if (Status st = DecodeCompactBatch(Span<const std::uint8_t>(batch.records), n, &compact); !st.ok()) return st;
  }
  Status first_error = InvalidArgument("keyframe batch of " + ServerRobotText(batch.robot_id) + " has no record");
  std::vector<float> descriptor(KeyframeRecordDimOf(kind_));
  for (std::size_t i = 0; i < n; ++i) {
    auto record = DecodeBatchRecord(batch, compact, i, Span<float>(descriptor));
    if (record.ok() && record->keyframe_index < max_keyframes_) return Status::Ok();
    if (i == 0) first_error = record.ok() ? CapacityError(batch.robot_id, record->keyframe_index) : record.status();
  }
  return first_error;
}

Result<KeyframePose> KeyframeDatabase::DecodeBatchRecord(const KeyframeBatch& batch,
                                                         const std::vector<CompactKeyframe>& compact, std::size_t i,
                                                         Span<float> descriptor) const {
  if (batch.record_kind == KeyframeRecordKind::kCompact40) {
    std::copy(compact[i].descriptor.begin(), compact[i].descriptor.end(), descriptor.begin());
    return compact[i].pose;
  }
  const std::size_t bytes = KeyframeRecordBytesOf(kind_);
  return DecodeRecordOfKind(kind_, Span<const std::uint8_t>(batch.records.data() + i * bytes, bytes), descriptor);
}

Status KeyframeDatabase::OnKeyframeBatch(const KeyframeBatch& batch, MergeServerStats* stats) {
  if (batch.robot_id < 0 || batch.robot_id >= max_robots()) {
    return CountRejection(stats, &stats->rejected_batches, InvalidArgument("keyframe batch: robot_id " + std::to_string(batch.robot_id) +
                                                            " is outside 0.." + std::to_string(max_robots() - 1)));
  }
  if (Status st = RecordKindError(batch); !st.ok()) return CountRejection(stats, &stats->rejected_batches, st);
  const std::size_t n = batch.num_records(), bytes = KeyframeRecordBytesOf(batch.record_kind);
  if (!batch.RecordArraysConsistent()) {
    const std::string shape = bytes == 0 ? "a compact batch of 1.." + std::to_string(kMaxRecordsPerBatch) +
                                               " records in 1.." + std::to_string(kMaxCompactBatchBytes) + " bytes"
                                         : "1.." + std::to_string(kMaxRecordsPerBatch) + " records of " +
                                               std::to_string(bytes) + " bytes";
    return CountRejection(stats, &stats->rejected_batches,
                  InvalidArgument("keyframe batch of " + ServerRobotText(batch.robot_id) + ": " +
                                  std::to_string(batch.records.size()) + " record bytes, " +
                                  std::to_string(batch.stored_points.size()) + " point counts and " +
                                  std::to_string(batch.num_compact_records) +
                                  " compact records do not describe " + shape));
  }
  if (Status st = DescriptorIdError(batch); !st.ok()) return CountRejection(stats, &stats->rejected_batches, st);
  if (batch.record_kind == KeyframeRecordKind::kCompact40) {
    if (Status st = DecodeCompactBatch(Span<const std::uint8_t>(batch.records), n, &compact_); !st.ok()) {
      return CountRejection(stats, &stats->rejected_batches,
                            Status(st.code(), "keyframe batch " + std::to_string(batch.sequence) + " of " +
                                                  ServerRobotText(batch.robot_id) + ": " + st.message()));
    }
  }
  ++stats->batches;
  Status first_error;
  for (std::size_t i = 0; i < n; ++i) {
    auto record = DecodeBatchRecord(batch, compact_, i, Span<float>(record_descriptor_));
    Status st = record.ok() ? EnsureKeyframe(batch.robot_id, record->keyframe_index) : record.status();
    if (!st.ok()) {
      Status named(st.code(), "keyframe batch " + std::to_string(batch.sequence) + " of " + ServerRobotText(batch.robot_id) +
                                  ", record " + std::to_string(i) + ": " + st.message());
      CountRejection(stats, &stats->rejected_records, named);
      if (first_error.ok()) first_error = named;
      continue;
    }
    RobotKeyframeDb& db = robots_[static_cast<std::size_t>(batch.robot_id)];
    const std::size_t k = record->keyframe_index;
    if (db.valid[k]) ++stats->records_repeated;
    std::copy(record_descriptor_.begin(), record_descriptor_.end(),
              db.descriptors.begin() + static_cast<std::ptrdiff_t>(k * db.dim));
    db.valid[k] = 1;
    db.pose_known[k] = 1;
    db.T_map_sensor[k] = record->T_map_sensor;
    db.stored_points[k] = batch.record_kind == KeyframeRecordKind::kCompact40 ? compact_[i].stored_points
                                                                              : batch.stored_points[i];
    // The robot's id is the one of its first batch that delivered a record.
    if (db.descriptor_id == 0) db.descriptor_id = batch.descriptor_id;
    ++stats->records;
  }
  return first_error;
}

Status KeyframeDatabase::CheckPoseUpdate(const PoseUpdate& update) const {
  if (update.robot_id < 0 || update.robot_id >= max_robots()) {
    return InvalidArgument("pose update: robot_id " + std::to_string(update.robot_id) + " is outside 0.." +
                           std::to_string(max_robots() - 1));
  }
  if (update.keyframes.size() != update.T_map_sensor.size() || update.keyframes.size() > kMaxPosesPerUpdate ||
      (!update.no_descriptor.empty() && update.no_descriptor.size() != update.keyframes.size())) {
    return InvalidArgument("pose update of " + ServerRobotText(update.robot_id) + ": " +
                           std::to_string(update.keyframes.size()) + " keyframes but " +
                           std::to_string(update.T_map_sensor.size()) + " poses and " +
                           std::to_string(update.no_descriptor.size()) + " descriptor flags (at most " +
                           std::to_string(kMaxPosesPerUpdate) + ")");
  }
  for (std::size_t i = 0; i < update.keyframes.size(); ++i) {
    if (!IsFiniteKeyframePose(update.T_map_sensor[i]) || !IsValidRigidTransform(update.T_map_sensor[i], 1e-3)) {
      return InvalidArgument("pose update " + std::to_string(update.sequence) + " of " + ServerRobotText(update.robot_id) +
                             ": keyframe " + std::to_string(update.keyframes[i]) + " has a non-finite or non-rigid pose");
    }
    if (update.keyframes[i] >= max_keyframes_) return CapacityError(update.robot_id, update.keyframes[i]);
  }
  return Status::Ok();
}

Status KeyframeDatabase::OnPoseUpdate(const PoseUpdate& update, MergeServerStats* stats) {
  // Validate everything first: a refused update changes nothing.
  if (Status st = CheckPoseUpdate(update); !st.ok()) {
    return CountRejection(stats, &stats->rejected_pose_updates, st);
  }
  for (std::size_t i = 0; i < update.keyframes.size(); ++i) {
    const std::uint32_t k = update.keyframes[i];
    (void)EnsureKeyframe(update.robot_id, k);
    RobotKeyframeDb& db = robots_[static_cast<std::size_t>(update.robot_id)];
    db.T_map_sensor[k] = update.T_map_sensor[i];
    db.pose_known[k] = 1;
    if (!update.no_descriptor.empty() && update.no_descriptor[i]) db.no_descriptor[k] = 1;
  }
  ++stats->pose_updates;
  return Status::Ok();
}

void KeyframeDatabase::ResetRobot(int robot) {
  if (robot < 0 || robot >= max_robots()) return;
  robots_[static_cast<std::size_t>(robot)] = RobotKeyframeDb();
  robots_[static_cast<std::size_t>(robot)].dim = KeyframeRecordDimOf(kind_);
}

std::vector<std::uint32_t> KeyframeDatabase::StoredKeyframes(int robot) const {
  std::vector<std::uint32_t> out;
  const RobotKeyframeDb& db = robots_[static_cast<std::size_t>(robot)];
  for (std::size_t k = 0; k < db.size(); ++k) {
    if (db.stored_points[k] > 0 || db.pose_known[k]) out.push_back(static_cast<std::uint32_t>(k));
  }
  return out;
}

std::size_t KeyframeDatabase::MemoryBytes() const {
  const auto held = [](const auto& v) { return v.capacity() * sizeof(v[0]); };
  std::size_t bytes = held(robots_);
  for (const RobotKeyframeDb& db : robots_) {
    bytes += held(db.descriptors) + held(db.valid) + held(db.pose_known) + held(db.no_descriptor) +
             held(db.T_map_sensor) + held(db.stored_points);
  }
  return bytes + held(record_descriptor_) + held(compact_);
}

}  // namespace commerge
