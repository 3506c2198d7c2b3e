// SPDX-License-Identifier: BSD-3-Clause
// commerge: the robot <-> server messages as plain structs (the agents' input and output). platform/lcm encodes
// them as the LCM types of lcmtypes/ (keyframe_batch_t, pose_update_t, exchange_policy_t, scan_chunk_t), field
// for field; the limits below are the types' MAX_... constants, enforced on both sides.
#pragma once

#include <cstddef>
#include <cstdint>
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
  std::int32_t sequence = 0;
  /// num_records x kKeyframeRecordBytes bytes of descriptor_codec records.
  std::vector<std::uint8_t> records;
  /// Points of each keyframe's stored scan (0 = not stored), one per record.
  std::vector<std::uint32_t> stored_points;
  std::size_t num_records() const noexcept { return records.size() / kKeyframeRecordBytes; }
};

/// Poses moved by loop closure, and poses of keyframes without a valid descriptor (robot -> server).
struct PoseUpdate {
  std::int64_t utime_us = 0;
  int robot_id = 0;
  std::int32_t sequence = 0;
  std::vector<std::uint32_t> keyframes;
  std::vector<Eigen::Isometry3d> T_map_sensor;  ///< one per keyframe, the robot's own map frame
};

/// The exchange policy for one robot (server -> robot).
struct ScanRequest {
  std::int64_t utime_us = 0;
  int robot_id = 0;
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

}  // namespace commerge
