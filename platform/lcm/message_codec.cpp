// SPDX-License-Identifier: BSD-3-Clause
#include "platform/lcm/message_codec.hpp"

#include <cmath>
#include <limits>

#include "commerge/exchange_policy_t.hpp"
#include "commerge/keyframe_batch_t.hpp"
#include "commerge/pose_update_t.hpp"
#include "commerge/scan_chunk_t.hpp"

namespace commerge::platform {

const char* const kKeyframesChannel = "COMMERGE_KEYFRAMES";
const char* const kPosesChannel = "COMMERGE_POSES";
const char* const kPolicyChannel = "COMMERGE_POLICY";
const char* const kScansChannel = "COMMERGE_SCANS";

namespace {

static_assert(commerge::keyframe_batch_t::MAX_RECORDS == static_cast<std::int32_t>(kMaxRecordsPerBatch), "");
static_assert(commerge::keyframe_batch_t::RECORD_BYTES == static_cast<std::int32_t>(kKeyframeRecordBytes), "");
static_assert(commerge::keyframe_batch_t::MAX_ROBOT_ID == kMaxRobotId, "");
static_assert(commerge::pose_update_t::MAX_POSES == static_cast<std::int32_t>(kMaxPosesPerUpdate), "");
static_assert(commerge::exchange_policy_t::MAX_KEYFRAMES == static_cast<std::int32_t>(kMaxKeyframesPerRequest), "");
static_assert(commerge::scan_chunk_t::MAX_PAYLOAD_BYTES == static_cast<std::int32_t>(kMaxScanChunkPayloadBytes), "");

// Big-endian integer at `offset` (LCM's byte order); the caller checked the size.
std::int64_t ReadBe(Span<const std::uint8_t> b, std::size_t offset, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | b[offset + static_cast<std::size_t>(i)];
  const int shift = 64 - 8 * bytes;
  return static_cast<std::int64_t>(v << shift) >> shift;  // sign-extend
}

// Checks the fingerprint and that the buffer holds the fixed header up to `header_bytes` (after the hash).
template <typename LcmType>
Status CheckHeader(Span<const std::uint8_t> bytes, std::size_t header_bytes, const char* type) {
  if (bytes.size() >= 8 && ReadBe(bytes, 0, 8) != LcmType::getHash()) {
    return DataLoss(std::string(type) + ": fingerprint does not match (another message type or another layout "
                                        "version of commerge)");
  }
  if (bytes.size() < 8 + header_bytes) {
    return DataLoss(std::string(type) + ": " + std::to_string(bytes.size()) + " bytes is shorter than its header");
  }
  return Status::Ok();
}

// The buffer must hold `needed` bytes for the counts it announces: checked before the decoder allocates.
Status CheckRoom(Span<const std::uint8_t> bytes, std::int64_t needed, const char* type) {
  if (static_cast<std::int64_t>(bytes.size()) < needed) {
    return DataLoss(std::string(type) + ": " + std::to_string(bytes.size()) + " bytes cannot hold the " +
                    std::to_string(needed) + " its counts announce");
  }
  return Status::Ok();
}

Status CheckCount(std::int64_t value, std::int64_t max, const char* type, const char* field) {
  if (value < 0 || value > max) {
    return DataLoss(std::string(type) + ": " + field + " = " + std::to_string(value) + " is outside 0.." +
                    std::to_string(max));
  }
  return Status::Ok();
}

template <typename LcmType>
Status DecodeChecked(Span<const std::uint8_t> bytes, LcmType* msg, const char* type) {
  const int n = msg->decode(bytes.data(), 0, static_cast<int>(bytes.size()));
  if (n < 0) return DataLoss(std::string(type) + ": truncated or malformed (" + std::to_string(bytes.size()) + " bytes)");
  if (static_cast<std::size_t>(n) != bytes.size()) {
    return DataLoss(std::string(type) + ": " + std::to_string(bytes.size() - static_cast<std::size_t>(n)) +
                    " trailing bytes");
  }
  return Status::Ok();
}

template <typename LcmType>
Status EncodeInto(const LcmType& msg, std::vector<std::uint8_t>* out, const char* type) {
  const int size = msg.getEncodedSize();
  out->resize(static_cast<std::size_t>(size));
  if (msg.encode(out->data(), 0, size) != size) {
    out->clear();
    return InvalidArgument(std::string(type) + ": LCM encoding failed");
  }
  return Status::Ok();
}

Status CheckRobotId(int robot_id, const char* type) {
  if (robot_id < 0 || robot_id > kMaxRobotId) {
    return InvalidArgument(std::string(type) + ": robot_id " + std::to_string(robot_id) + " is outside 0.." +
                           std::to_string(kMaxRobotId));
  }
  return Status::Ok();
}

Status CheckDecodedRobotId(int robot_id, const char* type) {
  if (robot_id < 0 || robot_id > kMaxRobotId) {
    return DataLoss(std::string(type) + ": robot_id " + std::to_string(robot_id) + " is outside 0.." +
                    std::to_string(kMaxRobotId));
  }
  return Status::Ok();
}

}  // namespace

Status EncodeKeyframeBatch(const KeyframeBatch& m, std::vector<std::uint8_t>* out) {
  const char* type = "keyframe_batch_t";
  if (Status st = CheckRobotId(m.robot_id, type); !st.ok()) return st;
  const std::size_t n = m.num_records();
  if (m.records.size() != n * kKeyframeRecordBytes || m.stored_points.size() != n || n > kMaxRecordsPerBatch) {
    return InvalidArgument("keyframe_batch_t: " + std::to_string(m.records.size()) + " record bytes and " +
                           std::to_string(m.stored_points.size()) + " point counts are not n x 92 and n with n <= " +
                           std::to_string(kMaxRecordsPerBatch));
  }
  commerge::keyframe_batch_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.sequence = m.sequence;
  msg.num_records = static_cast<std::int32_t>(n);
  msg.num_record_bytes = static_cast<std::int32_t>(m.records.size());
  msg.records = m.records;
  msg.stored_points.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    if (m.stored_points[i] > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max())) {
      return InvalidArgument("keyframe_batch_t: stored_points[" + std::to_string(i) + "] is too large");
    }
    msg.stored_points[i] = static_cast<std::int32_t>(m.stored_points[i]);
  }
  return EncodeInto(msg, out, type);
}

