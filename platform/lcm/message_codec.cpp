// SPDX-License-Identifier: BSD-3-Clause
#include "platform/lcm/message_codec.hpp"

#include <limits>

#include "commerge/exchange_policy_t.hpp"
#include "commerge/keyframe_batch_t.hpp"
#include "commerge/pose_update_t.hpp"
#include "commerge/scan_chunk_t.hpp"
#include "core/descriptor/compact_pose_codec.hpp"
#include "platform/lcm/codec_util.hpp"

namespace commerge::platform {

const char* const kKeyframesChannel = "COMMERGE_KEYFRAMES";
const char* const kPosesChannel = "COMMERGE_POSES";
const char* const kPolicyChannel = "COMMERGE_POLICY";
const char* const kScansChannel = "COMMERGE_SCANS";

namespace {

static_assert(commerge::keyframe_batch_t::MAX_RECORDS == static_cast<std::int32_t>(kMaxRecordsPerBatch), "");
static_assert(commerge::pose_update_t::MAX_POSE_BYTES == static_cast<std::int32_t>(kMaxCompactPoseBytes), "");
static_assert(commerge::pose_update_t::MAX_POSES == static_cast<std::int32_t>(kMaxCompactPoses), "");
static_assert(commerge::keyframe_batch_t::RECORD_BYTES == static_cast<std::int32_t>(kKeyframeRecordBytes), "");
static_assert(commerge::keyframe_batch_t::SCAN_CONTEXT_RECORD_BYTES ==
                  static_cast<std::int32_t>(ScanContextRecordBytes(kScanContextWireRings, kScanContextWireSectors)),
              "");
static_assert(commerge::keyframe_batch_t::RECORD_UNIT40 == static_cast<std::int8_t>(KeyframeRecordKind::kUnit40), "");
static_assert(commerge::keyframe_batch_t::RECORD_SCAN_CONTEXT ==
                  static_cast<std::int8_t>(KeyframeRecordKind::kScanContext),
              "");
static_assert(commerge::keyframe_batch_t::RECORD_COMPACT40 == static_cast<std::int8_t>(KeyframeRecordKind::kCompact40),
              "");
static_assert(commerge::keyframe_batch_t::MAX_COMPACT_BYTES == static_cast<std::int32_t>(kMaxCompactBatchBytes), "");
static_assert(commerge::keyframe_batch_t::MAX_ROBOT_ID == kMaxRobotId, "");
static_assert(commerge::pose_update_t::MAX_POSES == static_cast<std::int32_t>(kMaxPosesPerUpdate), "");
static_assert(commerge::exchange_policy_t::MAX_KEYFRAMES == static_cast<std::int32_t>(kMaxKeyframesPerRequest), "");
static_assert(commerge::scan_chunk_t::MAX_PAYLOAD_BYTES == static_cast<std::int32_t>(kMaxScanChunkPayloadBytes), "");

}  // namespace

using namespace lcm_detail;  // NOLINT(google-build-using-namespace): the shared helpers of platform/lcm

Status EncodeKeyframeBatch(const KeyframeBatch& m, std::vector<std::uint8_t>* out) {
  const char* type = "keyframe_batch_t";
  if (Status st = CheckRobotId(m.robot_id, type); !st.ok()) return st;
  if (!IsKeyframeRecordKind(static_cast<std::uint8_t>(m.record_kind))) {
    return InvalidArgument("keyframe_batch_t: record_kind " + std::to_string(static_cast<int>(m.record_kind)) +
                           " is not a record kind");
  }
  const std::size_t n = m.num_records();
  if (!m.RecordArraysConsistent()) {
    const std::size_t record_bytes = KeyframeRecordBytesOf(m.record_kind);
    return InvalidArgument("keyframe_batch_t: " + std::to_string(m.records.size()) + " record bytes and " +
                           std::to_string(m.stored_points.size()) + " point counts are not " +
                           (record_bytes == 0 ? std::string("1..") + std::to_string(kMaxCompactBatchBytes) + " bytes"
                                              : "n x " + std::to_string(record_bytes)) +
                           " and n with n <= " + std::to_string(kMaxRecordsPerBatch));
  }
  commerge::keyframe_batch_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.session = m.session;
  msg.sequence = m.sequence;
  msg.record_kind = static_cast<std::int8_t>(m.record_kind);
  msg.num_records = static_cast<std::int32_t>(n);
  msg.num_record_bytes = static_cast<std::int32_t>(m.records.size());
  msg.records = m.records;
  msg.num_stored_points = static_cast<std::int32_t>(m.stored_points.size());
  msg.stored_points.resize(m.stored_points.size());
  for (std::size_t i = 0; i < m.stored_points.size(); ++i) {
    if (m.stored_points[i] > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max())) {
      return InvalidArgument("keyframe_batch_t: stored_points[" + std::to_string(i) + "] is too large");
    }
    msg.stored_points[i] = static_cast<std::int32_t>(m.stored_points[i]);
  }
  msg.descriptor_id = static_cast<std::int32_t>(m.descriptor_id);  // the bits, as the type says
  return EncodeInto(msg, out, type);
}

