// SPDX-License-Identifier: BSD-3-Clause
// The merge server's keyframe database (core/agent/keyframe_database.hpp): malformed batches and pose updates are
// refused and counted without changing the state, a keyframe beyond the capacity is not allocated, robots of
// different descriptor ids are not compared and a robot's id holds within a session, Scan Context records are
// decoded at their own width and the other kind is refused; KeyframeDatabase::Create names the value out of range.
#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/agent/keyframe_database.hpp"
#include "core/agent/merge_server.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "tests/core/agent/keyframe_batch_fixtures.hpp"
#include "tests/core/agent/merge_server_test_support.hpp"
#include "tests/core/agent/server_fixture.hpp"

using namespace commerge;
using commerge::test::MakeBatch;
using commerge::test::PaperStageA;
using commerge::test::RandomDescriptor;
using commerge::test::ShiftedPairBatches;

TEST_CASE("Merge server holds compact batches as their keyframes quantised alone, beside 92-byte records, and "
          "refuses a corrupt or inconsistent one whole") {
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, MergeServerParams{});
  MergeServer& server = *server_owner;
  std::mt19937 rng(3);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d;
  std::vector<Eigen::Vector3d> pos;
  for (int i = 0; i < 6; ++i) {
    d.push_back(RandomDescriptor(&rng));
    pos.emplace_back(1.01 * i, 0.5 * i, 0.1);
  }
  const KeyframeBatch compact = commerge::test::MakeCompactBatch(0, 4, d, pos, 700, 6);
  REQUIRE(server.OnKeyframeBatch(compact).ok());
  // The next keyframes of the same robot as 92-byte records: one database, either kind.
  REQUIRE(server.OnKeyframeBatch(MakeBatch(0, 10, d, pos, 900)).ok());
  const RobotKeyframeDb& db = server.robot(0);
  REQUIRE(db.size() == 16);
  for (std::size_t i = 0; i < d.size(); ++i) {
    CAPTURE(i);
    const std::size_t k = 4 + i;
    CHECK(db.valid[k] == 1);
    CHECK(db.stored_points[k] == 700u + 37u * i);
    CompactKeyframe alone;
    alone.pose.keyframe_index = static_cast<std::uint32_t>(k);
    alone.pose.T_map_sensor.translation() = pos[i];
    alone.descriptor = d[i];
    auto expected = QuantiseCompactKeyframe(alone, 6);
    REQUIRE(expected.ok());
    CHECK(std::equal(expected->descriptor.begin(), expected->descriptor.end(),
                     db.descriptors.begin() + static_cast<std::ptrdiff_t>(k * db.dim)));
    CHECK((db.T_map_sensor[k].translation() - pos[i]).cwiseAbs().maxCoeff() <= 0.5e-3 + 1e-12);
    CHECK(db.valid[10 + i] == 1);
  }
  CHECK(server.stats().records == 12);

  // A cut stream, a record count that does not match it, or separate point counts beside it refuse the whole
  // batch and count it.
  KeyframeBatch cut = commerge::test::MakeCompactBatch(1, 0, d, pos, 700, 6);
  cut.records.pop_back();
  CHECK(server.OnKeyframeBatch(cut).code() == StatusCode::kDataLoss);
  KeyframeBatch miscounted = commerge::test::MakeCompactBatch(1, 0, d, pos, 700, 6);
  ++miscounted.num_compact_records;
  CHECK(server.OnKeyframeBatch(miscounted).code() == StatusCode::kDataLoss);
  KeyframeBatch beside = commerge::test::MakeCompactBatch(1, 0, d, pos, 700, 6);
  beside.stored_points.assign(beside.num_compact_records, 700);
  CHECK(server.OnKeyframeBatch(beside).code() == StatusCode::kInvalidArgument);
  KeyframeBatch empty = miscounted;
  empty.records.clear();
  CHECK(server.OnKeyframeBatch(empty).code() == StatusCode::kInvalidArgument);
  CHECK(server.stats().rejected_batches == 4);
  CHECK(server.robot(1).size() == 0);
}

