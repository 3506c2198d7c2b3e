// SPDX-License-Identifier: BSD-3-Clause
// The robot agent: keyframe batches carry exactly the mapper's keyframes (decodable records with its poses and
// the store's point counts), keyframes without a valid descriptor travel as pose updates, and scan requests are
// answered with chunks that reassemble into the stored encoded scans.
#include <doctest/doctest.h>

#include <cmath>
#include <memory>
#include <vector>

#include "core/agent/robot_agent.hpp"
#include "core/cloud/scan_codec.hpp"
#include "core/descriptor/compact_batch_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/geometry/se3.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "tests/support/batch_keyframes.hpp"

using namespace commerge;

namespace {

struct AgentRig {
  std::unique_ptr<SolidDescriptor> solid;
  std::unique_ptr<ScanStore> store;
  std::unique_ptr<RobotAgent> agent;
};

AgentRig MakeRig(int robot_id, const RobotAgentParams& params) {
  AgentRig rig;
  auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneHdl64e));
  REQUIRE(solid.ok());
  rig.solid = std::make_unique<SolidDescriptor>(std::move(*solid));
  ScanStoreParams sp;
  sp.capacity_bytes = 4u << 20;
  sp.max_scans = 256;
  auto store = ScanStore::Create(sp);
  REQUIRE(store.ok());
  rig.store = std::move(*store);
  RobotMapperCapacity cap;
  cap.max_keyframes = 64;
  cap.max_points_per_raw_scan = 32 * 512;
  cap.max_points_per_stored_scan = 8192;
  rig.agent = std::make_unique<RobotAgent>(robot_id, params, cap, rig.solid.get(), rig.store.get());
  return rig;
}

SpinningLidar SmallLidar() {
  SpinningLidar lidar;
  lidar.beams = 32;
  lidar.azimuth_steps = 512;
  lidar.max_range_m = 80.0f;
  return lidar;
}

Eigen::Isometry3d PoseAtX(double x) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = Eigen::Vector3d(x, 0.0, 0.0);
  return T;
}

// Drives `n` scans 1.1 m apart along a generated street; scan `empty_at` (if >= 0) has no points.
void Drive(RobotAgent* agent, int n, int empty_at) {
  const BoxScene scene = MakeStreetScene(5, 120.0f);
  const SpinningLidar lidar = SmallLidar();
  std::vector<PointXYZI> raw;
  for (int k = 0; k < n; ++k) {
    const float x = -30.0f + 1.1f * static_cast<float>(k);
    CastScan(scene, lidar, x, -1.5f, 1.73f, 0.0f, 100u + static_cast<std::uint32_t>(k), &raw);
    if (k == empty_at) raw.clear();
    auto step = agent->AddScan(Span<const PointXYZI>(raw), PoseAtX(1.1 * k));
    REQUIRE(step.ok());
    CHECK(step->is_keyframe);
  }
}

// The keyframes of a batch of either kind a robot sends for SOLiD (92-byte records or a compact batch).
std::vector<CompactKeyframe> BatchKeyframes(const KeyframeBatch& batch) {
  auto keyframes = test::BatchKeyframes(batch);
  REQUIRE_MESSAGE(keyframes.ok(), keyframes.status().ToString());
  return *keyframes;
}

}  // namespace

