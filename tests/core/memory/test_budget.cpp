// SPDX-License-Identifier: BSD-3-Clause
#include <doctest/doctest.h>

#include <string>

#include "core/common/bytes.hpp"
#include "core/memory/budget.hpp"
#include "tests/support/strings.hpp"

using namespace commerge;
using commerge::test::Contains;

TEST_CASE("Board profiles parse by name and reject unknown names with the valid list") {
  CHECK(*ParseBoardProfile("jetson-nano") == BoardProfile::kJetsonNano);
  CHECK(*ParseBoardProfile("ipc-6000") == BoardProfile::kIpc6000);
  CHECK(*ParseBoardProfile("desktop") == BoardProfile::kDesktop);
  auto bad = ParseBoardProfile("jetson-xavier");
  REQUIRE_FALSE(bad.ok());
  CHECK(Contains(bad.status().message(), "jetson-xavier"));
  CHECK(Contains(bad.status().message(), "jetson-nano, ipc-6000, desktop"));
  CHECK(GetBoard(BoardProfile::kJetsonNano).ram_bytes == 4 * kGiB);
  CHECK(GetBoard(BoardProfile::kIpc6000).ram_bytes == 8 * kGiB);
}

TEST_CASE("Every app's default table fits its own board, and the Jetson Nano defaults meet the field goals") {
  for (const BoardSpec& board : AllBoards()) {
    const MemoryConfig config = DefaultMemoryConfig(board.profile);
    REQUIRE(ValidateMemoryConfig(config).ok());
    // Desktop has no board figure: model a 16 GiB workstation through MemAvailable.
    const BudgetLimit limit = EffectiveLimit(board, board.ram_bytes > 0 ? -1 : 16 * kGiB, -1);
    for (AppKind app : {AppKind::kRobot, AppKind::kServer, AppKind::kRun}) {
      CAPTURE(board.name);
      CAPTURE(AppKindName(app));
      const BudgetVerdict v = CheckBudget(app, MakeBudgetTable(app, config), limit);
      CHECK(v.fits);
    }
  }
  const MemoryConfig nano = DefaultMemoryConfig(BoardProfile::kJetsonNano);
  CHECK(MakeBudgetTable(AppKind::kRobot, nano).total_bytes() < 384 * kMiB);
  CHECK(MakeBudgetTable(AppKind::kServer, nano).total_bytes() < 512 * kMiB);
}

TEST_CASE("Budget tables follow their formulas (independent recomputation of the entries)") {
  MemoryConfig c = DefaultMemoryConfig(BoardProfile::kJetsonNano);
  c.max_robots = 4;
  c.max_keyframes_per_robot = 1000;
  c.scan_store_bytes = 10 * kMiB;
  const BudgetTable robot = MakeBudgetTable(AppKind::kRobot, c);
  REQUIRE(robot.Find("scan_store") != nullptr);
  CHECK(robot.Find("scan_store")->bytes == 10 * kMiB);
  CHECK(robot.Find("descriptor_db")->bytes == 1000 * BudgetRecordSizes::kDescriptorRecordBytes);
  std::int64_t sum = 0;
  for (const BudgetEntry& e : robot.entries()) {
    CHECK(e.bytes > 0);
    CHECK_FALSE(e.basis.empty());
    sum += e.bytes;
  }
  CHECK(robot.total_bytes() == sum);

  // `run` holds every robot's modules plus the server's.
  const BudgetTable run = MakeBudgetTable(AppKind::kRun, c);
  const BudgetTable server = MakeBudgetTable(AppKind::kServer, c);
  REQUIRE(run.Find("robots.scan_store") != nullptr);
  CHECK(run.Find("robots.scan_store")->bytes == 4 * 10 * kMiB);
  CHECK(run.total_bytes() == 4 * (robot.total_bytes() - BudgetRecordSizes::kRuntimeBytes) +
                                 (server.total_bytes() - BudgetRecordSizes::kRuntimeBytes) +
                                 BudgetRecordSizes::kRuntimeBytes);
}

