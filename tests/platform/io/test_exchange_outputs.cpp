// SPDX-License-Identifier: BSD-3-Clause
// The server's exchange outputs (platform/io/exchange_outputs.hpp) read back: exchange_rounds.tsv field by field,
// exchange_summary.tsv against the traffic's own figures and the paper's eqs. exchmetric and commmetric written
// out, and exchange_bytes.png decoded by the independent reader with each robot's band where its bytes put it.
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/eval/mission_traffic.hpp"
#include "platform/io/exchange_outputs.hpp"
#include "platform/report/raster_image.hpp"
#include "tests/support/png_reader.hpp"
#include "tests/support/test_data.hpp"

using namespace commerge;

namespace {

std::vector<std::vector<std::string>> ReadTsv(const std::string& path) {
  std::vector<std::vector<std::string>> rows;
  std::istringstream in(test::ReadTextFile(path));
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] == '#') continue;
    std::vector<std::string> fields;
    std::string f;
    std::istringstream l(line);
    while (std::getline(l, f, '\t')) fields.push_back(f);
    rows.push_back(fields);
  }
  return rows;
}

}  // namespace

TEST_CASE("Exchange outputs: rounds, summary and chart read back as written") {
  // Two robots: records every second from 1 s (robot 0) and 1.5 s (robot 1), robot 1's scans in one burst at 30 s,
  // robot 0's status every 10 s, a pose update and a re-sent record; recorded in time order.
  struct Event {
    double t;
    int robot;
    TrafficKind kind;
    std::uint64_t bytes;
  };
  std::vector<Event> events;
  for (int s = 0; s < 60; ++s) {
    events.push_back({1.0 + s, 0, TrafficKind::kKeyframeRecords, 1100});
    events.push_back({1.5 + s, 1, TrafficKind::kKeyframeRecords, 1000});
    if (s % 10 == 0) events.push_back({1.2 + s, 0, TrafficKind::kRobotStatus, 380});
  }
  for (int c = 0; c < 100; ++c) events.push_back({30.0 + 0.01 * c, 1, TrafficKind::kScans, 1250});
  events.push_back({40.0, 0, TrafficKind::kPoseUpdates, 660});
  events.push_back({41.0, 0, TrafficKind::kResends, 139});
  std::stable_sort(events.begin(), events.end(), [](const Event& a, const Event& b) { return a.t < b.t; });
  MissionTraffic traffic(MissionTrafficParams{2, 256, 1.0});
  for (const Event& e : events) traffic.Record(e.robot, e.kind, e.bytes, e.t);

  const std::string rounds = test::ScratchFile("exchange_rounds.tsv");
  REQUIRE(platform::StartExchangeRounds(rounds, 2).ok());
  platform::ExchangeRoundRow row;
  row.round = 1;
  row.time_s = 31.25;
  row.robots_placed = 2;
  row.robots = 2;
  row.pairs_merged = 1;
  row.pairs_registered = 1;
  row.scans_requested = 100;
  row.scans_widened = 4;
  row.scans_refined = 2;
  for (std::size_t k = 0; k < kTrafficKinds; ++k) row.bytes[k] = traffic.KindTotal(static_cast<TrafficKind>(k));
  row.robot_bytes = {traffic.RobotTotal(0), traffic.RobotTotal(1)};
  row.placed = {0, 1};
  row.pairs = "0-1 robot_not_placed 100+4";
  REQUIRE(platform::AppendExchangeRound(rounds, row).ok());
  row.round = 2;
  row.pairs_registered = 0;
  row.pairs_kept = 1;
  row.scans_requested = row.scans_widened = row.scans_refined = 0;
  row.placed = {0};
  row.robots_placed = 1;
  row.pairs = "a\ttab";  // a tab in the text would shift the columns: written as a space
  REQUIRE(platform::AppendExchangeRound(rounds, row).ok());

  const auto tsv = ReadTsv(rounds);
  REQUIRE(tsv.size() == 3);
  const std::vector<std::string> header = {"round", "time_s", "robots_placed", "robots", "pairs_merged", "pairs_registered",
                                           "pairs_kept", "scans_requested", "scans_widened", "scans_refined", "keyframe_records_B",
                                           "pose_updates_B", "scans_B", "resends_B", "robot_status_B", "total_B",
                                           "robot0_B", "robot1_B", "placed", "pairs"};
  CHECK(tsv[0] == header);
  // records 60 x 1100 + 60 x 1000, poses 660, scans 100 x 1250, re-sent 139, status 6 x 380; robot 0 66000 + 660 +
  // 139 + 2280, robot 1 60000 + 125000.
  const std::vector<std::string> first = {"1", "31.250", "2", "2", "1", "1", "0", "100", "4", "2", "126000", "660", "125000",
                                          "139", "2280", "254079", "69079", "185000", "0,1", "0-1 robot_not_placed 100+4"};
  CHECK(tsv[1] == first);
  CHECK(tsv[2][0] == "2");
  CHECK(tsv[2][6] == "1");
  CHECK(tsv[2][9] == "0");
  CHECK(tsv[2][18] == "0");
  CHECK(tsv[2][19] == "a tab");

  const std::string summary_path = test::ScratchFile("exchange_summary.tsv");
  platform::ExchangeSummary summary;
  summary.rounds = 2;
  summary.send_all_bytes = 5000000;
  summary.keyframes = {60, 60};
  summary.scans_received = {0, 100};
  summary.policies_sent_bytes = 3 * 212;  // three scan requests the server sent
  REQUIRE(platform::WriteExchangeSummary(summary_path, traffic, summary).ok());
  std::map<std::string, std::string> s;
  for (const auto& f : ReadTsv(summary_path)) {
    REQUIRE(f.size() == 2);
    s[f[0]] = f[1];
  }
  // eq. exchmetric: the payload of every robot message but robot status; eq. commmetric: last - first per robot.
  CHECK(s["d_exch_bytes"] == std::to_string(126000 + 660 + 125000 + 139));
  CHECK(s["t_comm_s"] == "118.000");  // robot 0: 1 .. 60 s, robot 1: 1.5 .. 60.5 s
  CHECK(s["total_bytes"] == "254079");
  CHECK(s["scans_bytes"] == "125000");
  CHECK(s["robot_status_bytes"] == "2280");
  CHECK(s["rounds"] == "2");
  CHECK(s["send_all_bytes"] == "5000000");
  // The server's own outgoing policies: written beside, never part of what it received.
  CHECK(s["policies_sent_bytes"] == std::to_string(summary.policies_sent_bytes));
  CHECK(s["total_bytes"] == std::to_string(traffic.Total()));
  CHECK(s["robot0_first_s"] == "1.000");
  CHECK(s["robot1_last_s"] == "60.500");
  CHECK(s["robot1_scans_received"] == "100");

  // The chart: robot 0's band at the bottom, robot 1's on top of it, which jumps by its scans at 30 s.
  const std::string png_path = test::ScratchFile("exchange_bytes.png");
  const std::vector<double> marks = {31.25};
  REQUIRE(platform::WriteExchangeBytesPng(png_path, traffic, 2, Span<const double>(marks)).ok());
  const test::DecodedPng png = test::DecodePngFile(png_path);
  REQUIRE_MESSAGE(png.ok, png.error);
  const platform::StackedSeriesInput chart = platform::ExchangeBytesChart(traffic, 2, Span<const double>(marks));
  auto layout = platform::LayoutStackedSeries(chart);
  REQUIRE(layout.ok());
  CHECK(png.width == layout->image_width_px);
  CHECK(png.height == layout->image_height_px);
  const auto colour = [](int r) {
    const platform::Rgb c = platform::RobotColour(r);
    return (std::uint32_t{c.r} << 16) | (std::uint32_t{c.g} << 8) | c.b;
  };
  const auto band_height = [&](int x, int r) {
    int n = 0;
    for (int y = layout->plot_y_px; y < layout->plot_y_px + layout->plot_height_px; ++y) n += png.At(x, y) == colour(r);
    return n;
  };
  const auto column_at = [&](double t_since_first) {
    return layout->plot_x_px + static_cast<int>(t_since_first / layout->time_max_s * layout->plot_width_px);
  };
  // Before the burst (25 s after the first message) and after it (35 s): robot 1's band grows by the scans and
  // its ten records between (a pixel or two of rounding).
  const int before = band_height(column_at(25.0), 1), after = band_height(column_at(35.0), 1);
  CHECK(std::abs(after - before - layout->HeightPx(125000.0 + 10 * 1000.0)) <= 3);
  CHECK(band_height(column_at(35.0), 0) > 0);
  CHECK(chart.times_s.front() == 0.0);  // the axis starts at the first message
  CHECK(chart.marks_s == std::vector<double>{30.25});
}
