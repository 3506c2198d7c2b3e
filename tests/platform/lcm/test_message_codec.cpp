// SPDX-License-Identifier: BSD-3-Clause
// platform/lcm/message_codec: the robot <-> server messages to and from LCM wire bytes. Expectations come from
// the generated LCM types (their own encode/decode and fingerprints), hand-read big-endian byte offsets and the
// keyframe record codec; hostile buffers (foreign types, truncations, trailing bytes, patched counts) are
// refused with DataLoss naming what is wrong.
#include <doctest/doctest.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include <lcm/lcm-cpp.hpp>

#include <commerge/exchange_policy_t.hpp>
#include <commerge/keyframe_batch_t.hpp>
#include <commerge/pose_update_t.hpp>
#include <commerge/robot_status_t.hpp>
#include <commerge/scan_chunk_t.hpp>

#include "core/agent/messages.hpp"
#include "core/common/exp_golomb.hpp"
#include "core/descriptor/compact_pose_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/geometry/angles.hpp"
#include "platform/lcm/message_codec.hpp"
#include "tests/platform/lcm/lcm_test_util.hpp"

namespace commerge::platform {
namespace {

// ---- message builders ----

KeyframeRecord MakeRecord(std::uint32_t k) {
  KeyframeRecord r;
  r.keyframe_index = k;
  r.T_map_sensor = Eigen::Isometry3d::Identity();
  r.T_map_sensor.linear() =
      Eigen::AngleAxisd(0.3 + 0.7 * k, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  r.T_map_sensor.translation() = Eigen::Vector3d(1.5 * k, -2.25, 0.5 + k);
  double norm2 = 0.0;
  std::array<double, kKeyframeDescriptorDim> v{};
  for (std::size_t i = 0; i < v.size(); ++i) {
    v[i] = 1.0 + static_cast<double>((i * 7 + k) % 5);
    norm2 += v[i] * v[i];
  }
  for (std::size_t i = 0; i < v.size(); ++i) r.descriptor[i] = static_cast<float>(v[i] / std::sqrt(norm2));
  r.descriptor_valid = true;
  return r;
}

Buffer EncodeRecords(const std::vector<KeyframeRecord>& records) {
  Buffer bytes(records.size() * kKeyframeRecordBytes);
  for (std::size_t i = 0; i < records.size(); ++i) {
    REQUIRE(EncodeKeyframeRecord(records[i], Span<std::uint8_t>(bytes.data() + i * kKeyframeRecordBytes,
                                                                kKeyframeRecordBytes))
                .ok());
  }
  return bytes;
}

KeyframeBatch MakeBatch(std::size_t n) {
  KeyframeBatch m;
  m.utime_us = 1763800000123456;
  m.robot_id = 7;
  m.session = 1763799999000001;
  m.sequence = 41;
  m.descriptor_id = 0x761BEAA5u;  // the HDL-64E preset's id; its top bit exercises the int32 wire field
  std::vector<KeyframeRecord> records;
  for (std::size_t i = 0; i < n; ++i) records.push_back(MakeRecord(static_cast<std::uint32_t>(10 + 3 * i)));
  m.records = EncodeRecords(records);
  for (std::size_t i = 0; i < n; ++i) m.stored_points.push_back(static_cast<std::uint32_t>(i == 0 ? 0 : 1000 * i + 7));
  return m;
}

commerge::keyframe_batch_t ToLcm(const KeyframeBatch& m) {
  commerge::keyframe_batch_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.session = m.session;
  msg.sequence = m.sequence;
  msg.record_kind = static_cast<std::int8_t>(m.record_kind);
  msg.num_records = static_cast<std::int32_t>(m.num_records());
  msg.num_record_bytes = static_cast<std::int32_t>(m.records.size());
  msg.records = m.records;
  msg.num_stored_points = static_cast<std::int32_t>(m.stored_points.size());
  for (std::uint32_t p : m.stored_points) msg.stored_points.push_back(static_cast<std::int32_t>(p));
  msg.descriptor_id = static_cast<std::int32_t>(m.descriptor_id);
  return msg;
}

PoseUpdate MakePoseUpdate(std::size_t n) {
  PoseUpdate m;
  m.utime_us = 1763800000654321;
  m.robot_id = 3;
  m.session = 1763799999000003;
  m.sequence = 9;
  for (std::size_t i = 0; i < n; ++i) {
    m.keyframes.push_back(static_cast<std::uint32_t>(5 * i + 2));
    m.no_descriptor.push_back(static_cast<std::uint8_t>(i % 2));
    m.T_map_sensor.push_back(Pose(0.4 + 0.9 * static_cast<double>(i), Eigen::Vector3d(-1.0, 0.5, 2.0 + static_cast<double>(i)),
                                  Eigen::Vector3d(12.345 * static_cast<double>(i), -3.5, 0.125)));
  }
  return m;
}

ScanRequest MakeRequest(std::vector<std::uint32_t> keyframes) {
  ScanRequest m;
  m.utime_us = 1763800000000777;
  m.robot_id = 12;
  m.server_session = 1763799990000042;
  m.request_id = 4242;
  m.keyframes = std::move(keyframes);
  return m;
}

commerge::exchange_policy_t ToLcm(const ScanRequest& m) {
  commerge::exchange_policy_t msg{};
  msg.utime = m.utime_us;
  msg.robot_id = static_cast<std::int16_t>(m.robot_id);
  msg.server_session = m.server_session;
  msg.request_id = m.request_id;
  msg.num_keyframes = static_cast<std::int32_t>(m.keyframes.size());
  for (std::uint32_t k : m.keyframes) msg.keyframe_index.push_back(static_cast<std::int32_t>(k));
  return msg;
}

ScanChunk MakeChunk(std::size_t payload_bytes) {
  ScanChunk m;
  m.utime_us = 1763800000000999;
  m.robot_id = 5;
  m.request_id = -1;
  m.keyframe = 123456;
  m.total_bytes = 3000;
  m.chunk_index = 2;
  m.num_chunks = 3;
  for (std::size_t i = 0; i < payload_bytes; ++i) m.payload.push_back(static_cast<std::uint8_t>((i * 31 + 7) & 0xff));
  return m;
}

commerge::scan_chunk_t ToLcm(const ScanChunk& m) {
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
  return msg;
}


Buffer Encoded(const KeyframeBatch& m) {
  Buffer b;
  REQUIRE(EncodeKeyframeBatch(m, &b).ok());
  return b;
}
Buffer Encoded(const PoseUpdate& m) {
  Buffer b;
  REQUIRE(EncodePoseUpdate(m, &b).ok());
  return b;
}
Buffer Encoded(const ScanRequest& m) {
  Buffer b;
  REQUIRE(EncodeScanRequest(m, &b).ok());
  return b;
}
Buffer Encoded(const ScanChunk& m) {
  Buffer b;
  REQUIRE(EncodeScanChunk(m, &b).ok());
  return b;
}

// Codes of all four decoders for one buffer (ok or not, and the status).
struct AllDecoders {
  Result<KeyframeBatch> batch;
  Result<PoseUpdate> poses;
  Result<ScanRequest> request;
  Result<ScanChunk> chunk;
};
AllDecoders DecodeWithAll(const Buffer& b) {
  return {DecodeKeyframeBatch(S(b)), DecodePoseUpdate(S(b)), DecodeScanRequest(S(b)), DecodeScanChunk(S(b))};
}

// Offsets of the count fields (8-byte fingerprint first, then the fields in declaration order).
// utime 8, robot_id 2, session 8, sequence 4, (batch:) record_kind 1:
constexpr std::size_t kBatchRecordKind = 8 + 8 + 2 + 8 + 4;         // 30
constexpr std::size_t kBatchNumRecords = kBatchRecordKind + 1;      // 31
constexpr std::size_t kBatchNumRecordBytes = kBatchNumRecords + 4;  // 35
constexpr std::size_t kBatchRecords = kBatchNumRecordBytes + 4;     // 39
constexpr std::size_t kPoseNumPoses = 8 + 8 + 2 + 8 + 4;            // 30
// utime 8, robot_id 2, server_session 8, request_id 4:
constexpr std::size_t kRequestNumKeyframes = 8 + 8 + 2 + 8 + 4;     // 30
constexpr std::size_t kChunkNumBytes = 8 + 8 + 2 + 4 + 4 + 4 + 2 + 2;  // 34

TEST_CASE("message codec: channel names are the documented ones") {
  CHECK(std::string(kKeyframesChannel) == "COMMERGE_KEYFRAMES");
  CHECK(std::string(kPosesChannel) == "COMMERGE_POSES");
  CHECK(std::string(kPolicyChannel) == "COMMERGE_POLICY");
  CHECK(std::string(kScansChannel) == "COMMERGE_SCANS");
}

TEST_CASE("message codec: keyframe batch round trip keeps every field and every record") {
  KeyframeBatch m = MakeBatch(3);
  m.robot_id = 63;
  m.stored_points[2] = static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max());
  const Buffer b = Encoded(m);

  // Wire layout, read by hand: fingerprint, utime, robot_id, session, sequence, record_kind, num_records,
  // num_record_bytes, records, num_stored_points, stored_points, descriptor_id.
  REQUIRE(b.size() == 8 + 31 + 3 * 92 + 4 + 3 * 4 + 4);
  CHECK(GetBe(b, 0, 8) == commerge::keyframe_batch_t::getHash());
  CHECK(GetBe(b, 8, 8) == 1763800000123456);
  CHECK(GetBe(b, 16, 2) == 63);
  CHECK(GetBe(b, 18, 8) == 1763799999000001);
  CHECK(GetBe(b, 26, 4) == 41);
  CHECK(GetBe(b, kBatchRecordKind, 1) == 1);
  CHECK(GetBe(b, kBatchNumRecords, 4) == 3);
  CHECK(GetBe(b, kBatchNumRecordBytes, 4) == 276);
  CHECK(std::memcmp(b.data() + kBatchRecords, m.records.data(), 276) == 0);
  CHECK(GetBe(b, kBatchRecords + 276, 4) == 3);
  CHECK(GetBe(b, kBatchRecords + 280, 4) == 0);
  CHECK(GetBe(b, kBatchRecords + 280 + 4, 4) == 1007);
  CHECK(GetBe(b, kBatchRecords + 280 + 8, 4) == std::numeric_limits<std::int32_t>::max());
  CHECK(static_cast<std::uint32_t>(GetBe(b, kBatchRecords + 280 + 12, 4)) == 0x761BEAA5u);

  // The byte ledger counts the wire: the generated type encodes the same values to the same bytes.
  const commerge::keyframe_batch_t lcm = ToLcm(m);
  CHECK(static_cast<int>(b.size()) == lcm.getEncodedSize());
  CHECK(b == LcmEncode(lcm));

  auto d = DecodeKeyframeBatch(S(b));
  REQUIRE(d.ok());
  CHECK(d->utime_us == m.utime_us);
  CHECK(d->robot_id == 63);
  CHECK(d->session == 1763799999000001);
  CHECK(d->sequence == 41);
  CHECK(d->records == m.records);
  CHECK(d->stored_points == m.stored_points);
  CHECK(d->descriptor_id == 0x761BEAA5u);
  REQUIRE(d->num_records() == 3);
  for (std::size_t i = 0; i < 3; ++i) {
    const KeyframeRecord original = MakeRecord(static_cast<std::uint32_t>(10 + 3 * i));
    auto r = DecodeKeyframeRecord(Span<const std::uint8_t>(d->records.data() + i * 92, 92));
    REQUIRE(r.ok());
    CHECK(r->keyframe_index == original.keyframe_index);
    CHECK(r->descriptor_valid);
    CHECK((r->T_map_sensor.translation() - original.T_map_sensor.translation()).norm() < 1e-5);
    CHECK(RotationErrorRad(r->T_map_sensor.linear(), original.T_map_sensor.linear()) < 2e-4);
    double dist2 = 0.0;
    for (std::size_t k = 0; k < kKeyframeDescriptorDim; ++k) {
      const double e = static_cast<double>(r->descriptor[k]) - static_cast<double>(original.descriptor[k]);
      dist2 += e * e;
    }
    CHECK(std::sqrt(dist2) < 4e-4);
  }
}

TEST_CASE("message codec: an empty keyframe batch is the 39-byte header, the point count and the descriptor id, "
          "and round-trips") {
  KeyframeBatch m;
  m.utime_us = -5;
  m.robot_id = 0;
  m.session = 1;
  m.sequence = 0;
  const Buffer b = Encoded(m);
  CHECK(b.size() == 47);
  CHECK(b == LcmEncode(ToLcm(m)));
  auto d = DecodeKeyframeBatch(S(b));
  REQUIRE(d.ok());
  CHECK(d->utime_us == -5);
  CHECK(d->session == 1);
  CHECK(d->records.empty());
  CHECK(d->stored_points.empty());
}

TEST_CASE("message codec: pose update round trip keeps poses on the compact pose grid") {
  PoseUpdate m = MakePoseUpdate(4);
  m.keyframes[3] = static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max());
  // Rotation near pi (quaternion w ~ 0) and a large translation.
  m.T_map_sensor[1] = Pose(3.14159, Eigen::Vector3d(0.2, -1.0, 0.3), Eigen::Vector3d(-99.875, 63.3, -0.001));
  m.T_map_sensor[2] = Eigen::Isometry3d::Identity();
  const Buffer b = Encoded(m);