Result<KeyframeBatch> DecodeKeyframeBatch(Span<const std::uint8_t> bytes) {
  const char* type = "keyframe_batch_t";
  // After the hash: utime 8, robot_id 2, session 8, sequence 4, record_kind 1, num_records 4, num_record_bytes 4.
  if (Status st = CheckHeader<commerge::keyframe_batch_t>(bytes, 31, type); !st.ok()) return st;
  const std::int64_t kind = ReadBe(bytes, 8 + 22, 1);
  if (!IsKeyframeRecordKind(static_cast<std::uint8_t>(kind))) {
    return DataLoss("keyframe_batch_t: record_kind = " + std::to_string(kind) + " is not a record kind (1, 2, 3)");
  }
  const auto record_kind = static_cast<KeyframeRecordKind>(kind);
  const auto record_bytes = static_cast<std::int64_t>(KeyframeRecordBytesOf(record_kind));
  const std::int64_t n = ReadBe(bytes, 8 + 23, 4), nb = ReadBe(bytes, 8 + 27, 4);
  if (Status st = CheckCount(n, static_cast<std::int64_t>(kMaxRecordsPerBatch), type, "num_records"); !st.ok()) return st;
  if (record_kind == KeyframeRecordKind::kCompact40) {
    if (n < 1 || nb < 1 || nb > static_cast<std::int64_t>(kMaxCompactBatchBytes)) {
      return DataLoss("keyframe_batch_t: a compact batch of num_records = " + std::to_string(n) +
                      " and num_record_bytes = " + std::to_string(nb) + " (expected 1..512 records in 1.." +
                      std::to_string(kMaxCompactBatchBytes) + " bytes)");
    }
  } else if (nb != n * record_bytes) {
    return DataLoss("keyframe_batch_t: num_record_bytes = " + std::to_string(nb) + " is not " +
                    std::to_string(record_bytes) + " x num_records = " + std::to_string(n * record_bytes));
  }
  // ... records, num_stored_points 4, stored_points, descriptor_id 4.
  if (Status st = CheckRoom(bytes, 8 + 31 + nb + 4, type); !st.ok()) return st;
  const std::int64_t np = ReadBe(bytes, static_cast<std::size_t>(8 + 31 + nb), 4);
  const std::int64_t expected_np = record_kind == KeyframeRecordKind::kCompact40 ? 0 : n;
  if (np != expected_np) {
    return DataLoss("keyframe_batch_t: num_stored_points = " + std::to_string(np) + " is not " +
                    std::to_string(expected_np) + (expected_np == 0 ? " (a compact batch codes its point counts)"
                                                                    : " (num_records)"));
  }
  if (Status st = CheckRoom(bytes, 8 + 31 + nb + 4 + 4 * np + 4, type); !st.ok()) return st;
  commerge::keyframe_batch_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;
  if (Status st = CheckDecodedRobotId(msg.robot_id, type); !st.ok()) return st;
  KeyframeBatch m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
  m.session = msg.session;
  m.sequence = msg.sequence;
  m.record_kind = record_kind;
  m.records = std::move(msg.records);
  if (record_kind == KeyframeRecordKind::kCompact40) m.num_compact_records = static_cast<std::size_t>(n);
  m.stored_points.resize(static_cast<std::size_t>(np));
  for (std::size_t i = 0; i < m.stored_points.size(); ++i) {
    if (msg.stored_points[i] < 0) {
      return DataLoss("keyframe_batch_t: stored_points[" + std::to_string(i) + "] = " +
                      std::to_string(msg.stored_points[i]) + " is negative");
    }
    m.stored_points[i] = static_cast<std::uint32_t>(msg.stored_points[i]);
  }
  m.descriptor_id = static_cast<std::uint32_t>(msg.descriptor_id);
  return m;
}