TEST_CASE("Merge server refuses malformed keyframe batches and pose updates and counts them") {
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, MergeServerParams{});
  MergeServer& server = *server_owner;
  std::mt19937 rng(1);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d = {RandomDescriptor(&rng), RandomDescriptor(&rng)};
  std::vector<Eigen::Vector3d> pos = {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(1, 0, 0)};
  KeyframeBatch good = MakeBatch(0, 0, d, pos, 1000);

  KeyframeBatch foreign = good;
  foreign.robot_id = 2;  // the server was sized for robots 0 and 1
  CHECK(server.OnKeyframeBatch(foreign).code() == StatusCode::kInvalidArgument);
  KeyframeBatch ragged = good;
  ragged.records.pop_back();
  CHECK_FALSE(server.OnKeyframeBatch(ragged).ok());
  CHECK(server.stats().rejected_batches == 2);
  CHECK(server.robot(0).size() == 0);

  // One corrupt record: the other is kept, the corrupt one counted.
  KeyframeBatch corrupt = good;
  corrupt.records[kKeyframeRecordBytes + 20] ^= 0xff;
  corrupt.records[kKeyframeRecordBytes + 21] ^= 0xff;
  const Status st = server.OnKeyframeBatch(corrupt);
  const bool second_refused = !st.ok();
  CHECK(server.robot(0).size() >= 1);
  CHECK(server.robot(0).valid[0] == 1);
  CHECK(server.stats().rejected_records == (second_refused ? 1u : 0u));

  // A keyframe index beyond the server's capacity is refused, not allocated.
  std::unique_ptr<MergeServer> small_owner = commerge::test::MakeTestServer(2, 1, MergeServerParams{});
  MergeServer& small = *small_owner;
  CHECK(small.OnKeyframeBatch(good).code() == StatusCode::kResourceExhausted);
  CHECK(small.robot(0).size() == 1);

  PoseUpdate update;
  update.robot_id = 0;
  update.keyframes = {0, 1};
  update.T_map_sensor = {Eigen::Isometry3d::Identity()};
  CHECK_FALSE(server.OnPoseUpdate(update).ok());  // counts differ
  update.T_map_sensor.push_back(Eigen::Isometry3d::Identity());
  update.T_map_sensor[1].translation().x() = std::nan("");
  CHECK_FALSE(server.OnPoseUpdate(update).ok());  // non-finite pose: nothing applied
  CHECK(server.stats().rejected_pose_updates == 2);
  update.T_map_sensor[1] = Eigen::Isometry3d::Identity();
  update.T_map_sensor[1].translation() = Eigen::Vector3d(5, 6, 7);
  REQUIRE(server.OnPoseUpdate(update).ok());
  CHECK(server.robot(0).T_map_sensor[1].translation().isApprox(Eigen::Vector3d(5, 6, 7)));
}

