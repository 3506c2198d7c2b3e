// SPDX-License-Identifier: BSD-3-Clause
// Memory of the budget modules as the agents report it (RobotAgent::MemoryUse, MergeServer::MemoryUse): the
// names follow the budget tables, each figure equals an independent count of the pools (keyframes x record
// size, the store's records, the containers' capacities), the high-water mark is never below the current use
// and stays after the data is dropped.
#include <doctest/doctest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <initializer_list>
#include <memory>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "tests/core/agent/server_fixture.hpp"
#include "core/agent/merge_server.hpp"
#include "core/agent/robot_agent.hpp"
#include "core/cloud/scan_codec.hpp"
#include "core/descriptor/descriptor_codec.hpp"
#include "core/descriptor/sensor_presets.hpp"
#include "core/descriptor/solid.hpp"
#include "core/memory/budget.hpp"
#include "core/sim/synthetic_scan.hpp"
#include "tests/core/agent/keyframe_batch_fixtures.hpp"
#include "tests/support/scan_chunks.hpp"
#include "tests/core/registration/registration_test_support.hpp"
#include "tests/support/block_loop_drive.hpp"

using namespace commerge;
using commerge::test::ChunksOf;
using commerge::test::EncodeForTest;
using commerge::test::LatticePoints;
using commerge::test::MakeBatch;
using commerge::test::RandomDescriptor;
using commerge::test::ShiftedPairBatches;

namespace {

struct Rig {
  std::unique_ptr<SolidDescriptor> solid;
  std::unique_ptr<ScanStore> store;
  std::unique_ptr<RobotAgent> agent;
  RobotMapperCapacity capacity;
};

Rig MakeMemoryRig(std::size_t store_bytes, const RobotAgentParams& params = RobotAgentParams{}) {
  Rig rig;
  auto solid = SolidDescriptor::Create(SolidPreset(LidarSensor::kVelodyneVlp16));
  REQUIRE(solid.ok());
  rig.solid = std::make_unique<SolidDescriptor>(std::move(*solid));
  ScanStoreParams sp;
  sp.capacity_bytes = store_bytes;
  sp.max_scans = 400;
  auto store = ScanStore::Create(sp);
  REQUIRE(store.ok());
  rig.store = std::move(*store);
  rig.capacity.max_keyframes = 400;
  rig.capacity.max_points_per_raw_scan = 16 * 600;
  rig.capacity.max_points_per_stored_scan = 8192;
  rig.agent = std::make_unique<RobotAgent>(0, params, rig.capacity, rig.solid.get(), rig.store.get());
  return rig;
}

// Drives arc length [0, length_m] of the block loop (tests/support/block_loop_drive.hpp), one scan per metre
// (a keyframe each), odometry = truth. Calls `after(agent)` after every scan.
template <class After>
void DriveBlock(RobotAgent* agent, double length_m, After after) {
  const BoxScene scene = MakeBlockLoopScene(11, static_cast<float>(test::kWidth), static_cast<float>(test::kHeight));
  const SpinningLidar lidar = test::BlockLoopLidar();
  std::vector<PointXYZI> scan;
  for (double s = 0.0; s <= length_m; s += 1.0) {
    const Eigen::Isometry3d T = test::PoseOnLoop(s);
    const double yaw = std::atan2(T.linear()(1, 0), T.linear()(0, 0));
    CastScan(scene, lidar, static_cast<float>(T.translation().x()), static_cast<float>(T.translation().y()),
             static_cast<float>(test::kSensorZ), static_cast<float>(yaw), static_cast<std::uint32_t>(s + 1), &scan);
    auto step = agent->AddScan(Span<const PointXYZI>(scan), T);
    REQUIRE(step.ok());
    after(*agent);
  }
}

ModuleMemory Module(const std::vector<ModuleMemory>& modules, const std::string& name) {
  for (const ModuleMemory& m : modules) {
    if (m.name == name) return m;
  }
  FAIL("no module " << name);
  return modules.front();
}

std::vector<std::string> BudgetModules(AppKind app, std::initializer_list<const char*> not_measured) {
  std::vector<std::string> names;
  const BudgetTable table = MakeBudgetTable(app, MemoryConfig{});
  for (const BudgetEntry& e : table.entries()) {
    if (std::find_if(not_measured.begin(), not_measured.end(), [&](const char* n) { return e.module == n; }) ==
        not_measured.end()) {
      names.push_back(e.module);
    }
  }
  return names;
}

void CheckHighWaterNotBelowUse(const std::vector<ModuleMemory>& modules) {
  for (const ModuleMemory& m : modules) {
    INFO(m.name);
    CHECK(m.used_bytes >= 0);
    CHECK(m.high_water_bytes >= m.used_bytes);
    CHECK(m.budget_bytes == 0);
  }
}

template <class V>
std::int64_t Held(const V& v) {
  return static_cast<std::int64_t>(v.capacity() * sizeof(typename V::value_type));
}

}  // namespace