Status EncodePoseUpdate(const PoseUpdate& m, std::vector<std::uint8_t>* out) {
  const char* type = "pose_update_t";
  if (Status st = CheckRobotId(m.robot_id, type); !st.ok()) return st;
  const std::size_t n = m.keyframes.size();
  if (m.T_map_sensor.size() != n || n > kMaxPosesPerUpdate) {
    return InvalidArgument("pose_update_t: " + std::to_string(n) + " keyframes and " +
                           std::to_string(m.T_map_sensor.size()) + " poses (equal and at most " +
                           std::to_string(kMaxPosesPerUpdate) + ")");
  }
  if (!m.no_descriptor.empty() && m.no_descriptor.size() != n) {
    return InvalidArgument("pose_update_t: no_descriptor has " + std::to_string(m.no_descriptor.size()) +
                           " entries for " + std::to_string(n) + " keyframes (empty or one per keyframe)");
  }
  commerge::pose_update_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.session = m.session;
  msg.sequence = m.sequence;
  msg.num_poses = static_cast<std::int32_t>(n);
  if (Status st = EncodeCompactPoses(Span<const std::uint32_t>(m.keyframes), Span<const Eigen::Isometry3d>(m.T_map_sensor),
                                     Span<const std::uint8_t>(m.no_descriptor), &msg.poses);
      !st.ok()) {
    return InvalidArgument("pose_update_t: " + st.message());
  }
  msg.num_pose_bytes = static_cast<std::int32_t>(msg.poses.size());
  return EncodeInto(msg, out, type);
}

Result<PoseUpdate> DecodePoseUpdate(Span<const std::uint8_t> bytes) {
  const char* type = "pose_update_t";
  // After the hash: utime 8, robot_id 2, session 8, sequence 4, num_poses 4, num_pose_bytes 4.
  if (Status st = CheckHeader<commerge::pose_update_t>(bytes, 30, type); !st.ok()) return st;
  const std::int64_t n = ReadBe(bytes, 8 + 22, 4), nb = ReadBe(bytes, 8 + 26, 4);
  if (Status st = CheckCount(n, static_cast<std::int64_t>(kMaxPosesPerUpdate), type, "num_poses"); !st.ok()) return st;
  if (Status st = CheckCount(nb, static_cast<std::int64_t>(kMaxCompactPoseBytes), type, "num_pose_bytes"); !st.ok()) {
    return st;
  }
  if ((n == 0) != (nb == 0)) {
    return DataLoss("pose_update_t: num_pose_bytes = " + std::to_string(nb) + " for num_poses = " +
                    std::to_string(n) + " (0 bytes exactly for 0 poses)");
  }
  if (Status st = CheckRoom(bytes, 8 + 30 + nb, type); !st.ok()) return st;
  commerge::pose_update_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;
  if (Status st = CheckDecodedRobotId(msg.robot_id, type); !st.ok()) return st;
  PoseUpdate m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
  m.session = msg.session;
  m.sequence = msg.sequence;
  if (Status st = DecodeCompactPoses(Span<const std::uint8_t>(msg.poses), static_cast<std::size_t>(n), &m.keyframes,
                                     &m.T_map_sensor, &m.no_descriptor);
      !st.ok()) {
    return DataLoss("pose_update_t: " + st.message());
  }
  return m;
}

Status EncodeScanRequest(const ScanRequest& m, std::vector<std::uint8_t>* out) {
  const char* type = "exchange_policy_t";
  if (Status st = CheckRobotId(m.robot_id, type); !st.ok()) return st;
  if (m.keyframes.size() > kMaxKeyframesPerRequest) {
    return InvalidArgument("exchange_policy_t: " + std::to_string(m.keyframes.size()) + " keyframes (at most " +
                           std::to_string(kMaxKeyframesPerRequest) + ")");
  }
  commerge::exchange_policy_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.server_session = m.server_session;
  msg.request_id = m.request_id;
  msg.num_keyframes = static_cast<std::int32_t>(m.keyframes.size());
  msg.keyframe_index.resize(m.keyframes.size());
  for (std::size_t i = 0; i < m.keyframes.size(); ++i) {
    if (m.keyframes[i] > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max())) {
      return InvalidArgument("exchange_policy_t: keyframe " + std::to_string(m.keyframes[i]) + " is too large");
    }
    if (i > 0 && m.keyframes[i] <= m.keyframes[i - 1]) {
      return InvalidArgument("exchange_policy_t: keyframes must be ascending and unique (keyframe_index[" +
                             std::to_string(i) + "] = " + std::to_string(m.keyframes[i]) + ")");
    }
    msg.keyframe_index[i] = static_cast<std::int32_t>(m.keyframes[i]);
  }
  return EncodeInto(msg, out, type);
}

