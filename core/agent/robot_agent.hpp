// SPDX-License-Identifier: BSD-3-Clause
// commerge: the robot as a transport-free agent. It feeds scans to the RobotMapper (keyframes, SOLiD, scan
// store, loop closure) and keeps an outbox of what the server must learn: new keyframes (descriptor + pose
// records, in batches) and poses that changed after they were sent. It answers the server's scan requests
// with the stored encoded scans cut into chunks. The caller moves messages between agents (LCM, memq, or
// direct calls in tests) and counts their bytes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/agent/messages.hpp"
#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/descriptor/compact_batch_codec.hpp"
#include "core/slam/robot_mapper.hpp"
#include "core/slam/scan_store.hpp"

namespace commerge {

/// Bits per descriptor value of the compact keyframe batch by default (core/agent/decisions/ says why).
constexpr int kDefaultRecordDescriptorBits = 8;

struct RobotAgentParams {
  RobotMapperParams mapper;
  /// Records per keyframe batch (1..kMaxRecordsPerBatch).
  std::size_t max_records_per_batch = 256;
  /// Keyframes of a 40-value descriptor (SOLiD, ring occupancy) travel as compact batches with this many bits per
  /// descriptor value (kCompactMinDescriptorBits..kCompactMaxDescriptorBits; core/descriptor/compact_batch_codec.hpp),
  /// or as 92-byte records (0). Scan Context keeps its own record.
  int record_descriptor_bits = kDefaultRecordDescriptorBits;
  /// Poses per pose update (1..kMaxPosesPerUpdate).
  std::size_t max_poses_per_update = 1024;
  /// Payload bytes per scan chunk (1..kMaxScanChunkPayloadBytes): a chunk stays inside one UDP datagram.
  std::size_t chunk_payload_bytes = kMaxScanChunkPayloadBytes;
  /// A keyframe the optimisation moved is streamed again only when its pose differs from the one the server
  /// has by more than this. The server's positions of keyframes whose scans it does not hold feed the cascade's
  /// geometry (stage C's tau_con 5 m, the place checks' 8 m, the descriptor agreement's 3 m), which this error
  /// does not change; loop closures move every pose a little, and at 0.5 m / 1 deg the moves of a 10 000-keyframe
  /// patrol cost more than its scans.
  double pose_update_min_translation_m = 1.0;
  double pose_update_min_rotation_deg = 2.0;
  /// The same for keyframes whose scans the server requested: it places those scans (submaps, the merged map)
  /// and registers its verified overlaps again when they move (core/agent/pair_exchange.hpp).
  double scan_pose_min_translation_m = 0.1;
  double scan_pose_min_rotation_deg = 0.2;
  /// The scans the server requests are preceded by a pose update of those keyframes whose pose differs from
  /// the server's by more than this: the submaps are built with current poses.
  double request_pose_min_translation_m = 0.01;
  double request_pose_min_rotation_deg = 0.05;
};

Status ValidateRobotAgentParams(const RobotAgentParams& params);

/// What a scan request produced.
struct ScanAnswer {
  std::size_t scans_sent = 0;
  std::size_t chunks = 0;
  std::uint64_t scan_bytes = 0;              ///< encoded scan bytes (chunk payloads)
  std::vector<std::uint32_t> missing;        ///< requested keyframes whose scan the robot no longer has
};

class RobotAgent {
 public:
  /// `descriptor` must produce the values its record carries (RecordKindOf: 40 for SOLiD and the ring descriptor,
  /// 20 x 60 for Scan Context); `descriptor` and `store` are not owned.
  RobotAgent(int robot_id, const RobotAgentParams& params, const RobotMapperCapacity& capacity,
             PlaceDescriptor* descriptor, ScanStore* store);

  /// One scan with its odometry pose (see RobotMapper::AddScan). Poses moved by an optimisation are queued
  /// for a pose update when their keyframe was already sent.
  Result<KeyframeStep> AddScan(Span<const PointXYZI> raw_scan, const Eigen::Isometry3d& T_odom_sensor);

  /// End of the mission: optimises pending loops (their moved poses are queued as above).
  Status Finish();

  /// Fills `*batch` with the next unsent keyframes that have a valid descriptor (poses of keyframes without one
  /// are queued for a pose update), encoded with the current poses. False when there is nothing to send.
  Result<bool> TakeKeyframeBatch(std::int64_t utime_us, KeyframeBatch* batch);

  /// Fills `*update` with queued poses (ascending keyframes). False when none is queued.
  bool TakePoseUpdate(std::int64_t utime_us, PoseUpdate* update);

  // ---- Reliable delivery (driven by RobotLink from the server's transfer status) ----
  /// Session id put into every batch and pose update (default 1; a robot process uses its start time [us]).
  void set_session(std::int64_t session) noexcept { session_ = session; }
  std::int64_t session() const noexcept { return session_; }
  /// Announces keyframe `k` again: its record (current pose) in the next batches, or its pose when it has no valid
  /// descriptor. Keyframes not yet sent, or already queued, are left alone.
  void RequeueKeyframe(std::size_t k);
  /// Announces every keyframe sent so far again (the server lost its state).
  void RequeueAllSent();
  /// Sends the current poses of these sent keyframes again (a pose update was lost).
  void RequeuePoses(Span<const std::uint32_t> keyframes);
  /// utime_us of the last batch or pose update that carried keyframe k (-1: never).
  std::int64_t last_sent_us(std::size_t k) const { return k < last_sent_us_.size() ? last_sent_us_[k] : -1; }
  std::size_t queued_resends() const noexcept { return resend_count_; }
  std::size_t queued_poses() const noexcept { return dirty_count_; }
  /// Keyframes waiting for their first batch.
  std::size_t unsent_keyframes() const noexcept { return mapper_.num_keyframes() - sent_upto_; }