  // Wire layout, read by hand: fingerprint, utime, robot_id, session, sequence, num_poses, num_pose_bytes, the
  // compact pose list (core/descriptor/compact_pose_codec.hpp), which decodes alone to the same poses.
  CHECK(GetBe(b, 0, 8) == commerge::pose_update_t::getHash());
  CHECK(GetBe(b, 8, 8) == m.utime_us);
  CHECK(GetBe(b, 16, 2) == 3);
  CHECK(GetBe(b, 18, 8) == 1763799999000003);
  CHECK(GetBe(b, 26, 4) == 9);
  CHECK(GetBe(b, kPoseNumPoses, 4) == 4);
  const std::size_t list_bytes = static_cast<std::size_t>(GetBe(b, kPoseNumPoses + 4, 4));
  REQUIRE(b.size() == 8 + 30 + list_bytes);
  std::vector<std::uint32_t> keyframes;
  std::vector<Eigen::Isometry3d> poses;
  std::vector<std::uint8_t> flags;
  REQUIRE(DecodeCompactPoses(Span<const std::uint8_t>(b.data() + 38, list_bytes), 4, &keyframes, &poses, &flags).ok());
  CHECK(keyframes == m.keyframes);
  CHECK(flags == m.no_descriptor);
  const auto lcm = LcmDecode<commerge::pose_update_t>(b);
  CHECK(lcm.getEncodedSize() == static_cast<int>(b.size()));
  CHECK(LcmEncode(lcm) == b);