TEST_CASE("Robot agent batches carry every keyframe with its pose, descriptor and stored point count") {
  // 92-byte records (0), the default compact batch, and the compact batch's finest descriptor.
  for (int bits : {0, kDefaultRecordDescriptorBits, kCompactMaxDescriptorBits}) {
  CAPTURE(bits);
  RobotAgentParams params;
  params.max_records_per_batch = 8;
  params.record_descriptor_bits = bits;
  AgentRig rig = MakeRig(3, params);
  Drive(rig.agent.get(), 20, /*empty_at=*/-1);
  const RobotMapper& mapper = rig.agent->mapper();
  REQUIRE(mapper.num_keyframes() == 20);

  std::vector<std::uint32_t> seen;
  KeyframeBatch batch;
  std::int32_t expected_sequence = 0;
  while (true) {
    auto taken = rig.agent->TakeKeyframeBatch(42, &batch);
    REQUIRE(taken.ok());
    if (!*taken) break;
    CHECK(batch.robot_id == 3);
    CHECK(batch.utime_us == 42);
    // The parameter id of the HDL-64E preset (pinned in the SOLiD tests), so the server can tell teams apart.
    CHECK(batch.descriptor_id == SolidParameterId(SolidPreset(LidarSensor::kVelodyneHdl64e)));
    CHECK(batch.descriptor_id == rig.solid->parameter_id());
    CHECK(batch.sequence == expected_sequence++);
    CHECK(batch.record_kind == (bits == 0 ? KeyframeRecordKind::kUnit40 : KeyframeRecordKind::kCompact40));
    CHECK(batch.num_records() <= 8);
    // The compact stream carries the point counts; 92-byte records carry them beside.
    REQUIRE(batch.stored_points.size() == (bits == 0 ? batch.num_records() : 0));
    const std::vector<CompactKeyframe> records = BatchKeyframes(batch);
    REQUIRE(records.size() == batch.num_records());
    for (std::size_t i = 0; i < batch.num_records(); ++i) {
      const CompactKeyframe* rec = &records[i];
      const std::uint32_t k = rec->pose.keyframe_index;
      seen.push_back(k);
      // Pose: float32 translation or the 1 mm grid, quaternion codes.
      CHECK((rec->pose.T_map_sensor.translation() - mapper.pose(k).translation()).norm() < (bits == 0 ? 1e-4 : 1e-3));
      CHECK(RotationAngleRad(rec->pose.T_map_sensor.linear().transpose() * mapper.pose(k).linear()) < 2e-4);
      // Descriptor: the mapper's, quantised to 14 bits or the batch's.
      const Span<const float> d = mapper.descriptor(k);
      double err = 0.0;
      for (std::size_t j = 0; j < kKeyframeDescriptorDim; ++j) err = std::max(err, std::abs(double(d[j]) - double(rec->descriptor[j])));
      CHECK(err < (bits == 0 ? 1e-3 : 1.5 / ((1 << bits) - 1)));
      auto view = rig.store->View(k);
      REQUIRE(view.ok());
      CHECK(rec->stored_points == ParseScanHeader(*view)->num_points);
      CHECK(rec->stored_points > 100);
    }
  }
  CHECK(expected_sequence == 3);  // 8 + 8 + 4
  REQUIRE(seen.size() == 20);
  for (std::uint32_t k = 0; k < 20; ++k) CHECK(seen[k] == k);
  CHECK(rig.agent->keyframes_sent() == 20);
  PoseUpdate update;
  CHECK_FALSE(rig.agent->TakePoseUpdate(0, &update));  // no loop, nothing moved
  }
}

TEST_CASE("Robot agent sends the pose of a keyframe without a valid descriptor as a pose update") {
  AgentRig rig = MakeRig(0, RobotAgentParams{});
  Drive(rig.agent.get(), 6, /*empty_at=*/2);
  REQUIRE(rig.agent->mapper().num_keyframes() == 6);
  REQUIRE_FALSE(rig.agent->mapper().descriptor_valid(2));
  KeyframeBatch batch;
  auto taken = rig.agent->TakeKeyframeBatch(0, &batch);
  REQUIRE(taken.ok());
  REQUIRE(*taken);
  CHECK(batch.num_records() == 5);
  for (const CompactKeyframe& rec : BatchKeyframes(batch)) CHECK(rec.pose.keyframe_index != 2u);
  PoseUpdate update;
  REQUIRE(rig.agent->TakePoseUpdate(0, &update));
  REQUIRE(update.keyframes.size() == 1);
  CHECK(update.keyframes[0] == 2u);
  CHECK((update.T_map_sensor[0].translation() - rig.agent->mapper().pose(2).translation()).norm() < 1e-12);
  CHECK_FALSE(rig.agent->TakePoseUpdate(0, &update));
}