Result<ScanRequest> DecodeScanRequest(Span<const std::uint8_t> bytes) {
  const char* type = "exchange_policy_t";
  // After the hash: utime 8, robot_id 2, server_session 8, request_id 4, num_keyframes 4.
  if (Status st = CheckHeader<commerge::exchange_policy_t>(bytes, 26, type); !st.ok()) return st;
  const std::int64_t n = ReadBe(bytes, 8 + 22, 4);
  if (Status st = CheckCount(n, static_cast<std::int64_t>(kMaxKeyframesPerRequest), type, "num_keyframes"); !st.ok()) {
    return st;
  }
  if (Status st = CheckRoom(bytes, 8 + 26 + 4 * n, type); !st.ok()) return st;
  commerge::exchange_policy_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;
  if (Status st = CheckDecodedRobotId(msg.robot_id, type); !st.ok()) return st;
  ScanRequest m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
  m.server_session = msg.server_session;
  m.request_id = msg.request_id;
  m.keyframes.resize(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < m.keyframes.size(); ++i) {
    if (msg.keyframe_index[i] < 0 || (i > 0 && msg.keyframe_index[i] <= msg.keyframe_index[i - 1])) {
      return DataLoss("exchange_policy_t: keyframe_index[" + std::to_string(i) + "] = " +
                      std::to_string(msg.keyframe_index[i]) + " is negative or not ascending");
    }
    m.keyframes[i] = static_cast<std::uint32_t>(msg.keyframe_index[i]);
  }
  return m;
}

Status EncodeScanChunk(const ScanChunk& m, std::vector<std::uint8_t>* out) {
  const char* type = "scan_chunk_t";
  if (Status st = CheckRobotId(m.robot_id, type); !st.ok()) return st;
  if (m.payload.size() > kMaxScanChunkPayloadBytes || m.num_chunks == 0 || m.num_chunks > kMaxChunksPerScan ||
      m.chunk_index >= m.num_chunks || m.keyframe > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max()) ||
      m.total_bytes > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max())) {
    return InvalidArgument("scan_chunk_t: chunk " + std::to_string(m.chunk_index) + " of " +
                           std::to_string(m.num_chunks) + " with " + std::to_string(m.payload.size()) +
                           " payload bytes is outside the message's limits");
  }
  commerge::scan_chunk_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.request_id = m.request_id;
  msg.keyframe_index = static_cast<std::int32_t>(m.keyframe);
  msg.total_bytes = static_cast<std::int32_t>(m.total_bytes);
  msg.chunk_index = static_cast<std::int16_t>(m.chunk_index);
  msg.num_chunks = static_cast<std::int16_t>(m.num_chunks);
  msg.num_bytes = static_cast<std::int32_t>(m.payload.size());
  msg.payload = m.payload;
  return EncodeInto(msg, out, type);
}

Result<ScanChunk> DecodeScanChunk(Span<const std::uint8_t> bytes) {
  const char* type = "scan_chunk_t";
  // After the hash: utime 8, robot_id 2, request_id 4, keyframe_index 4, total_bytes 4, chunk_index 2,
  // num_chunks 2, num_bytes 4.
  if (Status st = CheckHeader<commerge::scan_chunk_t>(bytes, 30, type); !st.ok()) return st;
  const std::int64_t n = ReadBe(bytes, 8 + 26, 4);
  if (Status st = CheckCount(n, static_cast<std::int64_t>(kMaxScanChunkPayloadBytes), type, "num_bytes"); !st.ok()) {
    return st;
  }
  if (Status st = CheckRoom(bytes, 8 + 30 + n, type); !st.ok()) return st;
  commerge::scan_chunk_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;
  if (Status st = CheckDecodedRobotId(msg.robot_id, type); !st.ok()) return st;
  if (msg.keyframe_index < 0 || msg.total_bytes < 0 || msg.num_chunks < 1 || msg.chunk_index < 0 ||
      msg.chunk_index >= msg.num_chunks) {
    return DataLoss("scan_chunk_t: keyframe " + std::to_string(msg.keyframe_index) + ", total " +
                    std::to_string(msg.total_bytes) + " bytes, chunk " + std::to_string(msg.chunk_index) + " of " +
                    std::to_string(msg.num_chunks) + ": out of range");
  }
  ScanChunk m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
  m.request_id = msg.request_id;
  m.keyframe = static_cast<std::uint32_t>(msg.keyframe_index);
  m.total_bytes = static_cast<std::uint32_t>(msg.total_bytes);
  m.chunk_index = static_cast<std::uint16_t>(msg.chunk_index);
  m.num_chunks = static_cast<std::uint16_t>(msg.num_chunks);
  m.payload = std::move(msg.payload);
  return m;
}

}  // namespace commerge::platform