TEST_CASE("Robot agent memory: the robot budget modules, each counted from its own pool") {
  Rig rig = MakeMemoryRig(4u << 20);
  std::vector<std::string> names;
  for (const ModuleMemory& m : rig.agent->MemoryUse()) names.push_back(m.name);
  CHECK(names == BudgetModules(AppKind::kRobot, {"runtime"}));

  const std::size_t keyframes = 20;
  DriveBlock(rig.agent.get(), static_cast<double>(keyframes - 1), [](const RobotAgent&) {});
  REQUIRE(rig.agent->mapper().num_keyframes() == keyframes);
  REQUIRE(rig.agent->mapper().graph().num_loop_edges() == 0);  // no revisit yet: no optimisation, no workspace
  const std::vector<ModuleMemory> use = rig.agent->MemoryUse();
  CheckHighWaterNotBelowUse(use);

  // descriptor_db: K records of (dimension floats + the validity byte) in the fixed-capacity database.
  CHECK(Module(use, "descriptor_db").used_bytes ==
        static_cast<std::int64_t>(keyframes * (rig.solid->dimension() * sizeof(float) + 1)));
  // pose_graph: K nodes, the mapper's K odometry poses and K - 1 odometry edges, no solver workspace before the
  // first optimisation.
  CHECK(Module(use, "pose_graph").used_bytes ==
        static_cast<std::int64_t>(2 * keyframes * sizeof(Eigen::Isometry3d) +
                                  (keyframes - 1) * sizeof(PoseGraphEdge)));
  // scan_store: every stored record with its 8-byte header.
  std::int64_t records = 0;
  for (std::uint32_t k = 0; k < keyframes; ++k) {
    auto view = rig.store->View(k);
    REQUIRE(view.ok());
    records += static_cast<std::int64_t>(view->size()) + 8;
  }
  CHECK(Module(use, "scan_store").used_bytes == records);
  CHECK(Module(use, "scan_store").high_water_bytes == records);
  // outbox: the per-keyframe send bookkeeping (flags: pose queued, record queued, scan requested; times; poses)
  // for max_keyframes, the chunk buffer reserved for the largest stored scan, and one compact batch's keyframes.
  const std::int64_t bookkeeping = static_cast<std::int64_t>(
      rig.capacity.max_keyframes * (3 * sizeof(std::uint8_t) + sizeof(std::int64_t) + 7 * sizeof(float)));
  CHECK(Module(use, "outbox").used_bytes ==
        bookkeeping + static_cast<std::int64_t>(EncodedScanBytes(rig.capacity.max_points_per_stored_scan)) +
            static_cast<std::int64_t>(rig.agent->params().max_records_per_batch * sizeof(CompactKeyframe)));
  // scan_workspace: at least the voxelised scan and the encoded scan reserved for the largest stored scan, and
  // the voxel grid's workspace for the largest raw scan (16-byte entries, input and ping-pong).
  CHECK(Module(use, "scan_workspace").used_bytes >=
        static_cast<std::int64_t>(rig.capacity.max_points_per_stored_scan * sizeof(PointXYZI) +
                                  EncodedScanBytes(rig.capacity.max_points_per_stored_scan) +
                                  2 * rig.capacity.max_points_per_raw_scan * 16));
  // loop_closure: at least the decoded match scan reserved for the largest stored scan and the loop check's
  // path workspace (KeyframeGraphDistance: 36 B per keyframe of capacity, reserved up front).
  CHECK(Module(use, "loop_closure").used_bytes >=
        static_cast<std::int64_t>(rig.capacity.max_points_per_stored_scan * sizeof(PointXYZI) +
                                  36 * rig.capacity.max_keyframes));
}