Result<KeyframeBatch> DecodeKeyframeBatch(Span<const std::uint8_t> bytes) {
  const char* type = "keyframe_batch_t";
  // After the hash: utime 8, robot_id 2, sequence 4, num_records 4, num_record_bytes 4.
  if (Status st = CheckHeader<commerge::keyframe_batch_t>(bytes, 22, type); !st.ok()) return st;
  const std::int64_t n = ReadBe(bytes, 8 + 14, 4), nb = ReadBe(bytes, 8 + 18, 4);
  if (Status st = CheckCount(n, static_cast<std::int64_t>(kMaxRecordsPerBatch), type, "num_records"); !st.ok()) return st;
  if (nb != n * static_cast<std::int64_t>(kKeyframeRecordBytes)) {
    return DataLoss("keyframe_batch_t: num_record_bytes = " + std::to_string(nb) + " is not 92 x num_records = " +
                    std::to_string(n * 92));
  }
  if (Status st = CheckRoom(bytes, 8 + 22 + nb + 4 * n, type); !st.ok()) return st;
  commerge::keyframe_batch_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;
  if (Status st = CheckDecodedRobotId(msg.robot_id, type); !st.ok()) return st;
  KeyframeBatch m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
  m.sequence = msg.sequence;
  m.records = std::move(msg.records);
  m.stored_points.resize(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < m.stored_points.size(); ++i) {
    if (msg.stored_points[i] < 0) {
      return DataLoss("keyframe_batch_t: stored_points[" + std::to_string(i) + "] = " +
                      std::to_string(msg.stored_points[i]) + " is negative");
    }
    m.stored_points[i] = static_cast<std::uint32_t>(msg.stored_points[i]);
  }
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
  commerge::pose_update_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.sequence = m.sequence;
  msg.num_poses = static_cast<std::int32_t>(n);
  msg.keyframe_index.resize(n);
  msg.translation_m.assign(n, std::vector<float>(3));
  msg.quaternion.assign(n, std::vector<float>(4));
  for (std::size_t i = 0; i < n; ++i) {
    const Eigen::Isometry3d& T = m.T_map_sensor[i];
    if (!T.matrix().allFinite() || m.keyframes[i] > static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max())) {
      return InvalidArgument("pose_update_t: pose " + std::to_string(i) + " (keyframe " +
                             std::to_string(m.keyframes[i]) + ") is not finite or its index is too large");
    }
    msg.keyframe_index[i] = static_cast<std::int32_t>(m.keyframes[i]);
    const Eigen::Quaterniond q(T.linear());
    const Eigen::Quaterniond u = q.normalized();
    msg.quaternion[i] = {static_cast<float>(u.w()), static_cast<float>(u.x()), static_cast<float>(u.y()),
                         static_cast<float>(u.z())};
    for (int a = 0; a < 3; ++a) msg.translation_m[i][static_cast<std::size_t>(a)] = static_cast<float>(T.translation()[a]);
  }
  return EncodeInto(msg, out, type);
}

