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

TEST_CASE("The descriptor databases are budgeted for the descriptor's values: Scan Context's 1200 floats") {
  MemoryConfig c = DefaultMemoryConfig(BoardProfile::kJetsonNano);
  c.max_robots = 3;
  c.max_keyframes_per_robot = 1000;
  const std::int64_t unit_server = MakeBudgetTable(AppKind::kServer, c).Find("descriptor_db")->bytes;
  CHECK(unit_server == 3 * 1000 * 512);
  c.descriptor_floats = 1200;
  // 1200 floats of 4 B where the 40-value record budgets 160 B of them, the rest of the 512 B record as before.
  const std::int64_t sc_record = 512 + 4 * (1200 - 40);
  CHECK(BudgetRecordSizes::DescriptorRecordBytes(1200) == sc_record);
  CHECK(MakeBudgetTable(AppKind::kServer, c).Find("descriptor_db")->bytes == 3 * 1000 * sc_record);
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