TEST_CASE("The budget of `run` follows its input: pools sized from the mission, at most the board's where the mission fills less") {
  const MemoryConfig desktop = DefaultMemoryConfig(BoardProfile::kDesktop);
  // Unknown mission: the board's defaults untouched.
  const MemoryConfig unknown = SizeMemoryForMission(desktop, MissionExtent{});
  CHECK(unknown.max_keyframes_per_robot == desktop.max_keyframes_per_robot);
  CHECK(unknown.scan_store_bytes == desktop.scan_store_bytes);

  MissionExtent five;
  five.robots = 5;
  five.max_keyframes_per_robot = 400;
  five.max_points_per_raw_scan = 30000;
  const MemoryConfig c = SizeMemoryForMission(desktop, five);
  REQUIRE(ValidateMemoryConfig(c).ok());
  CHECK(c.max_robots == 5);
  CHECK(c.max_keyframes_per_robot == 400);
  CHECK(c.max_points_per_raw_scan == desktop.max_points_per_raw_scan);  // never below the board's (local map)
  CHECK(c.max_points_per_stored_scan == desktop.max_points_per_stored_scan);
  // Every keyframe's scan at the largest stored size: record and scan headers, 6 B a point, the index entry.
  CHECK(c.scan_store_bytes == 400 * (8 + 12 + 16 + 6 * std::int64_t{8192}));
  CHECK(c.max_scans_in_flight == 5 * 400);
  CHECK(c.merged_map_bytes == 5 * 400 * std::int64_t{8192} * 18 * 4 / 3);
  CHECK(c.solver_workspace_bytes == desktop.solver_workspace_bytes);
  CHECK(c.message_queue_bytes == desktop.message_queue_bytes);
  // The store the robots make from it holds every keyframe's largest scan.
  const std::int64_t index = 400 * 16;
  CHECK(c.scan_store_bytes - index >= 400 * (8 + 12 + 6 * std::int64_t{8192}));

  // The run's budget grows with the robots, the keyframes and the scans, and stays below the board's defaults.
  MissionExtent two = five;
  two.robots = 2;
  MissionExtent longer = five;
  longer.max_keyframes_per_robot = 3000;
  MissionExtent large_scans = five;
  large_scans.max_points_per_raw_scan = 2 * desktop.max_points_per_raw_scan;
  const auto total = [&](const MissionExtent& m) {
    return MakeBudgetTable(AppKind::kRun, SizeMemoryForMission(desktop, m)).total_bytes();
  };
  CHECK(total(two) < total(five));
  CHECK(total(five) < total(longer));
  CHECK(total(five) < total(large_scans));
  MemoryConfig board_for_five = desktop;
  board_for_five.max_robots = 5;
  CHECK(total(longer) < MakeBudgetTable(AppKind::kRun, board_for_five).total_bytes());
  // Small scans keep the board's raw capacity (the mapper's local map is bounded by it).
  MissionExtent small_scans = five;
  small_scans.max_points_per_raw_scan = 2000;
  CHECK(SizeMemoryForMission(desktop, small_scans).max_points_per_raw_scan == desktop.max_points_per_raw_scan);

  // A mission larger than the board's defaults gets what it needs (the start-up check decides whether it fits);
  // the scan store and the merged map stay at most the board's.
  MissionExtent huge = five;
  huge.max_keyframes_per_robot = 2 * desktop.max_keyframes_per_robot;
  huge.max_points_per_raw_scan = 2 * desktop.max_points_per_raw_scan;
  const MemoryConfig h = SizeMemoryForMission(desktop, huge);
  CHECK(h.max_keyframes_per_robot == huge.max_keyframes_per_robot);
  CHECK(h.max_points_per_raw_scan == huge.max_points_per_raw_scan);
  CHECK(h.scan_store_bytes == desktop.scan_store_bytes);
  CHECK(h.merged_map_bytes == desktop.merged_map_bytes);
  CHECK(h.max_scans_in_flight == desktop.max_scans_in_flight);
}