TEST_CASE("Merge server compares only robots of one descriptor id and refuses a batch that changes its robot's id") {
  // Three robots: 0 and 1 see the same places (stage A's loops are known), robot 2 the same places too but with
  // another descriptor id (a robot started with another --lidar): its descriptors are not comparable.
  const int n = 40, shift = 5;
  const std::uint32_t kId = 0x761BEAA5u, kOtherId = 0x12345678u;
  MergeServerParams params = PaperStageA(100);
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(3, 100, params);
  MergeServer& server = *server_owner;
  std::vector<KeyframeBatch> batches = ShiftedPairBatches(n, shift);
  REQUIRE(batches.size() == 2);
  KeyframeBatch third = batches[1];
  third.robot_id = 2;
  batches[0].descriptor_id = kId;
  batches[1].descriptor_id = kId;
  third.descriptor_id = kOtherId;
  for (const KeyframeBatch& b : batches) REQUIRE(server.OnKeyframeBatch(b).ok());
  REQUIRE(server.OnKeyframeBatch(third).ok());
  CHECK(server.robot(0).descriptor_id == kId);
  CHECK(server.robot(2).descriptor_id == kOtherId);

  REQUIRE(server.RunCascades().ok());
  // The control: robots 0 and 1 (same id) have their cascade, with stage A's loops.
  REQUIRE(server.cascade(0, 1) != nullptr);
  CHECK(server.cascade(0, 1)->stage_a.found);
  // Robot 2 holds the same descriptors as robot 1, so only the id keeps its pairs out.
  CHECK(server.cascade(0, 2) == nullptr);
  CHECK(server.cascade(1, 2) == nullptr);
  const std::vector<std::pair<int, int>> want = {{0, 2}, {1, 2}};
  CHECK(server.incomparable_pairs() == want);
  auto plan = server.Plan(ExchangeMode::kStageABC);
  REQUIRE(plan.ok());
  REQUIRE(plan->pairs.size() == 1);
  CHECK(plan->pairs[0].alpha == 0);
  CHECK(plan->pairs[0].beta == 1);

  // Within a session a robot's id cannot change: the batch is refused, counted and applies nothing.
  std::mt19937 rng(3);
  KeyframeBatch changed = MakeBatch(0, static_cast<std::uint32_t>(n), {RandomDescriptor(&rng)},
                                    {Eigen::Vector3d(1, 2, 3)}, 500);
  changed.descriptor_id = kOtherId;
  const std::uint64_t rejected = server.stats().rejected_batches;
  CHECK(server.CheckKeyframeBatch(changed).ok());  // what a new session of the robot, reset first, would accept
  const Status st = server.OnKeyframeBatch(changed);
  CHECK(st.code() == StatusCode::kInvalidArgument);
  CHECK(st.message().find("0x12345678") != std::string::npos);
  CHECK(st.message().find("0x761BEAA5") != std::string::npos);
  CHECK(server.stats().rejected_batches == rejected + 1);
  CHECK(server.robot(0).size() == static_cast<std::size_t>(n));
  // Id 0 (unknown) conflicts with nothing; the robot's id stays.
  changed.descriptor_id = 0;
  CHECK(server.OnKeyframeBatch(changed).ok());
  CHECK(server.robot(0).size() == static_cast<std::size_t>(n) + 1);
  CHECK(server.robot(0).descriptor_id == kId);
  // A new session (ResetRobot) may bring another id: robot 2 restarted with the team's setting joins in.
  server.ResetRobot(2);
  CHECK(server.robot(2).descriptor_id == 0u);
  third.descriptor_id = kId;
  REQUIRE(server.OnKeyframeBatch(third).ok());
  REQUIRE(server.RunCascades().ok());
  CHECK(server.incomparable_pairs().empty());
  CHECK(server.cascade(1, 2) != nullptr);
}

namespace commerge {
namespace {

// A Scan Context grid of one place: random heights in a third of its cells, its columns turned by `turn` sectors
// (the place seen with another heading), with a little noise.
std::vector<float> RandomScanContext(std::uint32_t place, int turn, std::mt19937* noise) {
  std::mt19937 rng(1000 + place);
  std::uniform_real_distribution<float> height(0.5f, 6.0f), jitter(-0.05f, 0.05f), u(0.0f, 1.0f);
  const int rings = kScanContextWireRings, sectors = kScanContextWireSectors;
  std::vector<float> base(static_cast<std::size_t>(rings * sectors));
  for (float& v : base) v = u(rng) < 0.3f ? height(rng) : 0.0f;  // structure in a third of the cells
  std::vector<float> out(base.size());
  for (int r = 0; r < rings; ++r) {
    for (int c = 0; c < sectors; ++c) {
      const float v = base[static_cast<std::size_t>(r * sectors + c)];
      out[static_cast<std::size_t>(r * sectors + (c + turn) % sectors)] = v > 0.0f ? v + jitter(*noise) : 0.0f;
    }
  }
  return out;
}

KeyframeBatch ScanContextBatch(int robot, std::uint32_t first, const std::vector<std::vector<float>>& descriptors) {
  KeyframeBatch b;
  b.robot_id = robot;
  b.record_kind = KeyframeRecordKind::kScanContext;
  const std::size_t bytes = KeyframeRecordBytesOf(KeyframeRecordKind::kScanContext);
  for (std::size_t k = 0; k < descriptors.size(); ++k) {
    KeyframePose pose;
    pose.keyframe_index = first + static_cast<std::uint32_t>(k);
    pose.T_map_sensor.translation() = Eigen::Vector3d(static_cast<double>(k), 0.0, 0.0);
    const std::size_t at = b.records.size();
    b.records.resize(at + bytes);
    REQUIRE(EncodeRecordOfKind(KeyframeRecordKind::kScanContext, pose, Span<const float>(descriptors[k]),
                               Span<std::uint8_t>(b.records.data() + at, bytes))
                .ok());
    b.stored_points.push_back(2000);
  }
  return b;
}

TEST_CASE("Merge server with Scan Context records: the other kind is refused and counted, stage A finds the "
          "revisit by the Scan Context distance") {
  MergeServerParams params;
  params.record_kind = KeyframeRecordKind::kScanContext;
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 200, params);
  MergeServer& server = *server_owner;
  CHECK(server.robot(0).dim == 1200);
  CHECK(server.params().cascade.metric.kind == DescriptorMetric::Kind::kScanContext);