TEST_CASE("Robot agent answers a scan request with chunks that reassemble into the stored scans") {
  RobotAgentParams params;
  params.chunk_payload_bytes = 500;
  AgentRig rig = MakeRig(1, params);
  Drive(rig.agent.get(), 8, -1);
  ScanRequest request;
  request.robot_id = 1;
  request.request_id = 7;
  request.keyframes = {0, 5, 7, 100};
  std::vector<ScanChunk> chunks;
  PoseUpdate poses;
  auto answer = rig.agent->AnswerRequest(request, 9, &chunks, &poses);
  REQUIRE(answer.ok());
  CHECK(answer->scans_sent == 3);
  REQUIRE(answer->missing.size() == 1);
  CHECK(answer->missing[0] == 100u);
  CHECK(answer->chunks == chunks.size());
  std::uint64_t bytes = 0;
  for (std::uint32_t k : {0u, 5u, 7u}) {
    std::vector<std::uint8_t> stored;
    REQUIRE(rig.store->CopyEncoded(k, &stored).ok());
    std::vector<std::uint8_t> rebuilt(stored.size(), 0);
    std::size_t count = 0;
    for (const ScanChunk& c : chunks) {
      if (c.keyframe != k) continue;
      ++count;
      CHECK(c.robot_id == 1);
      CHECK(c.request_id == 7);
      CHECK(c.utime_us == 9);
      CHECK(c.total_bytes == stored.size());
      CHECK(c.payload.size() <= 500);
      const ChunkRange r = ScanChunkRange(c.total_bytes, c.num_chunks, c.chunk_index);
      REQUIRE(r.size == c.payload.size());
      std::copy(c.payload.begin(), c.payload.end(), rebuilt.begin() + static_cast<std::ptrdiff_t>(r.offset));
    }
    CHECK(count == (stored.size() + 499) / 500);
    CHECK(rebuilt == stored);
    bytes += stored.size();
  }
  CHECK(answer->scan_bytes == bytes);

  ScanRequest foreign = request;
  foreign.robot_id = 2;
  auto refused = rig.agent->AnswerRequest(foreign, 0, &chunks, &poses);
  CHECK_FALSE(refused.ok());
  CHECK(refused.status().code() == StatusCode::kInvalidArgument);
}

TEST_CASE("Scan chunk ranges tile the scan exactly and never leave an empty last chunk") {
  std::size_t bad = 0, cases = 0;
  for (std::uint64_t total = 1; total < 3000; total += 7) {
    for (std::uint64_t max_payload : {1ull, 3ull, 64ull, 1200ull}) {
      const std::uint64_t n = ScanChunkCount(total, max_payload);
      std::uint64_t next = 0;
      for (std::uint64_t i = 0; i < n; ++i) {
        const ChunkRange r = ScanChunkRange(total, n, i);
        bad += r.offset != next || r.size < 1 || r.size > max_payload;
        next += r.size;
      }
      bad += next != total;
      ++cases;
    }
  }
  CHECK(cases > 1500);
  CHECK(bad == 0);
  CHECK(ScanChunkRange(10, 0, 0).size == 0);
  CHECK(ScanChunkRange(10, 2, 2).size == 0);
}

TEST_CASE("Robot agent refuses parameters outside their ranges") {
  RobotAgentParams p;
  p.max_records_per_batch = 0;
  CHECK_FALSE(ValidateRobotAgentParams(p).ok());
  p = RobotAgentParams{};
  p.chunk_payload_bytes = kMaxScanChunkPayloadBytes + 1;
  CHECK_FALSE(ValidateRobotAgentParams(p).ok());
  p = RobotAgentParams{};
  p.pose_update_min_translation_m = -1.0;
  CHECK_FALSE(ValidateRobotAgentParams(p).ok());
  AgentRig rig = MakeRig(64, RobotAgentParams{});  // robot id beyond 63
  std::vector<PointXYZI> none;
  CHECK_FALSE(rig.agent->AddScan(Span<const PointXYZI>(none), Eigen::Isometry3d::Identity()).ok());
}