TEST_CASE("The descriptor databases are budgeted for the descriptor's values: Scan Context's 1200 floats") {
  MemoryConfig c = DefaultMemoryConfig(BoardProfile::kJetsonNano);
  c.max_robots = 3;
  c.max_keyframes_per_robot = 1000;
  const std::int64_t unit_server = MakeBudgetTable(AppKind::kServer, c).Find("descriptor_db")->bytes;
  // One decoded compact batch beside the robots' keyframes.
  CHECK(unit_server == 3 * 1000 * 512 + BudgetRecordSizes::kCompactBatchScratchBytes);
  c.descriptor_floats = 1200;
  // 1200 floats of 4 B where the 40-value record budgets 160 B of them, the rest of the 512 B record as before.
  const std::int64_t sc_record = 512 + 4 * (1200 - 40);
  CHECK(BudgetRecordSizes::DescriptorRecordBytes(1200) == sc_record);
  CHECK(MakeBudgetTable(AppKind::kServer, c).Find("descriptor_db")->bytes ==
        3 * 1000 * sc_record + BudgetRecordSizes::kCompactBatchScratchBytes);
  CHECK(MakeBudgetTable(AppKind::kRobot, c).Find("descriptor_db")->bytes == 1000 * sc_record);
  CHECK(MakeBudgetTable(AppKind::kRun, c).Find("robots.descriptor_db")->bytes == 3 * 1000 * sc_record);
  // The stored floats themselves fit the record: 1200 x 4 B plus the 40-value record's non-float part.
  CHECK(1200 * 4 + (512 - 40 * 4) <= sc_record);
  c.descriptor_floats = 0;
  const Status st = ValidateMemoryConfig(c);
  CHECK_FALSE(st.ok());
  CHECK(st.message().find("descriptor_floats") != std::string::npos);
}

TEST_CASE("An over-budget configuration names the module, its need and the limit") {
  MemoryConfig c = DefaultMemoryConfig(BoardProfile::kJetsonNano);
  c.scan_store_bytes = 100 * kGiB;
  const BoardSpec& nano = GetBoard(BoardProfile::kJetsonNano);
  const BudgetLimit limit = EffectiveLimit(nano, 20 * kGiB, -1);
  const BudgetVerdict v = CheckBudget(AppKind::kRobot, MakeBudgetTable(AppKind::kRobot, c), limit);
  CHECK_FALSE(v.fits);
  CHECK(v.largest_module == "scan_store");
  CHECK(v.largest_module_bytes == 100 * kGiB);
  CHECK(Contains(v.message, "'scan_store' needs " + FormatBytes(100 * kGiB)));
  CHECK(Contains(v.message, "limit " + FormatBytes(limit.bytes)));
  CHECK(Contains(v.message, "jetson-nano"));
  CHECK(v.message.find('\n') == std::string::npos);  // one line
}

TEST_CASE("EffectiveLimit is the smallest of board, MemAvailable and cgroup, times the headroom") {
  const BoardSpec& nano = GetBoard(BoardProfile::kJetsonNano);
  const std::int64_t board_usable = nano.ram_bytes - nano.reserved_bytes;
  BudgetLimit l = EffectiveLimit(nano, 16 * kGiB, -1, 0.9);
  CHECK(l.bytes == static_cast<std::int64_t>(static_cast<double>(board_usable) * 0.9));
  CHECK(Contains(l.source, "jetson-nano"));
  l = EffectiveLimit(nano, 1 * kGiB, 2 * kGiB, 0.5);
  CHECK(l.bytes == 512 * kMiB);
  CHECK(Contains(l.source, "MemAvailable"));
  l = EffectiveLimit(nano, 3 * kGiB, 256 * kMiB, 1.0);
  CHECK(l.bytes == 256 * kMiB);
  CHECK(Contains(l.source, "cgroup"));
  const BoardSpec& desktop = GetBoard(BoardProfile::kDesktop);
  l = EffectiveLimit(desktop, -1, -1);
  CHECK(l.bytes == 0);
  const BudgetVerdict v = CheckBudget(AppKind::kServer, MakeBudgetTable(AppKind::kServer, MemoryConfig{}), l);
  CHECK_FALSE(v.fits);  // an unknown limit is never taken as "fits"
}

TEST_CASE("ValidateMemoryConfig names the bad field and value") {
  MemoryConfig c;
  c.max_keyframes_per_robot = 0;
  Status st = ValidateMemoryConfig(c);
  CHECK(st.code() == StatusCode::kInvalidArgument);
  CHECK(Contains(st.message(), "max_keyframes_per_robot = 0"));
  c = MemoryConfig{};
  c.max_robots = 1000;
  CHECK(Contains(ValidateMemoryConfig(c).message(), "max_robots = 1000"));
}