TEST_CASE("Robot agent memory: loop closure adds the k-d tree, edges and the pose-graph solver workspace") {
  RobotAgentParams params;
  params.mapper.loop.window_keyframes = 50;
  Rig rig = MakeMemoryRig(4u << 20, params);
  const std::int64_t loop_before = Module(rig.agent->MemoryUse(), "loop_closure").used_bytes;
  std::int64_t max_pose_graph = 0;
  const double perimeter = 2.0 * (test::kWidth + test::kHeight);
  DriveBlock(rig.agent.get(), perimeter + 20.0, [&](const RobotAgent& agent) {
    max_pose_graph = std::max(max_pose_graph, Module(agent.MemoryUse(), "pose_graph").used_bytes);
  });
  REQUIRE(rig.agent->Finish().ok());
  const PoseGraph& graph = rig.agent->mapper().graph();
  REQUIRE(graph.num_loop_edges() > 0);
  REQUIRE(rig.agent->mapper().stats().optimisations > 0);
  const std::vector<ModuleMemory> use = rig.agent->MemoryUse();
  CheckHighWaterNotBelowUse(use);
  CHECK(graph.workspace_bytes() > 0);
  CHECK(Module(use, "pose_graph").used_bytes ==
        static_cast<std::int64_t>(2 * graph.num_nodes() * sizeof(Eigen::Isometry3d) +
                                  graph.num_edges() * sizeof(PoseGraphEdge) + graph.workspace_bytes()));
  CHECK(Module(use, "pose_graph").high_water_bytes >= max_pose_graph);
  // The verifier indexed a match scan: its k-d tree now counts.
  CHECK(Module(use, "loop_closure").used_bytes > loop_before);
}

TEST_CASE("Robot agent memory: the scan store high-water mark stays when it evicts old scans") {
  Rig rig = MakeMemoryRig(64u << 10);  // a few VLP-16 scans
  std::int64_t max_seen = 0;
  DriveBlock(rig.agent.get(), 40.0, [&](const RobotAgent& agent) {
    max_seen = std::max(max_seen, static_cast<std::int64_t>(agent.store().stats().used_bytes));
  });
  const ScanStoreStats stats = rig.store->stats();
  REQUIRE(stats.num_evicted > 0);
  const ModuleMemory store = Module(rig.agent->MemoryUse(), "scan_store");
  CHECK(store.used_bytes == static_cast<std::int64_t>(stats.used_bytes));
  CHECK(store.high_water_bytes == static_cast<std::int64_t>(stats.high_water_bytes));
  CHECK(store.high_water_bytes >= max_seen);
  CHECK(store.high_water_bytes <= static_cast<std::int64_t>(64u << 10));
}