  // Robot 0 drives places 0..59; robot 1 places 20..79, every place seen turned by 17 sectors (102 deg).
  const int n = 60, shift = 20;
  std::mt19937 noise(5);
  std::vector<std::vector<float>> a, b;
  for (int k = 0; k < n; ++k) a.push_back(RandomScanContext(static_cast<std::uint32_t>(k), 0, &noise));
  for (int k = 0; k < n; ++k) b.push_back(RandomScanContext(static_cast<std::uint32_t>(k + shift), 17, &noise));
  REQUIRE(server.OnKeyframeBatch(ScanContextBatch(0, 0, a)).ok());
  REQUIRE(server.OnKeyframeBatch(ScanContextBatch(1, 0, b)).ok());
  CHECK(server.stats().records == static_cast<std::uint64_t>(2 * n));

  // A robot that sends 92-byte records to this server: refused as a whole, counted, the message names both kinds.
  std::mt19937 rng(3);
  std::vector<std::array<float, kKeyframeDescriptorDim>> d = {RandomDescriptor(&rng)};
  const KeyframeBatch unit = MakeBatch(1, 100, d, {Eigen::Vector3d::Zero()}, 0);
  const std::uint64_t rejected = server.stats().rejected_batches;
  const Status refused = server.OnKeyframeBatch(unit);
  CHECK(refused.code() == StatusCode::kInvalidArgument);
  CHECK(refused.message().find("unit-40") != std::string::npos);
  CHECK(refused.message().find("scan-context") != std::string::npos);
  CHECK(refused.message().find("--descriptor") != std::string::npos);
  CHECK(server.stats().rejected_batches == rejected + 1);
  CHECK_FALSE(server.CheckKeyframeBatch(unit).ok());
  CHECK(server.robot(1).size() == static_cast<std::size_t>(n));  // nothing of it was applied

  // The decoded descriptors equal the sent ones within the record's quantisation.
  for (std::size_t t = 0; t < 1200; ++t) {
    CHECK(std::fabs(server.robot(0).descriptors[t] - a[0][t]) <= 6.05f / 255.0f);
  }

  // Stage A on the Scan Context distance: L_seq holds every cell of the true revisit (beta j sees alpha's place
  // j + shift, whatever the heading) and, through the sequence smoothing's band, nothing further from it than the
  // smoothing window (4 keyframes) plus one.
  REQUIRE(server.RunCascades().ok());
  const ExchangeCascadeResult* c = server.cascade(0, 1);
  REQUIRE(c != nullptr);
  REQUIRE(c->stage_a.found);
  std::size_t on_diagonal = 0, off_band = 0;
  for (const SequentialLoopCell& l : c->stage_a.cells) {
    const long off = static_cast<long>(l.alpha_index) - static_cast<long>(l.beta_index) - shift;
    on_diagonal += off == 0;
    off_band += std::labs(off) > 5;
  }
  CHECK(on_diagonal == static_cast<std::size_t>(n - shift));
  CHECK(off_band == 0);