  /// The pose update that precedes a scan request's chunks (see AnswerRequest); false when no requested pose moved.
  bool TakeRequestPoses(const ScanRequest& request, std::int64_t utime_us, PoseUpdate* poses, bool remember_poses);
  /// Chunk `chunk_index` of keyframe k's stored scan for `request_id`; `*num_chunks` = the scan's chunk count.
  /// NotFound when the store no longer has the scan, InvalidArgument when chunk_index >= the count.
  Status MakeScanChunk(std::uint32_t k, std::uint16_t chunk_index, std::int32_t request_id, std::int64_t utime_us,
                       ScanChunk* chunk, std::uint16_t* num_chunks);

  /// Appends the chunks of every requested scan to `*chunks`, and fills `*poses` with the requested keyframes
  /// whose pose moved since the server got it (request_pose_min_...; send it before the chunks; empty when
  /// none moved). Requests for another robot are an error (InvalidArgument); keyframes the store no longer has
  /// are listed in ScanAnswer::missing.
  /// `remember_poses` = false leaves the record of what the server has unchanged (offline comparisons answer
  /// the same data once per exchange mode, each as if it were the only one).
  Result<ScanAnswer> AnswerRequest(const ScanRequest& request, std::int64_t utime_us, std::vector<ScanChunk>* chunks,
                                   PoseUpdate* poses, bool remember_poses = true);

  int robot_id() const noexcept { return robot_id_; }
  const RobotAgentParams& params() const noexcept { return params_; }
  const RobotMapper& mapper() const noexcept { return mapper_; }
  const ScanStore& store() const noexcept { return *store_; }
  /// Keyframes already put into batches (or queued as poses).
  std::size_t keyframes_sent() const noexcept { return sent_upto_; }

  /// Memory of the robot's budget modules (core/memory/budget.hpp), named and ordered as in its budget table:
  /// descriptor_db, pose_graph, scan_store, scan_workspace, loop_closure, outbox (budget_bytes 0: the caller's
  /// table has them; `runtime` is not measured here: it is the process's peak RSS minus these pools).
  /// used_bytes: pools reserved at construction for max_keyframes count the elements in use (pages of the unused
  /// rest are never touched): descriptor database keyframes x (dimension x 4 + 1) B, pose graph nodes x
  /// sizeof(Isometry3d) + edges x sizeof(PoseGraphEdge) + its solver workspace, scan store live records with their
  /// headers (ScanStoreStats). Buffers that grow on demand and are kept between calls count capacity x element
  /// size: the per-scan buffers, the loop-closure buffers (decoded match scan, k-d tree, ICP scratch), and the
  /// outbox (per-keyframe send bookkeeping, the scan being chunked).
  /// high_water_bytes: the largest used_bytes at the end of any AddScan, Finish, scan chunk or MemoryUse call
  /// (for scan_store: the store's own mark, updated on every Put).
  std::vector<ModuleMemory> MemoryUse() const;

 private:
  static constexpr std::size_t kMemoryModules = 6;
  std::array<std::int64_t, kMemoryModules> MeasureMemory() const;
  void NoteMemory() const;

  void QueuePoses(Span<const std::uint32_t> keyframes);
  void MarkPoseDirty(std::size_t k);
  Status AppendRecord(std::size_t k, std::int64_t utime_us, KeyframeBatch* batch);
  // Codes a compact batch's keyframes and numbers the batch.
  Result<bool> FinishBatch(KeyframeBatch* batch);
  void RememberSent(std::size_t keyframe);
  bool MovedSinceSent(std::size_t keyframe, double min_translation_m, double min_rotation_deg) const;
  /// MovedSinceSent with the stream's thresholds for this keyframe (pose_update_min_... or scan_pose_min_...).
  bool StreamPoseStale(std::size_t keyframe) const;

  int robot_id_;
  KeyframeRecordKind record_kind_ = KeyframeRecordKind::kUnit40;  ///< of the descriptor given at construction
  std::vector<CompactKeyframe> compact_;  ///< the compact batch being built (reserved for a whole batch)
  RobotAgentParams params_;
  Status params_status_;
  ScanStore* store_;
  RobotMapper mapper_;
  std::size_t sent_upto_ = 0;
  std::int32_t batch_sequence_ = 0, pose_sequence_ = 0;
  std::int64_t session_ = 1;
  std::vector<std::uint8_t> resend_;      ///< per keyframe: its record is queued again
  std::size_t resend_count_ = 0;
  std::size_t resend_from_ = 0;           ///< no resend flag below this keyframe
  std::vector<std::int64_t> last_sent_us_;
  std::int64_t encoded_keyframe_ = -1;    ///< the keyframe whose scan encoded_ holds (MakeScanChunk)
  std::vector<std::uint8_t> pose_dirty_;  ///< per keyframe (capacity max_keyframes)
  std::vector<std::uint8_t> scan_requested_;  ///< per keyframe: the server requested its scan
  /// The pose the server has of each sent keyframe: translation [m] and quaternion (w, x, y, z).
  std::vector<std::array<float, 7>> sent_pose_;
  std::size_t dirty_count_ = 0;
  std::size_t dirty_scan_from_ = 0;       ///< no dirty flag below this keyframe
  std::vector<std::uint8_t> encoded_;
  mutable ModuleHighWater<kMemoryModules> memory_high_water_;
};

}  // namespace commerge