TEST_CASE("Merge server memory: the server budget modules, descriptor_db from the capacity of each robot's arrays") {
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(3, 5000, MergeServerParams{});
  MergeServer& server = *server_owner;
  std::vector<std::string> names;
  for (const ModuleMemory& m : server.MemoryUse()) names.push_back(m.name);
  CHECK(names == BudgetModules(AppKind::kServer, {"merged_map", "inbox", "runtime"}));

  std::mt19937 rng(5);
  const std::size_t keyframes = 1000;
  for (std::uint32_t first = 0; first < keyframes; first += 100) {
    std::vector<std::array<float, kKeyframeDescriptorDim>> d;
    std::vector<Eigen::Vector3d> p;
    for (int i = 0; i < 100; ++i) {
      d.push_back(RandomDescriptor(&rng));
      p.emplace_back(first + i, 0.0, 0.0);
    }
    REQUIRE(server.OnKeyframeBatch(MakeBatch(1, first, d, p, 1000)).ok());
  }
  const std::vector<ModuleMemory> use = server.MemoryUse();
  CheckHighWaterNotBelowUse(use);
  // The robots' arrays, one decoded record's descriptor and one decoded compact batch (reserved at start-up).
  const auto scratch = static_cast<std::int64_t>(kKeyframeDescriptorDim * sizeof(float) +
                                                 kMaxRecordsPerBatch * sizeof(CompactKeyframe));
  std::int64_t expected = static_cast<std::int64_t>(3 * sizeof(RobotKeyframeDb)) + scratch;
  for (int r = 0; r < 3; ++r) {
    const RobotKeyframeDb& db = server.robot(r);
    expected += Held(db.descriptors) + Held(db.valid) + Held(db.pose_known) + Held(db.no_descriptor) +
                Held(db.T_map_sensor) + Held(db.stored_points);
  }
  const std::int64_t used = Module(use, "descriptor_db").used_bytes;
  CHECK(used == expected);
  // At least one record per keyframe: descriptor, three flags, pose, point count; growth at most doubles it.
  const std::int64_t record = static_cast<std::int64_t>(kKeyframeDescriptorDim * sizeof(float) + 3 +
                                                        sizeof(Eigen::Isometry3d) + sizeof(std::uint32_t));
  CHECK(used >= static_cast<std::int64_t>(keyframes) * record);
  CHECK(used <= 2 * static_cast<std::int64_t>(keyframes) * record + static_cast<std::int64_t>(3 * sizeof(RobotKeyframeDb)) +
                    scratch);
  for (const char* idle : {"affinity", "solvers", "scan_reassembly", "submaps", "registration"}) {
    CHECK(Module(use, idle).used_bytes == 0);
  }

  // A new session of robot 1 drops its keyframes; the mark stays.
  server.ResetRobot(1);
  const ModuleMemory after = Module(server.MemoryUse(), "descriptor_db");
  CHECK(after.used_bytes == static_cast<std::int64_t>(3 * sizeof(RobotKeyframeDb)) + scratch);
  CHECK(after.high_water_bytes == used);
}

TEST_CASE("Merge server memory: scan_reassembly counts held and partial scans, and its mark stays after ClearScans") {
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, MergeServerParams{});
  MergeServer& server = *server_owner;
  const std::vector<std::uint8_t> a = EncodeForTest(LatticePoints(1000)), b = EncodeForTest(LatticePoints(3000));
  const std::vector<ScanChunk> ca = ChunksOf(0, 4, a), cb = ChunksOf(1, 9, b);
  REQUIRE(cb.size() > 2);
  for (const ScanChunk& c : ca) REQUIRE(server.OnScanChunk(c).ok());
  REQUIRE(server.OnScanChunk(cb[0]).ok());  // b is partial: all its bytes and one flag per chunk are held
  const std::int64_t complete_entry = static_cast<std::int64_t>(sizeof(std::pair<const std::uint64_t, std::vector<std::uint8_t>>));
  const std::int64_t partial =
      Module(server.MemoryUse(), "scan_reassembly").used_bytes - static_cast<std::int64_t>(a.size()) - complete_entry;
  CHECK(partial >= static_cast<std::int64_t>(b.size() + cb.size()));
  for (std::size_t i = 1; i < cb.size(); ++i) REQUIRE(server.OnScanChunk(cb[i]).ok());
  REQUIRE(server.scans_received() == 2);
  const std::vector<ModuleMemory> use = server.MemoryUse();
  CheckHighWaterNotBelowUse(use);
  const ModuleMemory& held = Module(use, "scan_reassembly");
  CHECK(held.used_bytes == static_cast<std::int64_t>(a.size() + b.size()) + 2 * complete_entry);
  CHECK(static_cast<std::uint64_t>(held.used_bytes) >= server.scan_bytes_held());
  CHECK(held.high_water_bytes >= held.used_bytes);

  server.ClearScans();
  const ModuleMemory cleared = Module(server.MemoryUse(), "scan_reassembly");
  CHECK(cleared.used_bytes == 0);
  CHECK(cleared.high_water_bytes == std::max(held.used_bytes, partial + static_cast<std::int64_t>(a.size()) + complete_entry));
}