  auto d = DecodePoseUpdate(S(b));
  REQUIRE(d.ok());
  CHECK(d->utime_us == m.utime_us);
  CHECK(d->robot_id == 3);
  CHECK(d->session == 1763799999000003);
  CHECK(d->sequence == 9);
  CHECK(d->keyframes == m.keyframes);
  CHECK(d->no_descriptor == std::vector<std::uint8_t>{0, 1, 0, 1});
  REQUIRE(d->T_map_sensor.size() == 4);
  for (std::size_t i = 0; i < 4; ++i) {
    INFO("pose ", i);
    // The grid's half step per axis, the quaternion codes' ~1.2e-4 rad.
    CHECK((d->T_map_sensor[i].translation() - m.T_map_sensor[i].translation()).cwiseAbs().maxCoeff() <=
          0.5 * kCompactTranslationStepM + 1e-9);
    CHECK(RotationErrorRad(d->T_map_sensor[i].linear(), m.T_map_sensor[i].linear()) < 1.3e-4);
    CHECK(d->T_map_sensor[i].matrix() == poses[i].matrix());
    // A proper rotation (orthonormal, det 1) comes back.
    CHECK((d->T_map_sensor[i].linear().transpose() * d->T_map_sensor[i].linear() - Eigen::Matrix3d::Identity())
              .cwiseAbs()
              .maxCoeff() < 1e-12);
    CHECK(d->T_map_sensor[i].linear().determinant() == doctest::Approx(1.0));
    CHECK((d->T_map_sensor[i].matrix().row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() == 0.0);
  }

  PoseUpdate empty;
  empty.robot_id = 1;
  const Buffer e = Encoded(empty);
  CHECK(e.size() == 38);
  auto de = DecodePoseUpdate(S(e));
  REQUIRE(de.ok());
  CHECK(de->keyframes.empty());
  CHECK(de->T_map_sensor.empty());
  CHECK(de->no_descriptor.empty());
}

TEST_CASE("message codec: scan request round trip keeps ids and ascending keyframes") {
  const ScanRequest m = MakeRequest({0, 5, 6, 1000, static_cast<std::uint32_t>(std::numeric_limits<std::int32_t>::max())});
  const Buffer b = Encoded(m);
  REQUIRE(b.size() == 8 + 26 + 5 * 4);
  CHECK(GetBe(b, 0, 8) == commerge::exchange_policy_t::getHash());
  CHECK(GetBe(b, 8, 8) == m.utime_us);
  CHECK(GetBe(b, 16, 2) == 12);
  CHECK(GetBe(b, 18, 8) == 1763799990000042);
  CHECK(GetBe(b, 26, 4) == 4242);
  CHECK(GetBe(b, kRequestNumKeyframes, 4) == 5);
  CHECK(GetBe(b, 34 + 12, 4) == 1000);
  const commerge::exchange_policy_t lcm = ToLcm(m);
  CHECK(lcm.getEncodedSize() == static_cast<int>(b.size()));
  CHECK(LcmEncode(lcm) == b);

  auto d = DecodeScanRequest(S(b));
  REQUIRE(d.ok());
  CHECK(d->utime_us == m.utime_us);
  CHECK(d->robot_id == 12);
  CHECK(d->server_session == 1763799990000042);
  CHECK(d->request_id == 4242);
  CHECK(d->keyframes == m.keyframes);

  const ScanRequest none = MakeRequest({});
  const Buffer e = Encoded(none);
  CHECK(e.size() == 34);
  auto de = DecodeScanRequest(S(e));
  REQUIRE(de.ok());
  CHECK(de->keyframes.empty());
  CHECK(de->request_id == 4242);
}

TEST_CASE("message codec: scan chunk round trip keeps the payload bytes identical") {
  const ScanChunk m = MakeChunk(kMaxScanChunkPayloadBytes);
  const Buffer b = Encoded(m);
  REQUIRE(b.size() == 8 + 30 + 1200);
  CHECK(GetBe(b, 0, 8) == commerge::scan_chunk_t::getHash());
  CHECK(GetBe(b, 16, 2) == 5);
  CHECK(GetBe(b, 18, 4) == -1);
  CHECK(GetBe(b, 22, 4) == 123456);
  CHECK(GetBe(b, 26, 4) == 3000);
  CHECK(GetBe(b, 30, 2) == 2);
  CHECK(GetBe(b, 32, 2) == 3);
  CHECK(GetBe(b, kChunkNumBytes, 4) == 1200);
  CHECK(std::memcmp(b.data() + 38, m.payload.data(), 1200) == 0);
  const commerge::scan_chunk_t lcm = ToLcm(m);
  CHECK(lcm.getEncodedSize() == static_cast<int>(b.size()));
  CHECK(LcmEncode(lcm) == b);

  auto d = DecodeScanChunk(S(b));
  REQUIRE(d.ok());
  CHECK(d->utime_us == m.utime_us);
  CHECK(d->robot_id == 5);
  CHECK(d->request_id == -1);
  CHECK(d->keyframe == 123456);
  CHECK(d->total_bytes == 3000);
  CHECK(d->chunk_index == 2);
  CHECK(d->num_chunks == 3);
  CHECK(d->payload == m.payload);

  ScanChunk empty;  // an empty scan: one chunk of no bytes
  empty.total_bytes = 0;
  const Buffer e = Encoded(empty);
  CHECK(e.size() == 38);
  auto de = DecodeScanChunk(S(e));
  REQUIRE(de.ok());
  CHECK(de->payload.empty());
  CHECK(de->num_chunks == 1);
  CHECK(de->chunk_index == 0);
}

TEST_CASE("message codec: the encoded bytes are exactly what lcm publish of the generated type delivers") {
  lcm::LCM lcm("memq://");
  REQUIRE(lcm.good());
  std::vector<std::pair<std::string, Buffer>> got;
  for (const char* ch : {kKeyframesChannel, kPosesChannel, kPolicyChannel, kScansChannel}) {
    lcm.subscribeFunction(ch, &KeepBytes, &got);
  }
  const KeyframeBatch batch = MakeBatch(2);
  const ScanRequest request = MakeRequest({3, 9, 27});
  const ScanChunk chunk = MakeChunk(17);
  // Poses whose float quaternion and translation are exact, so the generated message can be built by hand:
  // identity and the half turns about x and z (Eigen gives the quaternion its positive non-zero component).
  PoseUpdate poses;
  poses.robot_id = 4;
  poses.session = 77;
  poses.sequence = 2;
  poses.keyframes = {1, 4, 8};
  poses.no_descriptor = {0, 1, 0};
  poses.T_map_sensor.assign(3, Eigen::Isometry3d::Identity());
  poses.T_map_sensor[0].translation() = Eigen::Vector3d(1.5, -2.25, 100.125);
  poses.T_map_sensor[1].linear() = Eigen::Vector3d(1, -1, -1).asDiagonal();
  poses.T_map_sensor[2].linear() = Eigen::Vector3d(-1, -1, 1).asDiagonal();
  poses.T_map_sensor[2].translation() = Eigen::Vector3d(0.5, 0.25, -8.0);
  commerge::pose_update_t pose_msg;
  pose_msg.utime = 0;
  pose_msg.robot_id = 4;
  pose_msg.session = 77;
  pose_msg.sequence = 2;
  pose_msg.num_poses = 3;
  REQUIRE(EncodeCompactPoses(Span<const std::uint32_t>(poses.keyframes), Span<const Eigen::Isometry3d>(poses.T_map_sensor),
                             Span<const std::uint8_t>(poses.no_descriptor), &pose_msg.poses)
              .ok());
  pose_msg.num_pose_bytes = static_cast<std::int32_t>(pose_msg.poses.size());

  const commerge::keyframe_batch_t batch_msg = ToLcm(batch);
  const commerge::exchange_policy_t request_msg = ToLcm(request);
  const commerge::scan_chunk_t chunk_msg = ToLcm(chunk);
  REQUIRE(lcm.publish(kKeyframesChannel, &batch_msg) == 0);
  REQUIRE(lcm.publish(kPosesChannel, &pose_msg) == 0);
  REQUIRE(lcm.publish(kPolicyChannel, &request_msg) == 0);
  REQUIRE(lcm.publish(kScansChannel, &chunk_msg) == 0);
  while (lcm.handleTimeout(0) > 0) {
  }
  REQUIRE(got.size() == 4);
  CHECK(got[0].first == kKeyframesChannel);
  CHECK(got[0].second == Encoded(batch));
  CHECK(got[1].first == kPosesChannel);
  CHECK(got[1].second == Encoded(poses));
  CHECK(got[2].first == kPolicyChannel);
  CHECK(got[2].second == Encoded(request));
  CHECK(got[3].first == kScansChannel);
  CHECK(got[3].second == Encoded(chunk));
}

TEST_CASE("message codec: every decoder refuses a foreign message type by its fingerprint") {
  const Buffer batch = Encoded(MakeBatch(1));
  const Buffer poses = Encoded(MakePoseUpdate(1));
  const Buffer request = Encoded(MakeRequest({1, 2, 3, 4, 5}));
  const Buffer chunk = Encoded(MakeChunk(10));
  const Buffer status = LcmEncode(SampleRobotStatusT());
  // Every buffer is at least as long as the longest header (38 bytes), so the fingerprint decides.
  for (const Buffer* b : {&batch, &poses, &request, &chunk, &status}) REQUIRE(b->size() >= 38);

  auto check = [](const Buffer& b, bool is_batch, bool is_poses, bool is_request, bool is_chunk) {
    const AllDecoders all = DecodeWithAll(b);
    if (is_batch) {
      CHECK(all.batch.ok());
    } else {
      CheckDataLoss(all.batch, {"keyframe_batch_t", "fingerprint"});
    }
    if (is_poses) {
      CHECK(all.poses.ok());
    } else {
      CheckDataLoss(all.poses, {"pose_update_t", "fingerprint"});
    }
    if (is_request) {
      CHECK(all.request.ok());
    } else {
      CheckDataLoss(all.request, {"exchange_policy_t", "fingerprint"});
    }
    if (is_chunk) {
      CHECK(all.chunk.ok());
    } else {
      CheckDataLoss(all.chunk, {"scan_chunk_t", "fingerprint"});
    }
  };
  check(batch, true, false, false, false);
  check(poses, false, true, false, false);
  check(request, false, false, true, false);
  check(chunk, false, false, false, true);
  check(status, false, false, false, false);

  // One flipped bit in the fingerprint of an otherwise valid buffer.
  for (std::size_t byte : {std::size_t{0}, std::size_t{7}}) {
    Buffer bad = chunk;
    bad[byte] ^= 0x01;
    CheckDataLoss(DecodeScanChunk(S(bad)), {"fingerprint"});
  }
  // A foreign message shorter than our header is refused too (whatever the reason given).
  PoseUpdate empty_poses;
  const Buffer short_foreign = Encoded(empty_poses);  // 34 bytes
  CHECK(DecodeScanChunk(S(short_foreign)).status().code() == StatusCode::kDataLoss);
  CHECK(DecodeKeyframeBatch(S(short_foreign)).status().code() == StatusCode::kDataLoss);
}

TEST_CASE("message codec: every truncation of a valid buffer is refused") {
  CheckEveryTruncationRefused(Encoded(MakeBatch(1)), DecodeKeyframeBatch, "keyframe_batch_t");
  CheckEveryTruncationRefused(Encoded(MakePoseUpdate(2)), DecodePoseUpdate, "pose_update_t");
  CheckEveryTruncationRefused(Encoded(MakeRequest({1, 2, 3, 4, 5})), DecodeScanRequest, "exchange_policy_t");
  CheckEveryTruncationRefused(Encoded(MakeChunk(10)), DecodeScanChunk, "scan_chunk_t");
}

TEST_CASE("message codec: trailing bytes after a valid message are refused") {
  CheckTrailingBytesRefused(Encoded(MakeBatch(1)), DecodeKeyframeBatch, "keyframe_batch_t");
  CheckTrailingBytesRefused(Encoded(MakePoseUpdate(1)), DecodePoseUpdate, "pose_update_t");
  CheckTrailingBytesRefused(Encoded(MakeRequest({2, 4})), DecodeScanRequest, "exchange_policy_t");
  CheckTrailingBytesRefused(Encoded(MakeChunk(3)), DecodeScanChunk, "scan_chunk_t");
}

TEST_CASE("message codec: a count field patched to a huge or negative value is refused quickly, naming it") {
  using Clock = std::chrono::steady_clock;
  // A decoder that trusted the count would allocate up to 2^31 elements (seconds and gigabytes); a bounded one
  // answers in microseconds. 100 ms leaves room for emulation and a loaded machine.
  auto quick = [](Clock::time_point start) {
    CHECK(std::chrono::duration<double>(Clock::now() - start).count() < 0.1);
  };
  const std::uint32_t bad_counts[] = {0x7fffffffu, 0x80000000u, 0xffffffffu, 0x10000000u};
  for (std::uint32_t v : bad_counts) {
    INFO("patched count ", v);
    {
      Buffer b = Encoded(MakeBatch(1));
      PutBe32(&b, kBatchNumRecords, v);
      const auto t = Clock::now();
      const auto r = DecodeKeyframeBatch(S(b));
      quick(t);
      CheckDataLoss(r, {"num_records"});
    }
    {
      Buffer b = Encoded(MakeBatch(1));
      PutBe32(&b, kBatchNumRecordBytes, v);
      const auto t = Clock::now();
      const auto r = DecodeKeyframeBatch(S(b));
      quick(t);
      CheckDataLoss(r, {"num_record_bytes"});
    }
    {
      Buffer b = Encoded(MakePoseUpdate(1));
      PutBe32(&b, kPoseNumPoses, v);
      const auto t = Clock::now();
      const auto r = DecodePoseUpdate(S(b));
      quick(t);
      CheckDataLoss(r, {"num_poses"});
    }
    {
      Buffer b = Encoded(MakeRequest({1, 2}));
      PutBe32(&b, kRequestNumKeyframes, v);
      const auto t = Clock::now();
      const auto r = DecodeScanRequest(S(b));
      quick(t);
      CheckDataLoss(r, {"num_keyframes"});
    }
    {
      Buffer b = Encoded(MakeChunk(4));
      PutBe32(&b, kChunkNumBytes, v);
      const auto t = Clock::now();
      const auto r = DecodeScanChunk(S(b));
      quick(t);
      CheckDataLoss(r, {"num_bytes"});
    }
  }
  // Counts within MAX but beyond what the buffer holds.
  {
    // A list of 2 poses announced as 4096 or as 3 (it cannot hold 4096, and ends early for 3); a byte count
    // beyond the buffer is refused before decoding.
    Buffer b = Encoded(MakePoseUpdate(2));
    PutBe32(&b, kPoseNumPoses, 4096);
    CheckDataLoss(DecodePoseUpdate(S(b)), {"pose_update_t", "cannot hold 4096 poses"});
    PutBe32(&b, kPoseNumPoses, 3);
    CheckDataLoss(DecodePoseUpdate(S(b)), {"pose_update_t", "compact pose list: pose 2", "ends early"});
    Buffer c = Encoded(MakePoseUpdate(2));
    PutBe32(&c, kPoseNumPoses + 4, 262144);
    CheckDataLoss(DecodePoseUpdate(S(c)), {"pose_update_t", "cannot hold"});
    Buffer d = Encoded(MakePoseUpdate(2));
    PutBe32(&d, kPoseNumPoses + 4, 262145);
    CheckDataLoss(DecodePoseUpdate(S(d)), {"num_pose_bytes = 262145"});
    Buffer e = Encoded(MakePoseUpdate(2));
    PutBe32(&e, kPoseNumPoses, 0);
    CheckDataLoss(DecodePoseUpdate(S(e)), {"0 bytes exactly for 0 poses"});
  }
  {
    Buffer b = Encoded(MakeBatch(1));
    PutBe32(&b, kBatchNumRecords, 512);
    PutBe32(&b, kBatchNumRecordBytes, 512 * 92);
    CHECK(DecodeKeyframeBatch(S(b)).status().code() == StatusCode::kDataLoss);
  }
  {
    Buffer b = Encoded(MakeRequest({1, 2}));
    PutBe32(&b, kRequestNumKeyframes, 65536);
    CHECK(DecodeScanRequest(S(b)).status().code() == StatusCode::kDataLoss);
  }
  {
    Buffer b = Encoded(MakeChunk(4));
    PutBe32(&b, kChunkNumBytes, 1200);
    CHECK(DecodeScanChunk(S(b)).status().code() == StatusCode::kDataLoss);
  }
}

TEST_CASE("message codec: encoders refuse arrays beyond MAX and inconsistent sizes, and accept exactly MAX") {
  Buffer out;
  {
    KeyframeBatch m;
    m.records.assign(513 * 92, 0);
    m.stored_points.assign(513, 0);
    CheckInvalid(EncodeKeyframeBatch(m, &out), {"keyframe_batch_t", "512"});
    m.records.assign(512 * 92, 0);
    m.stored_points.assign(512, 0);
    REQUIRE(EncodeKeyframeBatch(m, &out).ok());
    CHECK(out.size() == kBatchRecords + 512 * 96 + 4 + 4);
    KeyframeBatch mismatch = MakeBatch(2);
    mismatch.stored_points.push_back(1);
    CheckInvalid(EncodeKeyframeBatch(mismatch, &out), {"keyframe_batch_t", "point counts"});
    // A compact batch carries its point counts in its stream, none beside it.
    KeyframeBatch compact;
    compact.record_kind = KeyframeRecordKind::kCompact40;
    compact.records.assign(40, 1);
    compact.num_compact_records = 3;
    REQUIRE(EncodeKeyframeBatch(compact, &out).ok());
    CHECK(out.size() == kBatchRecords + 40 + 4 + 4);
    compact.stored_points.assign(3, 5);
    CheckInvalid(EncodeKeyframeBatch(compact, &out), {"keyframe_batch_t", "point counts"});
    KeyframeBatch ragged = MakeBatch(1);
    ragged.records.push_back(0);  // 93 bytes
    CheckInvalid(EncodeKeyframeBatch(ragged, &out), {"keyframe_batch_t", "record bytes"});
  }
  {
    PoseUpdate m;
    m.keyframes.assign(4097, 0);
    m.T_map_sensor.assign(4097, Eigen::Isometry3d::Identity());
    CheckInvalid(EncodePoseUpdate(m, &out), {"pose_update_t", "4096"});
    m.keyframes.assign(4096, 0);
    m.T_map_sensor.assign(4096, Eigen::Isometry3d::Identity());
    REQUIRE(EncodePoseUpdate(m, &out).ok());
    CHECK(out.size() <= 38 + commerge::pose_update_t::MAX_POSE_BYTES);
    auto full = DecodePoseUpdate(S(out));
    REQUIRE(full.ok());
    CHECK(full->keyframes.size() == 4096);
    PoseUpdate mismatch = MakePoseUpdate(2);
    mismatch.keyframes.push_back(99);
    CheckInvalid(EncodePoseUpdate(mismatch, &out), {"pose_update_t", "3 keyframes and 2 poses"});
    PoseUpdate nan = MakePoseUpdate(2);
    nan.T_map_sensor[1].translation().y() = std::numeric_limits<double>::quiet_NaN();
    CheckInvalid(EncodePoseUpdate(nan, &out), {"pose_update_t", "pose 1", "not finite"});
    PoseUpdate inf = MakePoseUpdate(1);
    inf.T_map_sensor[0].linear()(0, 0) = std::numeric_limits<double>::infinity();
    CheckInvalid(EncodePoseUpdate(inf, &out), {"pose_update_t", "pose 0"});
  }
  {
    ScanRequest m;
    m.keyframes.resize(65537);
    for (std::size_t i = 0; i < m.keyframes.size(); ++i) m.keyframes[i] = static_cast<std::uint32_t>(i);
    CheckInvalid(EncodeScanRequest(m, &out), {"exchange_policy_t", "65537"});
    m.keyframes.pop_back();
    REQUIRE(EncodeScanRequest(m, &out).ok());
    CHECK(out.size() == 34 + 65536 * 4);
    auto d = DecodeScanRequest(S(out));
    REQUIRE(d.ok());
    CHECK(d->keyframes.size() == 65536);
    CHECK(d->keyframes.back() == 65535);
  }
  {
    ScanChunk m = MakeChunk(1201);
    CheckInvalid(EncodeScanChunk(m, &out), {"scan_chunk_t", "1201 payload bytes"});
    m = MakeChunk(10);
    m.chunk_index = 3;  // == num_chunks
    CheckInvalid(EncodeScanChunk(m, &out), {"scan_chunk_t", "chunk 3 of 3"});
    m.chunk_index = 0;
    m.num_chunks = 0;
    CheckInvalid(EncodeScanChunk(m, &out), {"scan_chunk_t"});
    m.num_chunks = 32768;  // beyond int16
    CheckInvalid(EncodeScanChunk(m, &out), {"scan_chunk_t"});
    m.num_chunks = 32767;
    m.chunk_index = 32766;
    REQUIRE(EncodeScanChunk(m, &out).ok());
    auto d = DecodeScanChunk(S(out));
    REQUIRE(d.ok());
    CHECK(d->num_chunks == 32767);
    CHECK(d->chunk_index == 32766);
    m = MakeChunk(10);
    m.keyframe = 0x80000000u;  // beyond int32
    CheckInvalid(EncodeScanChunk(m, &out), {"scan_chunk_t"});
  }
}

TEST_CASE("message codec: decoders refuse counts beyond MAX in otherwise well-formed LCM messages") {
  {
    commerge::keyframe_batch_t msg{};
    msg.record_kind = commerge::keyframe_batch_t::RECORD_UNIT40;
    msg.num_records = 513;
    msg.num_record_bytes = 513 * 92;
    msg.records.assign(513 * 92, 0);
    msg.num_stored_points = 513;
    msg.stored_points.assign(513, 0);
    const Buffer b = LcmEncode(msg);
    LcmDecode<commerge::keyframe_batch_t>(b);  // the generated type itself accepts it
    CheckDataLoss(DecodeKeyframeBatch(S(b)), {"keyframe_batch_t", "num_records = 513", "0..512"});
  }
  {
    commerge::pose_update_t msg{};
    msg.num_poses = 4097;
    msg.num_pose_bytes = 4097;
    msg.poses.assign(4097, 0);
    const Buffer b = LcmEncode(msg);
    CheckDataLoss(DecodePoseUpdate(S(b)), {"pose_update_t", "num_poses = 4097", "0..4096"});
  }
  {
    commerge::exchange_policy_t msg{};
    msg.num_keyframes = 65537;
    msg.keyframe_index.resize(65537);
    for (std::size_t i = 0; i < msg.keyframe_index.size(); ++i) msg.keyframe_index[i] = static_cast<std::int32_t>(i);
    const Buffer b = LcmEncode(msg);
    CheckDataLoss(DecodeScanRequest(S(b)), {"exchange_policy_t", "num_keyframes = 65537", "0..65536"});
  }
  {
    commerge::scan_chunk_t msg{};
    msg.num_chunks = 1;
    msg.num_bytes = 1201;
    msg.payload.assign(1201, 0xAB);
    const Buffer b = LcmEncode(msg);
    CheckDataLoss(DecodeScanChunk(S(b)), {"scan_chunk_t", "num_bytes = 1201", "0..1200"});
  }
}

TEST_CASE("message codec: robot_id outside 0..63 is refused by encoders and decoders") {
  Buffer out;
  for (int id : {-1, 64, 1000}) {
    INFO("robot_id ", id);
    KeyframeBatch b = MakeBatch(1);
    b.robot_id = id;
    CheckInvalid(EncodeKeyframeBatch(b, &out), {"keyframe_batch_t", "robot_id"});
    PoseUpdate p = MakePoseUpdate(1);
    p.robot_id = id;
    CheckInvalid(EncodePoseUpdate(p, &out), {"pose_update_t", "robot_id"});
    ScanRequest r = MakeRequest({1});
    r.robot_id = id;
    CheckInvalid(EncodeScanRequest(r, &out), {"exchange_policy_t", "robot_id"});
    ScanChunk c = MakeChunk(2);
    c.robot_id = id;
    CheckInvalid(EncodeScanChunk(c, &out), {"scan_chunk_t", "robot_id"});
  }
  for (std::int16_t id : {std::int16_t{-1}, std::int16_t{64}, std::int16_t{32767}, std::int16_t{-32768}}) {
    INFO("robot_id ", id);
    commerge::keyframe_batch_t kb = ToLcm(MakeBatch(1));
    kb.robot_id = id;
    CheckDataLoss(DecodeKeyframeBatch(S(LcmEncode(kb))), {"keyframe_batch_t", "robot_id"});
    commerge::pose_update_t pu = LcmDecode<commerge::pose_update_t>(Encoded(MakePoseUpdate(1)));
    pu.robot_id = id;
    CheckDataLoss(DecodePoseUpdate(S(LcmEncode(pu))), {"pose_update_t", "robot_id"});
    commerge::exchange_policy_t ep = ToLcm(MakeRequest({1}));
    ep.robot_id = id;
    CheckDataLoss(DecodeScanRequest(S(LcmEncode(ep))), {"exchange_policy_t", "robot_id"});
    commerge::scan_chunk_t sc = ToLcm(MakeChunk(2));
    sc.robot_id = id;
    CheckDataLoss(DecodeScanChunk(S(LcmEncode(sc))), {"scan_chunk_t", "robot_id"});
  }
  // The bounds themselves pass both ways.
  for (int id : {0, 63}) {
    ScanChunk c = MakeChunk(2);
    c.robot_id = id;
    auto d = DecodeScanChunk(S(Encoded(c)));
    REQUIRE(d.ok());
    CHECK(d->robot_id == id);
    KeyframeBatch b = MakeBatch(1);
    b.robot_id = id;
    auto db = DecodeKeyframeBatch(S(Encoded(b)));
    REQUIRE(db.ok());
    CHECK(db->robot_id == id);
  }
}

TEST_CASE("message codec: a scan request whose keyframes are not ascending and non-negative is refused") {
  auto decode = [](const std::vector<std::int32_t>& keyframes) {
    commerge::exchange_policy_t msg{};
    msg.robot_id = 1;
    msg.num_keyframes = static_cast<std::int32_t>(keyframes.size());
    msg.keyframe_index = keyframes;
    return DecodeScanRequest(S(LcmEncode(msg)));
  };
  CheckDataLoss(decode({1, 3, 3}), {"keyframe_index[2] = 3", "not ascending"});
  CheckDataLoss(decode({5, 2}), {"keyframe_index[1] = 2", "not ascending"});
  CheckDataLoss(decode({-1, 2}), {"keyframe_index[0] = -1", "negative"});
  CheckDataLoss(decode({0, 7, std::numeric_limits<std::int32_t>::min()}), {"keyframe_index[2]"});
  auto ok = decode({0, 1, 9});
  REQUIRE(ok.ok());
  CHECK(ok->keyframes == std::vector<std::uint32_t>{0, 1, 9});
}

TEST_CASE("message codec: a keyframe batch whose byte count is not its record kind's per record is refused") {
  // num_stored_points: num_records, or 0 for a compact batch (-1: what the kind asks for).
  auto decode = [](std::int32_t n, std::int32_t nb, std::int8_t kind = commerge::keyframe_batch_t::RECORD_UNIT40,
                   std::int32_t np = -1) {
    commerge::keyframe_batch_t msg{};
    msg.record_kind = kind;
    msg.num_records = n;
    msg.num_record_bytes = nb;
    msg.records.assign(static_cast<std::size_t>(nb), 0);
    msg.num_stored_points = np >= 0 ? np : kind == commerge::keyframe_batch_t::RECORD_COMPACT40 ? 0 : n;
    msg.stored_points.assign(static_cast<std::size_t>(msg.num_stored_points), 0);
    return DecodeKeyframeBatch(S(LcmEncode(msg)));
  };
  CheckDataLoss(decode(2, 183), {"num_record_bytes = 183", "92 x num_records = 184"});
  CheckDataLoss(decode(2, 185), {"num_record_bytes = 185"});
  CheckDataLoss(decode(1, 0), {"num_record_bytes = 0"});
  CheckDataLoss(decode(0, 92), {"num_record_bytes = 92"});
  auto ok = decode(2, 184);
  REQUIRE(ok.ok());
  CHECK(ok->num_records() == 2);
  CHECK(ok->record_kind == KeyframeRecordKind::kUnit40);
  // Scan Context records are 1226 bytes; a kind the decoder does not know is refused before anything else.
  const std::int8_t sc = commerge::keyframe_batch_t::RECORD_SCAN_CONTEXT;
  CheckDataLoss(decode(2, 184, sc), {"num_record_bytes = 184", "1226 x num_records = 2452"});
  auto sc_ok = decode(2, 2452, sc);
  REQUIRE(sc_ok.ok());
  CHECK(sc_ok->record_kind == KeyframeRecordKind::kScanContext);
  CHECK(sc_ok->num_records() == 2);
  CheckDataLoss(decode(2, 184, 0), {"record_kind = 0"});
  CheckDataLoss(decode(2, 184, 4), {"record_kind = 4"});
  // A compact batch: one stream of 1..MAX_COMPACT_BYTES bytes holding 1..MAX_RECORDS records (its content is the
  // server's to decode).
  const std::int8_t compact = commerge::keyframe_batch_t::RECORD_COMPACT40;
  const std::int32_t max_compact = commerge::keyframe_batch_t::MAX_COMPACT_BYTES;
  CheckDataLoss(decode(0, 10, compact), {"compact batch", "num_records = 0"});
  CheckDataLoss(decode(2, 0, compact), {"compact batch", "num_record_bytes = 0"});
  CheckDataLoss(decode(2, max_compact + 1, compact), {"num_record_bytes = " + std::to_string(max_compact + 1)});
  auto compact_ok = decode(3, 57, compact);
  REQUIRE(compact_ok.ok());
  CHECK(compact_ok->record_kind == KeyframeRecordKind::kCompact40);
  CHECK(compact_ok->num_records() == 3);
  CHECK(compact_ok->records.size() == 57);
  CHECK(compact_ok->stored_points.empty());
  // Point counts beside a compact stream, or not one per record of a fixed-size kind, are refused.
  CheckDataLoss(decode(3, 57, compact, 3), {"num_stored_points = 3 is not 0", "compact batch"});
  CheckDataLoss(decode(2, 184, commerge::keyframe_batch_t::RECORD_UNIT40, 1), {"num_stored_points = 1 is not 2"});
  CheckDataLoss(decode(2, 184, commerge::keyframe_batch_t::RECORD_UNIT40, 0), {"num_stored_points = 0 is not 2"});
  // A negative stored point count is refused too.
  commerge::keyframe_batch_t msg = ToLcm(MakeBatch(2));
  msg.stored_points[1] = -4;
  CheckDataLoss(DecodeKeyframeBatch(S(LcmEncode(msg))), {"stored_points[1] = -4", "negative"});
}

TEST_CASE("message codec: a pose update whose pose list holds values no encoder writes is refused") {
  // Lists written by hand with the stream's own writer (core/common/exp_golomb.hpp), one pose each: index EG(0),
  // 3 zig-zagged grid values EG(0), 4 x 16-bit quaternion codes, the flag bit; header orders 0.
  auto list = [](std::uint64_t index, std::int64_t x, std::array<std::int64_t, 4> q, std::uint64_t flag) {
    std::vector<std::uint8_t> bytes;
    BitWriter w(&bytes);
    for (int k = 0; k < 3; ++k) w.Put(0, kExpGolombOrderBits);
    w.PutExpGolomb(index, 0);
    for (std::int64_t t : {x, std::int64_t{2000}, std::int64_t{-3000}}) w.PutExpGolomb(ZigZag(t), 0);
    for (std::int64_t c : q) w.Put(static_cast<std::uint64_t>(c) & 0xFFFFu, 16);
    w.Put(flag, 1);
    return bytes;
  };
  auto decode = [](const std::vector<std::uint8_t>& poses) {
    commerge::pose_update_t msg{};
    msg.robot_id = 2;
    msg.num_poses = 1;
    msg.num_pose_bytes = static_cast<std::int32_t>(poses.size());
    msg.poses = poses;
    return DecodePoseUpdate(S(LcmEncode(msg)));
  };
  const std::array<std::int64_t, 4> half_turn{0, 0, 0, 32767};
  auto ok = decode(list(4, 1000, half_turn, 1));
  REQUIRE(ok.ok());
  REQUIRE(ok->keyframes == std::vector<std::uint32_t>{4});
  CHECK(ok->no_descriptor == std::vector<std::uint8_t>{1});
  CHECK((ok->T_map_sensor[0].translation() - Eigen::Vector3d(1.0, 2.0, -3.0)).norm() < 1e-12);
  CHECK(RotationErrorRad(ok->T_map_sensor[0].linear(), Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitZ()).toRotationMatrix()) <
        1e-9);
  CheckDataLoss(decode(list(4, 1000, {0, 0, 0, 0}, 0)), {"pose_update_t", "pose 0", "all-zero quaternion"});
  CheckDataLoss(decode(list(4, 1000, {-32768, 0, 0, 0}, 0)), {"pose 0", "quaternion code -32768"});
  CheckDataLoss(decode(list(std::uint64_t{1} << 31, 1000, half_turn, 0)), {"pose 0", "keyframe index"});
  CheckDataLoss(decode(list(4, std::int64_t{1} << 43, half_turn, 0)), {"pose 0", "translation beyond"});
  std::vector<std::uint8_t> padded = list(4, 1000, half_turn, 0);
  padded.push_back(0);
  CheckDataLoss(decode(padded), {"pose 0", "after the last pose"});
}

TEST_CASE("message codec: a scan chunk with chunk_index outside 0..num_chunks-1 or negative ids is refused") {
  auto decode = [](std::int16_t index, std::int16_t count, std::int32_t keyframe, std::int32_t total) {
    commerge::scan_chunk_t msg = ToLcm(MakeChunk(5));
    msg.chunk_index = index;
    msg.num_chunks = count;
    msg.keyframe_index = keyframe;
    msg.total_bytes = total;
    return DecodeScanChunk(S(LcmEncode(msg)));
  };
  CheckDataLoss(decode(3, 3, 1, 100), {"scan_chunk_t", "chunk 3 of 3", "out of range"});
  CheckDataLoss(decode(7, 3, 1, 100), {"chunk 7 of 3"});
  CheckDataLoss(decode(0, 0, 1, 100), {"chunk 0 of 0"});
  CheckDataLoss(decode(-1, 3, 1, 100), {"chunk -1 of 3"});
  CheckDataLoss(decode(0, -2, 1, 100), {"of -2"});
  CheckDataLoss(decode(0, 1, -1, 100), {"keyframe -1"});
  CheckDataLoss(decode(0, 1, 1, -100), {"total -100 bytes"});
  auto ok = decode(2, 3, 1, 100);
  REQUIRE(ok.ok());
  CHECK(ok->chunk_index == 2);
  CHECK(ok->num_chunks == 3);
}

TEST_CASE("message codec: the encoder refuses a request whose keyframes are not ascending and unique") {
  Buffer out;
  ScanRequest r = MakeRequest({1, 5, 5});
  CheckInvalid(EncodeScanRequest(r, &out), {"ascending", "keyframe_index[2]"});
  r = MakeRequest({7, 3});
  CHECK(EncodeScanRequest(r, &out).code() == StatusCode::kInvalidArgument);
}

TEST_CASE("message codec: a short buffer announcing large arrays is refused before decoding") {
  // Headers only, counts patched to the largest legal values: the announced arrays are not there.
  Buffer request = Encoded(MakeRequest({}));
  PutBe32(&request, kRequestNumKeyframes, 65536);
  CheckDataLoss(DecodeScanRequest(S(request)), {"cannot hold"});
  Buffer chunk = Encoded(MakeChunk(0));
  PutBe32(&chunk, kChunkNumBytes, 1200);
  CheckDataLoss(DecodeScanChunk(S(chunk)), {"cannot hold"});
  Buffer batch = Encoded(MakeBatch(0));
  PutBe32(&batch, kBatchNumRecords, 512);
  PutBe32(&batch, kBatchNumRecordBytes, 512 * 92);
  CheckDataLoss(DecodeKeyframeBatch(S(batch)), {"cannot hold"});
}

TEST_CASE("message codec: a short foreign message is refused by its fingerprint") {
  const Buffer tiny = Encoded(MakeRequest({}));  // 34 bytes: shorter than a scan chunk's header (38)
  CheckDataLoss(DecodeScanChunk(S(tiny)), {"fingerprint"});
}

TEST_CASE("message codec: session ids travel as int64 at their offsets in batches, pose updates and requests") {
  for (std::int64_t session : {std::int64_t{1}, std::int64_t{1763799999123456}, std::numeric_limits<std::int64_t>::max(),
                               std::int64_t{0}, std::int64_t{-7}}) {
    INFO("session ", session);
    KeyframeBatch batch = MakeBatch(1);
    batch.session = session;
    const Buffer bb = Encoded(batch);
    CHECK(GetBe(bb, 18, 8) == session);  // after the fingerprint, utime and robot_id
    CHECK(bb == LcmEncode(ToLcm(batch)));
    auto db = DecodeKeyframeBatch(S(bb));
    REQUIRE(db.ok());
    CHECK(db->session == session);

    PoseUpdate poses = MakePoseUpdate(1);
    poses.session = session;
    const Buffer pb = Encoded(poses);
    CHECK(GetBe(pb, 18, 8) == session);
    auto dp = DecodePoseUpdate(S(pb));
    REQUIRE(dp.ok());
    CHECK(dp->session == session);

    ScanRequest request = MakeRequest({4});
    request.server_session = session;
    const Buffer rb = Encoded(request);
    CHECK(GetBe(rb, 18, 8) == session);
    CHECK(rb == LcmEncode(ToLcm(request)));
    auto dr = DecodeScanRequest(S(rb));
    REQUIRE(dr.ok());
    CHECK(dr->server_session == session);
  }
}

TEST_CASE("message codec: pose update no_descriptor is empty or one 0 or 1 flag per keyframe") {
  // Empty: all 0 on the wire, and the decoder fills one flag per pose.
  PoseUpdate m = MakePoseUpdate(3);
  m.no_descriptor.clear();
  const Buffer b = Encoded(m);
  PoseUpdate zeros = m;
  zeros.no_descriptor = {0, 0, 0};
  CHECK(Encoded(zeros) == b);
  auto d = DecodePoseUpdate(S(b));
  REQUIRE(d.ok());
  CHECK(d->no_descriptor == std::vector<std::uint8_t>{0, 0, 0});
  // All 1: a pose update of keyframes without descriptors; one bit a pose more than the zeros' list differs.
  PoseUpdate ones = MakePoseUpdate(3);
  ones.no_descriptor = {1, 1, 1};
  const Buffer ob = Encoded(ones);
  CHECK(ob.size() == b.size());
  CHECK(ob != b);
  auto dones = DecodePoseUpdate(S(ob));
  REQUIRE(dones.ok());
  CHECK(dones->no_descriptor == ones.no_descriptor);
  CHECK(dones->keyframes == d->keyframes);

  // The encoder refuses another size or another value, naming the field.
  Buffer out;
  PoseUpdate wrong_size = MakePoseUpdate(3);
  wrong_size.no_descriptor = {0, 1};
  CheckInvalid(EncodePoseUpdate(wrong_size, &out), {"pose_update_t", "no_descriptor", "2 entries for 3 keyframes"});
  wrong_size.no_descriptor = {0, 1, 0, 1};
  CheckInvalid(EncodePoseUpdate(wrong_size, &out), {"no_descriptor", "4 entries for 3 keyframes"});
  PoseUpdate wrong_value = MakePoseUpdate(3);
  wrong_value.no_descriptor = {0, 2, 1};
  CheckInvalid(EncodePoseUpdate(wrong_value, &out), {"pose_update_t", "pose 1", "no_descriptor = 2", "not 0 or 1"});
}

}  // namespace
}  // namespace commerge::platform
