// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's keyframe database (budget module "descriptor_db"): each robot's descriptors and poses,
// from keyframe batches and pose updates, and the descriptor parameter id its batches carry. A malformed or
// foreign message is refused with a Status naming the field and counted; it never changes the state.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <Eigen/Geometry>

#include "core/agent/merge_server_params.hpp"
#include "core/agent/messages.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/compact_batch_codec.hpp"

namespace commerge {

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

/// Two descriptor parameter ids that are both known and differ: the robots' descriptors are not comparable.
bool DescriptorIdsConflict(std::uint32_t a, std::uint32_t b) noexcept;

class KeyframeDatabase {
 public:
  /// Empty: no robot (every message is refused as out of range).
  KeyframeDatabase() = default;
  /// Robots 0..max_robots-1 (2..kMaxRobotId + 1), at most max_keyframes_per_robot (1..2^31) keyframes each, records
  /// of `kind`. InvalidArgument naming the value otherwise.
  static Result<KeyframeDatabase> Create(int max_robots, std::size_t max_keyframes_per_robot, KeyframeRecordKind kind);

  /// OK when OnKeyframeBatch would apply at least one record (for a robot reset by ResetRobot: the batch's
  /// descriptor id is not held against the robot's earlier batches); nothing is counted or applied.
  Status CheckKeyframeBatch(const KeyframeBatch& batch) const;
  /// OK when OnPoseUpdate would accept the update.
  Status CheckPoseUpdate(const PoseUpdate& update) const;
  /// Applies the batch's records; refusals are counted in *stats (a refused record does not refuse the others; the
  /// first refusal is returned).
  Status OnKeyframeBatch(const KeyframeBatch& batch, MergeServerStats* stats);
  /// Applies the whole update or nothing.
  Status OnPoseUpdate(const PoseUpdate& update, MergeServerStats* stats);
  /// Forgets one robot's keyframes.
  void ResetRobot(int robot);

  int max_robots() const noexcept { return static_cast<int>(robots_.size()); }
  std::size_t max_keyframes_per_robot() const noexcept { return max_keyframes_; }
  const RobotKeyframeDb& robot(int r) const { return robots_[static_cast<std::size_t>(r)]; }
  /// The keyframes of `robot` that have a stored scan (or a known pose): what send-all asks for.
  std::vector<std::uint32_t> StoredKeyframes(int robot) const;
  /// Bytes held (capacity x element size of every container).
  std::size_t MemoryBytes() const;

 private:
  // InvalidArgument when the batch's descriptor id conflicts with the one its robot's earlier batches set.
  Status DescriptorIdError(const KeyframeBatch& batch) const;
  // InvalidArgument when the batch's records are not of the kind this database takes.
  Status RecordKindError(const KeyframeBatch& batch) const;
  Status CapacityError(int robot, std::uint32_t keyframe) const;
  Status EnsureKeyframe(int robot, std::uint32_t keyframe);
  // Record i of `batch` (of a consistent size; `compact`: the batch decoded when it is a compact one).
  Result<KeyframePose> DecodeBatchRecord(const KeyframeBatch& batch, const std::vector<CompactKeyframe>& compact,
                                         std::size_t i, Span<float> descriptor) const;

  KeyframeRecordKind kind_ = KeyframeRecordKind::kUnit40;
  std::size_t max_keyframes_ = 0;
  std::vector<RobotKeyframeDb> robots_;
  std::vector<float> record_descriptor_;  ///< one decoded record's descriptor
  std::vector<CompactKeyframe> compact_;  ///< the compact batch being applied, decoded
};

}  // namespace commerge