TEST_CASE("Merge server memory: the cascade, the submaps and the registration count their buffers") {
  SyntheticSubmapPair pair;
  REQUIRE(MakeStreetSubmapPair(test::LightStreetSpec(41, test::YawOffset(70.0, 12.0, -6.0, 0.3)), &pair).ok());
  MergeServerParams params;
  params.cascade.stage_a = SequentialMatchParams{};  // the paper's stage A: B_ij = [A_ij <= tau_inter]
  params.cascade.stage_a.tau_area = 100;
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, params);
  MergeServer& server = *server_owner;
  // Stage A: beta's keyframe j sees alpha's place j + 5.
  const int n = 40;
  for (const KeyframeBatch& b : ShiftedPairBatches(n, 5)) REQUIRE(server.OnKeyframeBatch(b).ok());
  REQUIRE(server.RunCascades().ok());
  const ExchangeCascadeResult* cascade = server.cascade(0, 1);
  REQUIRE(cascade != nullptr);
  REQUIRE(cascade->stage_a.found);
  std::vector<ModuleMemory> use = server.MemoryUse();
  CheckHighWaterNotBelowUse(use);
  // affinity: stage A's loops and the keyframe positions of both robots, at least.
  CHECK(Module(use, "affinity").used_bytes >=
        static_cast<std::int64_t>(cascade->stage_a.cells.size() * sizeof(SequentialLoopCell) +
                                  2 * n * sizeof(Eigen::Vector3d)));
  CHECK(Module(use, "solvers").used_bytes >=
        static_cast<std::int64_t>((cascade->stage_b.selected_left.size() + cascade->stage_b.selected_right.size()) *
                                      sizeof(int) +
                                  cascade->stage_c.selected_loops.size() * sizeof(SequentialLoopCell)));
  CHECK(Module(use, "submaps").used_bytes == 0);
  CHECK(Module(use, "registration").used_bytes == 0);

  // Scans: alpha's keyframe 3 holds the target submap, beta's keyframe 0 the source.
  const Eigen::Isometry3d T_a = test::YawOffset(-25.0, 4.0, 2.0, 0.0);
  PoseUpdate update;
  update.robot_id = 0;
  update.keyframes = {3};
  update.T_map_sensor = {T_a};
  REQUIRE(server.OnPoseUpdate(update).ok());
  for (const ScanChunk& c : ChunksOf(0, 3, EncodeForTest(test::Transformed(pair.target.points, T_a.inverse())))) {
    REQUIRE(server.OnScanChunk(c).ok());
  }
  for (const ScanChunk& c : ChunksOf(1, 0, EncodeForTest(pair.source.points))) REQUIRE(server.OnScanChunk(c).ok());
  PairSelection sel;
  sel.alpha = 0;
  sel.beta = 1;
  sel.alpha_keyframes = {3};
  sel.beta_keyframes = {0};
  auto merged = server.MergePair(sel);
  REQUIRE(merged.ok());
  REQUIRE(merged->attempted);
  use = server.MemoryUse();
  CheckHighWaterNotBelowUse(use);
  // submaps: both submaps, and the union and decoded scan they came from (each at least as large).
  const std::int64_t submap_points =
      static_cast<std::int64_t>(merged->alpha_submap_points + merged->beta_submap_points);
  CHECK(Module(use, "submaps").used_bytes >= 2 * submap_points * static_cast<std::int64_t>(sizeof(PointXYZI)));
  // registration: per point of both submaps at least a normal (3 floats) and a GICP covariance (3 x 3 doubles).
  CHECK(Module(use, "registration").used_bytes >=
        submap_points * static_cast<std::int64_t>(sizeof(Eigen::Vector3f) + sizeof(Eigen::Matrix3d)));
  // ... and at most the budget's share per submap point (plus the fallback's fixed grids, not run here).
  MESSAGE("registration " << Module(use, "registration").used_bytes << " B for " << submap_points << " points");
  CHECK(Module(use, "registration").used_bytes <=
        submap_points * BudgetRecordSizes::kRegistrationPointBytes + BudgetRecordSizes::kRegistrationGridBytes);

  // A new round drops the cascade results: the marks stay.
  const std::int64_t solvers = Module(use, "solvers").used_bytes;
  server.ResetRobot(1);
  REQUIRE(server.RunCascades().ok());
  const std::vector<ModuleMemory> after = server.MemoryUse();
  CHECK(Module(after, "solvers").used_bytes < solvers);
  CHECK(Module(after, "solvers").high_water_bytes >= solvers);
  CHECK(Module(after, "registration").high_water_bytes >= Module(use, "registration").used_bytes);
}