  // A robot that restarts (a new session resets it) keeps the server's descriptor width: its new batch applies.
  server.ResetRobot(1);
  CHECK(server.robot(1).size() == 0);
  CHECK(server.robot(1).dim == 1200);
  REQUIRE(server.OnKeyframeBatch(ScanContextBatch(1, 0, b)).ok());
  CHECK(server.robot(1).size() == static_cast<std::size_t>(n));
  REQUIRE(server.RunCascades().ok());
  REQUIRE(server.cascade(0, 1) != nullptr);
  CHECK(server.cascade(0, 1)->stage_a.found);

  // A server of 40-value records refuses the Scan Context batch the same way.
  std::unique_ptr<MergeServer> unit_server_owner = commerge::test::MakeTestServer(2, 200, MergeServerParams{});
  MergeServer& unit_server = *unit_server_owner;
  const Status other = unit_server.OnKeyframeBatch(ScanContextBatch(0, 0, a));
  CHECK(other.code() == StatusCode::kInvalidArgument);
  CHECK(unit_server.stats().rejected_batches == 1);
  CHECK(unit_server.robot(0).size() == 0);
}

}  // namespace
}  // namespace commerge

TEST_CASE("Keyframe database: Create refuses 1 and 65 robots, 0 keyframes and a kind that is no record kind") {
  // kMaxRobotId is 63: robots 0..63, so 2..64 of them.
  CHECK(KeyframeDatabase::Create(2, 1, KeyframeRecordKind::kUnit40).ok());
  CHECK(KeyframeDatabase::Create(64, 1, KeyframeRecordKind::kUnit40).ok());
  for (int robots : {1, 65}) {
    CAPTURE(robots);
    const auto db = KeyframeDatabase::Create(robots, 100, KeyframeRecordKind::kUnit40);
    REQUIRE_FALSE(db.ok());
    CHECK(db.status().code() == StatusCode::kInvalidArgument);
    CHECK(db.status().message().find("max_robots = " + std::to_string(robots)) != std::string::npos);
  }
  const auto none = KeyframeDatabase::Create(2, 0, KeyframeRecordKind::kUnit40);
  REQUIRE_FALSE(none.ok());
  CHECK(none.status().code() == StatusCode::kInvalidArgument);
  CHECK(none.status().message().find("max_keyframes_per_robot = 0") != std::string::npos);
  for (int kind : {0, 3, 4, 255}) {  // 3: compact batches are taken by a kUnit40 database, not a kind of their own
    CAPTURE(kind);
    const auto db = KeyframeDatabase::Create(2, 100, static_cast<KeyframeRecordKind>(kind));
    REQUIRE_FALSE(db.ok());
    CHECK(db.status().code() == StatusCode::kInvalidArgument);
    CHECK(db.status().message().find("record_kind " + std::to_string(kind)) != std::string::npos);
  }
  // The kinds there are: one descriptor per record of 40 values, or the 20 x 60 Scan Context grid.
  const auto unit = KeyframeDatabase::Create(3, 10, KeyframeRecordKind::kUnit40);
  REQUIRE(unit.ok());
  CHECK(unit->max_robots() == 3);
  CHECK(unit->max_keyframes_per_robot() == 10);
  CHECK(unit->robot(2).dim == 40);
  CHECK(unit->robot(2).size() == 0);
  const auto scan_context = KeyframeDatabase::Create(2, 10, KeyframeRecordKind::kScanContext);
  REQUIRE(scan_context.ok());
  CHECK(scan_context->robot(1).dim == 20 * 60);
}

