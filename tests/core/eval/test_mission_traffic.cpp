// SPDX-License-Identifier: BSD-3-Clause
// MissionTraffic: totals, d_exch and t_comm against an independent tally of a random message stream (the paper's
// eqs. exchmetric and commmetric written out), and the bounded time series against the stream's cumulative bytes.
#include <doctest/doctest.h>

#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "core/eval/mission_traffic.hpp"

using namespace commerge;

TEST_CASE("MissionTraffic: totals, d_exch and t_comm match an independent tally of a random stream") {
  MissionTrafficParams params;
  params.max_robots = 4;
  params.max_samples = 64;
  params.sample_interval_s = 0.5;
  MissionTraffic traffic(params);
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> robot(-1, 4), kind(0, kTrafficKinds - 1), bytes(0, 20000);
  std::exponential_distribution<double> gap(4.0);
  std::map<std::pair<int, int>, std::uint64_t> tally;
  std::array<double, 4> first{-1, -1, -1, -1}, last{-1, -1, -1, -1};
  std::vector<std::pair<double, std::array<std::uint64_t, 4>>> history;  // after each in-range message
  std::array<std::uint64_t, 4> cumulative{};
  std::uint64_t other = 0, total = 0;
  double t = 3.0;
  for (int i = 0; i < 5000; ++i) {
    t += gap(rng);
    const int r = robot(rng), k = kind(rng);
    const std::uint64_t b = static_cast<std::uint64_t>(bytes(rng));
    traffic.Record(r, static_cast<TrafficKind>(k), b, t);
    total += b;
    if (r < 0 || r >= 4) {
      other += b;
      continue;
    }
    tally[{r, k}] += b;
    cumulative[static_cast<std::size_t>(r)] += b;
    history.emplace_back(t, cumulative);
    if (static_cast<TrafficKind>(k) != TrafficKind::kRobotStatus) {
      if (first[static_cast<std::size_t>(r)] < 0) first[static_cast<std::size_t>(r)] = t;
      last[static_cast<std::size_t>(r)] = t;
    }
  }
  std::uint64_t exchanged = 0;
  double comm = 0.0;
  for (int r = 0; r < 4; ++r) {
    std::uint64_t robot_total = 0;
    for (int k = 0; k < static_cast<int>(kTrafficKinds); ++k) {
      CHECK(traffic.Bytes(r, static_cast<TrafficKind>(k)) == tally[{r, k}]);
      robot_total += tally[{r, k}];
      if (static_cast<TrafficKind>(k) != TrafficKind::kRobotStatus) exchanged += tally[{r, k}];
    }
    CHECK(traffic.RobotTotal(r) == robot_total);
    CHECK(traffic.first_s(r) == first[static_cast<std::size_t>(r)]);
    CHECK(traffic.last_s(r) == last[static_cast<std::size_t>(r)]);
    comm += last[static_cast<std::size_t>(r)] - first[static_cast<std::size_t>(r)];
  }
  for (int k = 0; k < static_cast<int>(kTrafficKinds); ++k) {
    std::uint64_t n = 0;
    for (int r = 0; r < 4; ++r) n += tally[{r, k}];
    CHECK(traffic.KindTotal(static_cast<TrafficKind>(k)) == n);
  }
  CHECK(traffic.other_bytes() == other);
  CHECK(traffic.Total() == total);
  CHECK(traffic.ExchangedBytes() == exchanged);
  CHECK(traffic.CommSeconds() == doctest::Approx(comm).epsilon(1e-12));
  CHECK(traffic.first_s(-1) == -1.0);
  CHECK(traffic.Bytes(9, TrafficKind::kScans) == 0);

  // The time series: at most max_samples, times ascending, each sample the cumulative bytes after the message at
  // its time; the last is the final state; the interval doubled as often as the series was halved.
  const std::size_t n = traffic.num_samples();
  REQUIRE(n >= 2);
  CHECK(n <= params.max_samples);
  CHECK(traffic.sample_interval_s() > params.sample_interval_s);
  for (std::size_t i = 0; i < n; ++i) {
    if (i > 0) CHECK(traffic.sample_time_s(i) > traffic.sample_time_s(i - 1));
    std::size_t j = 0;
    while (j + 1 < history.size() && history[j + 1].first <= traffic.sample_time_s(i)) ++j;
    REQUIRE(history[j].first == traffic.sample_time_s(i));
    for (int r = 0; r < 4; ++r) CHECK(traffic.sample_bytes(i, r) == history[j].second[static_cast<std::size_t>(r)]);
  }
  CHECK(traffic.sample_time_s(n - 1) == history.back().first);
  for (int r = 0; r < 4; ++r) CHECK(traffic.sample_bytes(n - 1, r) == cumulative[static_cast<std::size_t>(r)]);
  // Halved at least once: more than half of the capacity is in use only between halvings.
  CHECK(n > params.max_samples / 2 - 1);
}

TEST_CASE("MissionTraffic: a scan burst is one step of the series, and times never run backwards") {
  MissionTraffic traffic(MissionTrafficParams{2, 16, 1.0});
  for (int s = 0; s < 10; ++s) traffic.Record(0, TrafficKind::kKeyframeRecords, 100, s);
  for (int c = 0; c < 50; ++c) traffic.Record(1, TrafficKind::kScans, 1200, 10.0 + 0.001 * c);  // one burst
  traffic.Record(1, TrafficKind::kKeyframeRecords, 100, 5.0);  // an earlier time: taken as the last
  CHECK(traffic.last_s(1) == doctest::Approx(10.049));
  CHECK(traffic.first_s(1) == doctest::Approx(10.0));
  CHECK(traffic.CommSeconds() == doctest::Approx(9.0 + 0.049));
  const std::size_t n = traffic.num_samples();
  CHECK(traffic.sample_bytes(n - 1, 1) == 50 * 1200 + 100);
  // The burst falls in one sample interval: the sample before it holds none of robot 1's bytes.
  CHECK(traffic.sample_bytes(n - 2, 1) == 0);
  CHECK(traffic.RobotTotal(0) == 1000);
  // Robot status is not exchange payload and does not move first/last transmission.
  traffic.Record(0, TrafficKind::kRobotStatus, 400, 60.0);
  CHECK(traffic.ExchangedBytes() == 1000 + 60100);
  CHECK(traffic.last_s(0) == 9.0);
  traffic.Record(0, TrafficKind::kScans, 10, std::numeric_limits<double>::quiet_NaN());
  CHECK(traffic.last_s(0) == 60.0);
}

TEST_CASE("MissionTraffic: parameters outside their ranges are named and clamped") {
  CHECK(ValidateMissionTrafficParams(MissionTrafficParams{}).ok());
  CHECK(ValidateMissionTrafficParams(MissionTrafficParams{0, 64, 1.0}).message().find("max_robots = 0") !=
        std::string::npos);
  CHECK(ValidateMissionTrafficParams(MissionTrafficParams{4, 8, 1.0}).message().find("max_samples = 8") !=
        std::string::npos);
  CHECK(ValidateMissionTrafficParams(MissionTrafficParams{4, 64, 0.0}).message().find("sample_interval_s") !=
        std::string::npos);
  MissionTraffic clamped(MissionTrafficParams{1000, 1, -1.0});
  CHECK(clamped.max_robots() == 64);
  for (int i = 0; i < 100; ++i) clamped.Record(0, TrafficKind::kScans, 1, i);
  CHECK(clamped.num_samples() <= 16);
}
