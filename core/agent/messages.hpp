// SPDX-License-Identifier: BSD-3-Clause
// commerge: the robot <-> server messages as plain structs (the agents' input and output). platform/lcm encodes
// them as the LCM types of lcmtypes/ (keyframe_batch_t, pose_update_t, exchange_policy_t, scan_chunk_t,
// transfer_status_t, merge_result_t, merge_round_t, robot_status_t, server_status_t), field for field; the
// limits below are the types' MAX_... constants, enforced on both sides.
//
// Sessions: a robot process picks a session id when it starts (its start time in microseconds), and so does the
// server. A keyframe database belongs to one robot session; a newer session of the same robot id (the robot
// restarted and maps from scratch) replaces it, an older one is stale and refused. A robot that sees a new server
// session learns that the server lost everything and announces its keyframes again.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "core/descriptor/descriptor_codec.hpp"

namespace commerge {

inline constexpr int kMaxRobotId = 63;
inline constexpr std::size_t kMaxRecordsPerBatch = 512;
inline constexpr std::size_t kMaxPosesPerUpdate = 4096;
inline constexpr std::size_t kMaxKeyframesPerRequest = 65536;
inline constexpr std::size_t kMaxScanChunkPayloadBytes = 1200;
/// A scan is cut into at most this many chunks (int16 on the wire): 39 MB, far above any 1 m scan.
inline constexpr std::size_t kMaxChunksPerScan = 32767;
/// transfer_status_t limits: keyframe gaps, recently received pose-update sequences, missing chunk ranges.
inline constexpr std::size_t kMaxStatusGaps = 256;
inline constexpr std::size_t kMaxStatusPoseAcks = 64;
inline constexpr std::size_t kMaxStatusMissingRanges = 1024;
/// merge_result_t limits: robots and robot pairs (64 robots: 64 x 63 / 2 pairs).
inline constexpr std::size_t kMaxMergeRobots = kMaxRobotId + 1;
inline constexpr std::size_t kMaxMergePairs = kMaxMergeRobots * (kMaxMergeRobots - 1) / 2;
/// robot_status_t / server_status_t: budget modules, and the length of every string field.
inline constexpr std::size_t kMaxStatusModules = 32;
inline constexpr std::size_t kMaxStatusTextBytes = 256;

/// Bytes [offset, offset + size) of a scan of `total_bytes` that chunk `index` of `num_chunks` carries: every
/// chunk holds ceil(total / num_chunks) bytes except the last, which holds the rest. Sender and receiver both
/// use this, so a chunk's payload size is checkable on arrival.
struct ChunkRange {
  std::uint64_t offset = 0;
  std::uint64_t size = 0;
};
inline ChunkRange ScanChunkRange(std::uint64_t total_bytes, std::uint64_t num_chunks, std::uint64_t index) noexcept {
  if (num_chunks == 0 || index >= num_chunks) return {};
  const std::uint64_t per = (total_bytes + num_chunks - 1) / num_chunks;
  const std::uint64_t begin = index * per < total_bytes ? index * per : total_bytes;
  const std::uint64_t end = begin + per < total_bytes ? begin + per : total_bytes;
  return {begin, end - begin};
}
/// Chunks a scan of `total_bytes` is cut into when a chunk carries at most `max_payload` bytes (>= 1).
inline std::uint64_t ScanChunkCount(std::uint64_t total_bytes, std::uint64_t max_payload) noexcept {
  return total_bytes == 0 ? 1 : (total_bytes + max_payload - 1) / max_payload;
}

/// New keyframes of one robot (robot -> server).
struct KeyframeBatch {
  std::int64_t utime_us = 0;
  int robot_id = 0;
  std::int64_t session = 0;  ///< the robot process's session id (> 0)
  std::int32_t sequence = 0;
  /// What the records carry: num_records x KeyframeRecordBytesOf(record_kind) bytes of descriptor_codec records,
  /// or for kCompact40 one compact batch (compact_batch_codec.hpp).
  KeyframeRecordKind record_kind = KeyframeRecordKind::kUnit40;
  std::vector<std::uint8_t> records;
  /// Points of each keyframe's stored scan (0 = not stored), one per record; empty for kCompact40, whose stream
  /// carries the counts.
  std::vector<std::uint32_t> stored_points;
  /// kCompact40 only: the keyframes coded in `records` (the stream does not hold its own count).
  std::size_t num_compact_records = 0;
  /// PlaceDescriptor::parameter_id() of the records' descriptors: only descriptors of one id are comparable.
  std::uint32_t descriptor_id = 0;
  /// Records of a fixed-size kind: records.size() / the record size; of kCompact40: num_compact_records.
  std::size_t num_records() const noexcept {
    if (record_kind == KeyframeRecordKind::kCompact40) return num_compact_records;
    const std::size_t bytes = KeyframeRecordBytesOf(record_kind);
    return bytes == 0 ? 0 : records.size() / bytes;
  }
  /// records and stored_points describe at most kMaxRecordsPerBatch records of record_kind (sizes only; a
  /// compact batch holds at least one record in 1..kMaxCompactBatchBytes bytes and no separate point count).
  bool RecordArraysConsistent() const noexcept {
    const std::size_t n = num_records();
    if (n > kMaxRecordsPerBatch) return false;
    if (record_kind == KeyframeRecordKind::kCompact40) {
      return n >= 1 && stored_points.empty() && !records.empty() && records.size() <= kMaxCompactBatchBytes;
    }
    return stored_points.size() == n && records.size() == n * KeyframeRecordBytesOf(record_kind);
  }
};

/// Poses moved by loop closure, and poses of keyframes without a valid descriptor (robot -> server).
struct PoseUpdate {
  std::int64_t utime_us = 0;
  int robot_id = 0;
  std::int64_t session = 0;  ///< the robot process's session id (> 0)
  std::int32_t sequence = 0;
  std::vector<std::uint32_t> keyframes;
  std::vector<Eigen::Isometry3d> T_map_sensor;  ///< one per keyframe, the robot's own map frame
  /// One per keyframe: 1 = the keyframe has no valid descriptor, so this pose is all the server gets of it (it
  /// counts as delivered); 0 = a moved pose of a keyframe whose record the server should have. Empty = all 0.
  std::vector<std::uint8_t> no_descriptor;
};

/// The exchange policy for one robot (server -> robot).
struct ScanRequest {
  std::int64_t utime_us = 0;
  int robot_id = 0;
  std::int64_t server_session = 0;  ///< the server process's session id
  std::int32_t request_id = 0;
  std::vector<std::uint32_t> keyframes;  ///< ascending, unique
};

/// One piece of one encoded scan (robot -> server).
struct ScanChunk {
  std::int64_t utime_us = 0;
  int robot_id = 0;
  std::int32_t request_id = -1;  ///< -1: unsolicited (the send-all baseline)
  std::uint32_t keyframe = 0;
  std::uint32_t total_bytes = 0;
  std::uint16_t chunk_index = 0;
  std::uint16_t num_chunks = 1;
  std::vector<std::uint8_t> payload;  ///< at most kMaxScanChunkPayloadBytes
};

/// Keyframes [begin, end) the server lacks.
struct KeyframeGap {
  std::uint32_t begin = 0, end = 0;
};

/// Chunks [first_chunk, first_chunk + count) of one requested scan the server lacks; count 0 = nothing of this
/// scan has arrived (the server does not know its chunk count yet): the whole scan.
struct MissingChunkRange {
  std::uint32_t keyframe = 0;
  std::uint16_t first_chunk = 0;
  std::uint16_t count = 0;
};

/// What the server holds of one robot (server -> robot, periodically): the acknowledgement that drives the
/// robot's re-announcements and selective retransmission.
struct TransferStatus {
  std::int64_t utime_us = 0;
  int robot_id = 0;
  std::int64_t server_session = 0;
  std::int64_t robot_session = 0;         ///< the session whose keyframes the server holds (0: none)
  std::uint32_t keyframes_contiguous = 0; ///< the server holds every keyframe below this
  std::uint32_t keyframes_seen = 0;       ///< 1 + the highest keyframe it holds (0: none)
  /// Keyframes in [keyframes_contiguous, keyframes_seen) it lacks: ascending, disjoint, at most kMaxStatusGaps
  /// (the lowest ones; gaps_truncated says there are more).
  std::vector<KeyframeGap> gaps;
  bool gaps_truncated = false;
  /// The most recent pose-update sequences received from robot_session (at most kMaxStatusPoseAcks).
  std::vector<std::int32_t> pose_sequences;
  std::int32_t request_id = -1;           ///< the robot's active scan request (-1: none)
  bool request_complete = false;          ///< every scan of it arrived (or the robot reported it missing)
  /// Of the active request, ascending by keyframe, at most kMaxStatusMissingRanges (the lowest ones).
  std::vector<MissingChunkRange> missing;
};

/// One solver stage of a pair's cascade as merge_result_t carries it (StageBOutcome / StageCOutcome).
struct StageSolverSummary {
  /// 0 = not reached, 1 = optimal, 2 = stopped by a node or time limit with a selection (gap), 3 = no selection
  /// (a limit before any, or infeasible).
  std::uint8_t status = 0;
  float gap = 0.0f;                 ///< relative gap in [0, 1]
  std::uint32_t nodes = 0;          ///< branch-and-bound nodes (saturated at 2^31 - 1 on the wire)
  std::uint32_t lp_solves = 0;      ///< LP relaxations solved
};
inline constexpr std::uint8_t kMaxStageSolverStatus = 3;

/// "B optimal, 3 nodes, 5 LPs", "C limit, gap 2.10 %, 2000000 nodes, 1 LP", "B no selection", "B not run".
std::string StageSolverText(const char* stage, const StageSolverSummary& summary);

/// One robot pair of a merge result.
struct MergePairOutcome {
  int alpha = 0, beta = 0;
  bool success = false;
  std::string verdict;                    ///< "success" or the failed gate / the reason it was not tried
  Eigen::Isometry3d T_alpha_beta = Eigen::Isometry3d::Identity();  ///< p_alpha = T p_beta (map frames)
  std::uint32_t loops_stage_a = 0, loops_stage_c = 0;  ///< |L_seq|, |L_K|
  std::uint32_t alpha_scans = 0, beta_scans = 0;       ///< received scans registered
  float overlap = 0.0f;                   ///< registration overlap ratio
  std::uint32_t inliers = 0;              ///< fine-stage inliers
  bool consistent = false;                ///< kept by the frame solver
  StageSolverSummary stage_b, stage_c;    ///< the cascade's solver stages
  std::uint32_t stage_c_loops_dropped = 0;  ///< loops beyond stage C's max_loops left out of its graph
};

/// The server's answer after a merge round (server -> everyone).
struct MergeResultMessage {
  std::int64_t utime_us = 0;
  std::int64_t server_session = 0;
  std::int32_t round = 0;                 ///< 1, 2, ... per server session
  std::vector<int> robot_ids;             ///< robots with keyframes at the server, ascending
  std::vector<std::uint8_t> in_world;     ///< per robot: 1 = connected to the world frame (robot 0's map)
  std::vector<Eigen::Isometry3d> T_world_map;  ///< per robot (identity when not in_world)
  std::vector<std::uint32_t> keyframes;   ///< per robot: its keyframes at the server when the round started
  std::vector<MergePairOutcome> pairs;
};

/// merge_round_t limits: scan requests of one round step, and their keyframes together.
inline constexpr std::size_t kMaxRoundRequests = 64;
inline constexpr std::size_t kMaxRoundKeyframes = 1u << 20;

/// What the server had taken of one robot when a round step ran: messages of this robot id handed to it, by
/// kind, over every session (merge_round_t).
struct RoundRobotInput {
  int robot_id = 0;
  std::int64_t session = 0;           ///< the robot's current session (0: none yet)
  std::uint32_t keyframe_batches = 0;
  std::uint32_t pose_updates = 0;
  std::uint32_t scan_chunks = 0;      ///< also chunks refused as stale
  /// FNV-1a over what identifies each of those messages, in the order taken (a batch's and a pose update's
  /// session and sequence, a chunk's request, keyframe and chunk index): equal counts of other messages differ.
  std::uint32_t digest = 2166136261u;
  bool left = false;                  ///< its status said "merged": asked for nothing more
  bool operator==(const RoundRobotInput& o) const {
    return robot_id == o.robot_id && session == o.session && keyframe_batches == o.keyframe_batches &&
           pose_updates == o.pose_updates && scan_chunks == o.scan_chunks && digest == o.digest && left == o.left;
  }
};

/// One step of a merge round (server -> everyone): step 0 began the round, step k >= 1 continued it. The data
/// it used (per robot, ascending by id) and the requests it sent, so a replay can cut its data exactly there
/// and check that it asks for the same scans.
struct RoundStep {
  std::int64_t utime_us = 0;
  std::int64_t server_session = 0;
  std::int32_t round = 0;             ///< 1, 2, ... per server session
  std::int32_t step = 0;
  bool finished = false;              ///< the round ended in this step
  std::vector<RoundRobotInput> robots;
  std::vector<ScanRequest> requests;  ///< robot_id, request_id and keyframes of each (utime, session unused)
};

/// Memory of one budget module (robot_status_t / server_status_t).
struct ModuleMemory {
  std::string name;
  std::int64_t budget_bytes = 0, used_bytes = 0, high_water_bytes = 0;
};

/// High-water marks of a fixed list of budget modules (RobotAgent, MergeServer): Note() raises each mark to what
/// is in use now; Report() also returns the named rows (budget_bytes 0: the caller's budget table has them).
template <std::size_t N>
struct ModuleHighWater {
  std::array<std::int64_t, N> marks{};
  void Note(const std::array<std::int64_t, N>& used) noexcept {
    for (std::size_t i = 0; i < N; ++i) marks[i] = std::max(marks[i], used[i]);
  }
  std::vector<ModuleMemory> Report(const char* const (&names)[N], const std::array<std::int64_t, N>& used) {
    Note(used);
    std::vector<ModuleMemory> out(N);
    for (std::size_t i = 0; i < N; ++i) {
      out[i].name = names[i];
      out[i].used_bytes = used[i];
      out[i].high_water_bytes = marks[i];
    }
    return out;
  }
};

/// Health of one robot process (robot -> everyone, about once per second; for lcm-spy).
struct RobotStatus {
  std::int64_t utime_us = 0;
  int robot_id = 0;
  std::int64_t session = 0;
  std::int64_t peak_rss_bytes = 0, budget_total_bytes = 0, budget_limit_bytes = 0;
  std::vector<ModuleMemory> modules;      ///< at most kMaxStatusModules
  std::uint32_t keyframes = 0;            ///< keyframes made so far
  std::uint32_t keyframes_acked = 0;      ///< of them, held by the server (its last status)
  std::uint32_t queued_keyframes = 0;     ///< waiting to be (re-)announced
  std::uint32_t queued_poses = 0;         ///< poses waiting to be sent
  std::uint32_t queued_chunks = 0;        ///< scan chunks waiting to be sent
  std::int64_t bytes_sent = 0;            ///< every message this robot published, encoded
  std::int64_t bytes_resent = 0;          ///< of them, re-announcements and retransmissions
  std::int32_t request_id = -1;           ///< the scan request it is answering (-1: none)
  std::string state;                      ///< e.g. "mapping", "sending scans", "done"
};

/// Health of the server process (server -> everyone, about once per second; for lcm-spy).
struct ServerStatus {
  std::int64_t utime_us = 0;
  std::int64_t session = 0;
  std::int64_t peak_rss_bytes = 0, budget_total_bytes = 0, budget_limit_bytes = 0;
  std::vector<ModuleMemory> modules;      ///< at most kMaxStatusModules
  std::int32_t round = 0;                 ///< merge rounds finished
  std::string state;                      ///< e.g. "collecting", "waiting for scans", "merged 3/3"
  std::int64_t bytes_received = 0;        ///< every accepted message, encoded
  std::int64_t messages_rejected = 0;     ///< malformed, foreign, stale or from unknown robots
  std::string last_rejection;             ///< the latest reason, in words (at most kMaxStatusTextBytes)
  /// Per robot with a session at the server (at most kMaxMergeRobots).
  std::vector<int> robot_ids;
  std::vector<std::uint32_t> keyframes;   ///< keyframes held
  std::vector<std::uint32_t> scans;       ///< complete scans held
  std::vector<std::uint32_t> chunks_missing;  ///< of the active request
  /// The descriptor parameter id of its batches (RobotKeyframeDb::descriptor_id; 0: none yet). Robots whose ids
  /// differ are not compared (MergeServer::incomparable_pairs), so this column shows which robot is set up apart.
  std::vector<std::uint32_t> descriptor_ids;
  /// Per robot pair of the latest merge round (at most kMaxMergePairs): StageSolverText of stage B and C.
  struct PairSolvers {
    int alpha = 0, beta = 0;
    std::string text;                     ///< at most kMaxStatusTextBytes
  };
  std::vector<PairSolvers> pairs;
};

}  // namespace commerge