TEST_CASE("Merge server memory: the submaps stay within their budget module however many scans a pair selects") {
  // Small submaps and scans, so that 40 selected scans a robot overflow the union many times over.
  MemoryConfig config = DefaultMemoryConfig(BoardProfile::kJetsonNano);
  config.max_robots = 2;
  config.max_keyframes_per_robot = 100;
  config.max_submap_points = 1000;
  config.max_points_per_stored_scan = 3000;
  const BudgetTable table = MakeBudgetTable(AppKind::kServer, config);
  const BudgetEntry* budget = table.Find("submaps");
  REQUIRE(budget != nullptr);
  MergeServerParams params;
  params.max_submap_points = static_cast<std::size_t>(config.max_submap_points);
  params.max_scan_points = static_cast<std::size_t>(config.max_points_per_stored_scan);
  std::unique_ptr<MergeServer> server_owner = commerge::test::MakeTestServer(2, 100, params);
  MergeServer& server = *server_owner;
  const int n = 40;
  for (const KeyframeBatch& b : ShiftedPairBatches(n, 5)) REQUIRE(server.OnKeyframeBatch(b).ok());
  std::mt19937 rng(23);
  std::uniform_real_distribution<float> u(-30.0f, 30.0f), h(0.0f, 6.0f);
  const auto scan_of = [&](std::size_t points) {
    std::vector<PointXYZI> scan;
    for (std::size_t i = 0; i < points; ++i) scan.push_back({u(rng), u(rng), h(rng), 1.0f});
    return scan;
  };
  PairSelection sel;
  sel.alpha = 0;
  sel.beta = 1;
  for (int robot = 0; robot < 2; ++robot) {
    for (int k = 0; k < n; ++k) {
      // Every size up to the largest a stored scan may have.
      const std::size_t points = (k % 4 == 0) ? params.max_scan_points : 500 + 60 * static_cast<std::size_t>(k);
      for (const ScanChunk& c : ChunksOf(robot, static_cast<std::uint32_t>(k), EncodeForTest(scan_of(points)))) {
        REQUIRE(server.OnScanChunk(c).ok());
      }
      (robot == 0 ? sel.alpha_keyframes : sel.beta_keyframes).push_back(static_cast<std::uint32_t>(k));
    }
  }
  // A scan larger than a stored scan may be is refused at its first chunk and counted.
  const std::uint64_t rejected = server.stats().rejected_chunks;
  const Status refused = server.OnScanChunk(ChunksOf(0, 60, EncodeForTest(scan_of(params.max_scan_points + 1)))[0]);
  CHECK_FALSE(refused.ok());
  CHECK(refused.message().find("3000 points") != std::string::npos);
  CHECK(server.stats().rejected_chunks == rejected + 1);

  auto merged = server.MergePair(sel);
  REQUIRE(merged.ok());
  CHECK(merged->alpha_scans == static_cast<std::size_t>(n));
  CHECK(merged->beta_scans == static_cast<std::size_t>(n));
  const ModuleMemory submaps = Module(server.MemoryUse(), "submaps");
  MESSAGE("submaps high-water " << submaps.high_water_bytes << " B of a budget of " << budget->bytes << " B");
  // The union was filled to its capacity (the bound is not slack) and never beyond the module.
  CHECK(submaps.high_water_bytes >= BudgetRecordSizes::kSubmapUnionFactor * config.max_submap_points *
                                        static_cast<std::int64_t>(sizeof(PointXYZI)));
  CHECK(submaps.high_water_bytes <= budget->bytes);
}
