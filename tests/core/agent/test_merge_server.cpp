// SPDX-License-Identifier: BSD-3-Clause
// The merge server as a whole (core/agent/merge_server.hpp), a facade over its four modules: Create names the
// parameter out of range whichever module checks it, and ResetRobot forgets one robot in every module at once
// (keyframes, complete and partial scans, pairs) while ClearScans drops the scans alone. Each module's own tests:
// test_keyframe_database.cpp, test_scan_inbox.cpp, test_exchange_planner.cpp, test_pair_registrar.cpp; the
// decisions: test_pair_decision.cpp; its memory: test_memory_use.cpp.
#include <doctest/doctest.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/agent/merge_server.hpp"
#include "tests/core/agent/keyframe_batch_fixtures.hpp"
#include "tests/core/agent/merge_server_test_support.hpp"
#include "tests/core/agent/scan_chunk_fixtures.hpp"
#include "tests/core/agent/server_fixture.hpp"

using namespace commerge;
using commerge::test::ChunksOf;
using commerge::test::EncodeForTest;
using commerge::test::LatticePoints;
using commerge::test::PaperStageA;
using commerge::test::ShiftedPairBatches;

TEST_CASE("Merge server: Create names the parameter out of range, whichever of its modules checks it") {
  const auto refusal = [](int robots, std::size_t keyframes, const MergeServerParams& params) {
    auto server = MergeServer::Create(robots, keyframes, params);
    REQUIRE_FALSE(server.ok());
    CHECK(server.status().code() == StatusCode::kInvalidArgument);
    return server.status().message();
  };
  CHECK(refusal(1, 100, MergeServerParams{}).find("max_robots = 1") != std::string::npos);
  CHECK(refusal(65, 100, MergeServerParams{}).find("max_robots = 65") != std::string::npos);
  CHECK(refusal(2, 0, MergeServerParams{}).find("max_keyframes_per_robot = 0") != std::string::npos);
  MergeServerParams params;
  params.max_scans_held = 0;
  CHECK(refusal(2, 100, params).find("max_scans_held") != std::string::npos);
  params = MergeServerParams{};
  params.max_scan_points = 0;
  CHECK(refusal(2, 100, params).find("max_scan_points = 0") != std::string::npos);
  params = MergeServerParams{};
  params.record_kind = static_cast<KeyframeRecordKind>(7);
  CHECK(refusal(2, 100, params).find("record_kind") != std::string::npos);
  auto widest = MergeServer::Create(64, 1, MergeServerParams{});
  REQUIRE(widest.ok());
  CHECK((*widest)->max_robots() == 64);
  CHECK((*widest)->keyframes().max_keyframes_per_robot() == 1);
}

TEST_CASE("Merge server: ResetRobot forgets one robot's keyframes, scans and pairs, ClearScans only the scans") {
  std::unique_ptr<MergeServer> server = commerge::test::MakeTestServer(3, 100, PaperStageA(100));
  // Robots 0 and 1: ShiftedPairBatches(40, 5); robot 2 the same keyframes as robot 1.
  std::vector<KeyframeBatch> batches = ShiftedPairBatches(40, 5);
  batches.push_back(batches[1]);
  batches[2].robot_id = 2;
  for (const KeyframeBatch& b : batches) REQUIRE(server->OnKeyframeBatch(b).ok());
  REQUIRE(server->RunCascades().ok());
  REQUIRE(server->cascade(0, 1) != nullptr);
  REQUIRE(server->cascade(0, 2) != nullptr);
  REQUIRE(server->cascade(1, 2) != nullptr);
  // Complete scans of robot 1's and robot 2's keyframe 3 (10 points: 12 + 60 bytes), half of robot 2's keyframe 4
  // (200 points: 1212 bytes in two chunks; a partial scan holds its whole size).
  const std::vector<std::uint8_t> small = EncodeForTest(LatticePoints(10));
  REQUIRE(small.size() == 72);
  for (int robot : {1, 2}) {
    for (const ScanChunk& c : ChunksOf(robot, 3, small)) REQUIRE(server->OnScanChunk(c).ok());
  }
  const std::vector<ScanChunk> halves = ChunksOf(2, 4, EncodeForTest(LatticePoints(200)), 700);
  REQUIRE(halves.size() == 2);
  REQUIRE(server->OnScanChunk(halves[0]).ok());
  CHECK(server->scans_received() == 2);
  CHECK(server->scan_bytes_held() == 72 + 72 + 1212);

  server->ResetRobot(2);
  CHECK(server->robot(2).size() == 0);
  CHECK(server->robot(0).size() == 40);
  CHECK(server->robot(1).size() == 40);
  CHECK_FALSE(server->has_scan(2, 3));
  std::uint16_t num_chunks = 0;
  const std::vector<std::uint8_t>* have = nullptr;
  CHECK_FALSE(server->PartialScan(2, 4, &num_chunks, &have));
  CHECK(server->has_scan(1, 3));
  CHECK(server->scans_received() == 1);
  CHECK(server->scan_bytes_held() == 72);
  CHECK(server->cascade(0, 2) == nullptr);
  CHECK(server->cascade(1, 2) == nullptr);
  REQUIRE(server->cascade(0, 1) != nullptr);
  CHECK(server->cascade(0, 1)->stage_a.found);
  auto plan = server->Plan(ExchangeMode::kStageABC);
  REQUIRE(plan.ok());
  REQUIRE(plan->pairs.size() == 1);
  CHECK(plan->pairs[0].alpha == 0);
  CHECK(plan->pairs[0].beta == 1);

  server->ClearScans();
  CHECK(server->scans_received() == 0);
  CHECK(server->scan_bytes_held() == 0);
  CHECK_FALSE(server->has_scan(1, 3));
  CHECK(server->robot(1).size() == 40);
  CHECK(server->cascade(0, 1) != nullptr);
  server->ResetRobot(3);  // no such robot: nothing happens
  CHECK(server->robot(0).size() == 40);
}