TEST_CASE("Keyframe database: its handlers count records, repeats and pose-only keyframes, ResetRobot one robot") {
  auto created = KeyframeDatabase::Create(2, 10, KeyframeRecordKind::kUnit40);
  REQUIRE(created.ok());
  KeyframeDatabase& db = *created;
  MergeServerStats stats;
  std::mt19937 rng(5);
  const std::vector<std::array<float, kKeyframeDescriptorDim>> d = {RandomDescriptor(&rng), RandomDescriptor(&rng),
                                                                    RandomDescriptor(&rng)};
  const auto at_x = [](double x) { return Eigen::Vector3d(x, 0.0, 0.0); };
  // Robot 0: keyframes 0..2 at x = 0, 1, 2 with 100, 100, 100 stored points; then keyframe 2 again and keyframe 3.
  REQUIRE(db.OnKeyframeBatch(MakeBatch(0, 0, d, {at_x(0), at_x(1), at_x(2)}, 100), &stats).ok());
  REQUIRE(db.OnKeyframeBatch(MakeBatch(0, 2, {d[2], d[0]}, {at_x(2), at_x(3)}, 50), &stats).ok());
  // Robot 1: keyframe 1 by record; keyframe 4 has no valid descriptor, only its pose.
  REQUIRE(db.OnKeyframeBatch(MakeBatch(1, 1, {d[1]}, {at_x(7)}, 80), &stats).ok());
  PoseUpdate pose_only;
  pose_only.robot_id = 1;
  pose_only.keyframes = {4};
  pose_only.T_map_sensor = {Eigen::Isometry3d(Eigen::Translation3d(9.0, 1.0, 0.0))};
  pose_only.no_descriptor = {1};
  REQUIRE(db.OnPoseUpdate(pose_only, &stats).ok());
  CHECK(stats.batches == 3);
  CHECK(stats.records == 6);           // 3 + 2 + 1
  CHECK(stats.records_repeated == 1);  // robot 0's keyframe 2
  CHECK(stats.pose_updates == 1);
  CHECK(stats.rejected_batches + stats.rejected_records + stats.rejected_pose_updates == 0);

  const RobotKeyframeDb& r0 = db.robot(0);
  REQUIRE(r0.size() == 4);
  CHECK(r0.stored_points == std::vector<std::uint32_t>{100, 100, 50, 50});
  CHECK(r0.T_map_sensor[3].translation().isApprox(Eigen::Vector3d(3, 0, 0)));
  for (std::size_t k = 0; k < 4; ++k) CHECK(r0.delivered(k));
  const RobotKeyframeDb& r1 = db.robot(1);
  REQUIRE(r1.size() == 5);  // keyframes 0..4, of which 1 and 4 arrived
  CHECK(r1.valid == std::vector<std::uint8_t>{0, 1, 0, 0, 0});
  CHECK(r1.pose_known == std::vector<std::uint8_t>{0, 1, 0, 0, 1});
  CHECK(r1.no_descriptor == std::vector<std::uint8_t>{0, 0, 0, 0, 1});
  CHECK_FALSE(r1.delivered(0));
  CHECK(r1.delivered(1));
  CHECK(r1.delivered(4));  // no descriptor will ever come: its pose is all
  CHECK_FALSE(r1.delivered(5));
  CHECK(db.StoredKeyframes(1) == std::vector<std::uint32_t>{1, 4});
  CHECK(db.StoredKeyframes(0) == std::vector<std::uint32_t>{0, 1, 2, 3});

  // A pose update beyond the capacity (10 keyframes) is refused whole: keyframe 3's pose stays.
  PoseUpdate beyond;
  beyond.robot_id = 0;
  beyond.keyframes = {3, 10};
  beyond.T_map_sensor = {Eigen::Isometry3d::Identity(), Eigen::Isometry3d::Identity()};
  CHECK(db.CheckPoseUpdate(beyond).code() == StatusCode::kResourceExhausted);
  CHECK(db.OnPoseUpdate(beyond, &stats).code() == StatusCode::kResourceExhausted);
  CHECK(stats.rejected_pose_updates == 1);
  CHECK(stats.pose_updates == 1);
  CHECK(db.robot(0).T_map_sensor[3].translation().isApprox(Eigen::Vector3d(3, 0, 0)));

  db.ResetRobot(1);
  CHECK(db.robot(1).size() == 0);
  CHECK(db.robot(1).dim == 40);
  CHECK(db.StoredKeyframes(1).empty());
  CHECK(db.robot(0).size() == 4);
  db.ResetRobot(2);  // no such robot: nothing happens
  CHECK(db.robot(0).size() == 4);
}