Result<PoseUpdate> DecodePoseUpdate(Span<const std::uint8_t> bytes) {
  const char* type = "pose_update_t";
  if (Status st = CheckHeader<commerge::pose_update_t>(bytes, 18, type); !st.ok()) return st;
  const std::int64_t n = ReadBe(bytes, 8 + 14, 4);
  if (Status st = CheckCount(n, static_cast<std::int64_t>(kMaxPosesPerUpdate), type, "num_poses"); !st.ok()) return st;
  // Each pose takes 4 + 12 + 16 bytes: a short buffer is refused before the decoder allocates for it.
  if (static_cast<std::int64_t>(bytes.size()) < 8 + 18 + 32 * n) {
    return DataLoss("pose_update_t: " + std::to_string(bytes.size()) + " bytes cannot hold " + std::to_string(n) +
                    " poses");
  }
  commerge::pose_update_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;
  if (Status st = CheckDecodedRobotId(msg.robot_id, type); !st.ok()) return st;
  PoseUpdate m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
  m.sequence = msg.sequence;
  m.keyframes.resize(static_cast<std::size_t>(n));
  m.T_map_sensor.resize(static_cast<std::size_t>(n));
  for (std::size_t i = 0; i < m.keyframes.size(); ++i) {
    const auto& t = msg.translation_m[i];
    const auto& q = msg.quaternion[i];
    const Eigen::Vector4d qv(q[0], q[1], q[2], q[3]);
    const Eigen::Vector3d tv(t[0], t[1], t[2]);
    if (msg.keyframe_index[i] < 0 || !qv.allFinite() || !tv.allFinite() || std::abs(qv.norm() - 1.0) > 1e-3) {
      return DataLoss("pose_update_t: pose " + std::to_string(i) + " has a negative keyframe index, a non-finite "
                      "value or a quaternion that is not unit");
    }
    m.keyframes[i] = static_cast<std::uint32_t>(msg.keyframe_index[i]);
    Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
    T.linear() = Eigen::Quaterniond(qv[0], qv[1], qv[2], qv[3]).normalized().toRotationMatrix();
    T.translation() = tv;
    m.T_map_sensor[i] = T;
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
  if (Status st = CheckHeader<commerge::exchange_policy_t>(bytes, 18, type); !st.ok()) return st;
  const std::int64_t n = ReadBe(bytes, 8 + 14, 4);
  if (Status st = CheckCount(n, static_cast<std::int64_t>(kMaxKeyframesPerRequest), type, "num_keyframes"); !st.ok()) {
    return st;
  }
  if (Status st = CheckRoom(bytes, 8 + 18 + 4 * n, type); !st.ok()) return st;
  commerge::exchange_policy_t msg{};
  if (Status st = DecodeChecked(bytes, &msg, type); !st.ok()) return st;
  if (Status st = CheckDecodedRobotId(msg.robot_id, type); !st.ok()) return st;
  ScanRequest m;
  m.utime_us = msg.utime;
  m.robot_id = msg.robot_id;
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
