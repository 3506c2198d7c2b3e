// SPDX-License-Identifier: BSD-3-Clause
// Byte ledger: every counter and total against an independent tally of a random message stream, the
// invalid-robot and unclassified buckets, names, parameter checks, and no heap use after construction.
#include <doctest/doctest.h>

#include <cstdint>
#include <map>
#include <random>
#include <set>
#include <string>
#include <tuple>

#include "core/eval/byte_ledger.hpp"
#include "platform/memory/allocator.hpp"

namespace commerge {
namespace {

constexpr MessageKind kAllKinds[] = {MessageKind::kKeyframes, MessageKind::kPoseUpdates, MessageKind::kPolicies,
                                     MessageKind::kScans,     MessageKind::kStatus,      MessageKind::kOther};
constexpr Direction kBothDirections[] = {Direction::kRobotToServer, Direction::kServerToRobot};

// Reference: a map keyed by (robot, kind, direction); robot -1 stands for "invalid".
struct Tally {
  std::map<std::tuple<std::int64_t, int, int>, ByteCount> cells;
  void Add(std::int64_t robot, MessageKind kind, Direction direction, std::uint64_t bytes) {
    ByteCount& c = cells[{robot, static_cast<int>(kind), static_cast<int>(direction)}];
    c.messages += 1;
    c.bytes += bytes;
  }
  template <class Pred>
  ByteCount Sum(Pred pred) const {
    ByteCount s;
    for (const auto& [key, c] : cells) {
      if (pred(std::get<0>(key), std::get<1>(key), std::get<2>(key))) s += c;
    }
    return s;
  }
};

}  // namespace

TEST_CASE("ByteLedger counters and totals match an independent tally of a random message stream") {
  ByteLedgerParams params;
  params.max_robots = 5;
  ByteLedger ledger(params);
  REQUIRE(ledger.max_robots() == 5);
  Tally tally;
  std::mt19937_64 rng(17);
  std::uniform_int_distribution<std::int64_t> robot(-2, 7);  // 5, 6, 7 and negatives are out of range
  std::uniform_int_distribution<int> kind(0, 5), direction(0, 1);
  std::uniform_int_distribution<std::uint64_t> bytes(0, 200000);
  int invalid_records = 0;
  for (int i = 0; i < 3000; ++i) {
    const std::int64_t r = robot(rng);
    const auto k = static_cast<MessageKind>(kind(rng));
    const auto d = static_cast<Direction>(direction(rng));
    const std::uint64_t b = bytes(rng);
    const bool valid = r >= 0 && r < 5;
    CHECK(ledger.Record(r, k, d, b) == valid);
    tally.Add(valid ? r : -1, k, d, b);
    invalid_records += valid ? 0 : 1;
  }
  REQUIRE(invalid_records > 0);

  for (std::int64_t r = -3; r < 8; ++r) {
    for (MessageKind k : kAllKinds) {
      for (Direction d : kBothDirections) {
        const ByteCount expected = (r >= 0 && r < 5) ? tally.Sum([&](std::int64_t rr, int kk, int dd) {
          return rr == r && kk == static_cast<int>(k) && dd == static_cast<int>(d);
        })
                                                     : ByteCount{};
        CHECK(ledger.Get(r, k, d) == expected);
      }
    }
  }
  for (MessageKind k : kAllKinds) {
    const int ki = static_cast<int>(k);
    CHECK(ledger.KindTotal(k) == tally.Sum([&](std::int64_t, int kk, int) { return kk == ki; }));
    for (Direction d : kBothDirections) {
      const int di = static_cast<int>(d);
      CHECK(ledger.KindTotal(k, d) == tally.Sum([&](std::int64_t, int kk, int dd) { return kk == ki && dd == di; }));
      CHECK(ledger.InvalidRobot(k, d) ==
            tally.Sum([&](std::int64_t rr, int kk, int dd) { return rr == -1 && kk == ki && dd == di; }));
    }
  }
  for (std::int64_t r = 0; r < 5; ++r) {
    CHECK(ledger.RobotTotal(r) == tally.Sum([&](std::int64_t rr, int, int) { return rr == r; }));
    for (Direction d : kBothDirections) {
      const int di = static_cast<int>(d);
      CHECK(ledger.RobotTotal(r, d) == tally.Sum([&](std::int64_t rr, int, int dd) { return rr == r && dd == di; }));
    }
  }
  CHECK(ledger.RobotTotal(5) == ByteCount{});
  CHECK(ledger.RobotTotal(-1) == ByteCount{});
  for (Direction d : kBothDirections) {
    const int di = static_cast<int>(d);
    CHECK(ledger.DirectionTotal(d) == tally.Sum([&](std::int64_t, int, int dd) { return dd == di; }));
  }
  CHECK(ledger.InvalidRobotTotal() == tally.Sum([](std::int64_t rr, int, int) { return rr == -1; }));
  CHECK(ledger.InvalidRobotTotal().messages == static_cast<std::uint64_t>(invalid_records));
  const ByteCount all = tally.Sum([](std::int64_t, int, int) { return true; });
  CHECK(ledger.Total() == all);
  CHECK(all.messages == 3000);
  CHECK(ledger.Unclassified() == ByteCount{});

  ledger.Reset();
  CHECK(ledger.Total() == ByteCount{});
  CHECK(ledger.max_robots() == 5);
}

TEST_CASE("ByteLedger counts out-of-range robots and invalid enum values in their own buckets") {
  ByteLedger ledger(ByteLedgerParams{2});
  CHECK(ledger.Record(0, MessageKind::kScans, Direction::kRobotToServer, 1000));
  CHECK(ledger.Record(1, MessageKind::kPolicies, Direction::kServerToRobot, 40));
  CHECK_FALSE(ledger.Record(2, MessageKind::kScans, Direction::kRobotToServer, 300));
  CHECK_FALSE(ledger.Record(-1, MessageKind::kScans, Direction::kRobotToServer, 5));
  CHECK_FALSE(ledger.Record(INT64_MAX, MessageKind::kStatus, Direction::kServerToRobot, 7));
  CHECK_FALSE(ledger.Record(0, static_cast<MessageKind>(6), Direction::kRobotToServer, 11));
  CHECK_FALSE(ledger.Record(1, MessageKind::kOther, static_cast<Direction>(2), 13));

  CHECK(ledger.Get(0, MessageKind::kScans, Direction::kRobotToServer) == ByteCount{1, 1000});
  CHECK(ledger.Get(2, MessageKind::kScans, Direction::kRobotToServer) == ByteCount{});
  CHECK(ledger.Get(0, static_cast<MessageKind>(6), Direction::kRobotToServer) == ByteCount{});
  CHECK(ledger.InvalidRobot(MessageKind::kScans, Direction::kRobotToServer) == ByteCount{2, 305});
  CHECK(ledger.InvalidRobot(MessageKind::kStatus, Direction::kServerToRobot) == ByteCount{1, 7});
  CHECK(ledger.InvalidRobotTotal() == ByteCount{3, 312});
  CHECK(ledger.Unclassified() == ByteCount{2, 24});
  // Robots, invalid robots and unclassified add up to the total.
  ByteCount sum = ledger.RobotTotal(0);
  sum += ledger.RobotTotal(1);
  sum += ledger.InvalidRobotTotal();
  sum += ledger.Unclassified();
  CHECK(sum == ledger.Total());
  CHECK(ledger.Total() == ByteCount{7, 1000 + 40 + 305 + 7 + 24});
  CHECK(ledger.KindTotal(MessageKind::kScans) == ByteCount{3, 1305});
  CHECK(ledger.DirectionTotal(Direction::kServerToRobot) == ByteCount{2, 47});
}

TEST_CASE("ByteLedger kind and direction names are distinct and stable") {
  CHECK(std::string(MessageKindName(MessageKind::kKeyframes)) == "keyframes");
  CHECK(std::string(MessageKindName(MessageKind::kPoseUpdates)) == "pose_updates");
  CHECK(std::string(MessageKindName(MessageKind::kPolicies)) == "policies");
  CHECK(std::string(MessageKindName(MessageKind::kScans)) == "scans");
  CHECK(std::string(MessageKindName(MessageKind::kStatus)) == "status");
  CHECK(std::string(MessageKindName(MessageKind::kOther)) == "other");
  CHECK(std::string(MessageKindName(static_cast<MessageKind>(9))) == "invalid");
  CHECK(std::string(DirectionName(Direction::kRobotToServer)) == "robot_to_server");
  CHECK(std::string(DirectionName(Direction::kServerToRobot)) == "server_to_robot");
  CHECK(std::string(DirectionName(static_cast<Direction>(5))) == "invalid");
  std::set<std::string> names;
  for (MessageKind k : kAllKinds) names.insert(MessageKindName(k));
  CHECK(names.size() == kMessageKindCount);
}

TEST_CASE("ByteLedger params are checked and clamped") {
  CHECK(ValidateByteLedgerParams(ByteLedgerParams{}).ok());
  const Status zero = ValidateByteLedgerParams(ByteLedgerParams{0});
  CHECK(zero.code() == StatusCode::kInvalidArgument);
  CHECK(zero.message().find("max_robots") != std::string::npos);
  CHECK(ValidateByteLedgerParams(ByteLedgerParams{kByteLedgerMaxRobots + 1}).message().find("1025") !=
        std::string::npos);
  CHECK(ByteLedger(ByteLedgerParams{0}).max_robots() == 1);
  CHECK(ByteLedger(ByteLedgerParams{1u << 30}).max_robots() == kByteLedgerMaxRobots);
}

TEST_CASE("ByteLedger records and queries without touching the heap") {
  ByteLedger ledger(ByteLedgerParams{8});
  const std::uint64_t before = platform::OperatorNewCalls();
  std::uint64_t sink = 0;
  for (int i = 0; i < 1000; ++i) {
    ledger.Record(i % 11 - 1, static_cast<MessageKind>(i % 6), static_cast<Direction>(i % 2), 100);
    sink += ledger.Total().bytes + ledger.KindTotal(MessageKind::kScans).messages + ledger.RobotTotal(i % 8).bytes +
            ledger.InvalidRobotTotal().messages + ledger.DirectionTotal(Direction::kRobotToServer).bytes;
  }
  const std::uint64_t after = platform::OperatorNewCalls();
  CHECK(after == before);
  CHECK(sink > 0);
  CHECK(ledger.Total() == ByteCount{1000, 100000});
}

}  // namespace commerge
