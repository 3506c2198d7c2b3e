// SPDX-License-Identifier: BSD-3-Clause
#include "platform/io/exchange_outputs.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "platform/io/file_util.hpp"
#include "platform/io/text_io.hpp"
#include "platform/report/png_writer.hpp"

namespace commerge::platform {

namespace {

Status WriteText(const std::string& path, const char* mode, const std::string& text) {
  std::FILE* f = std::fopen(path.c_str(), mode);
  if (f == nullptr) return IoError("cannot write " + path + ": " + std::strerror(errno));
  const bool wrote = std::fwrite(text.data(), 1, text.size(), f) == text.size() && std::ferror(f) == 0;
  if (std::fclose(f) != 0 || !wrote) return IoError("error writing " + path);
  return Status::Ok();
}

void AddField(std::string* line, const std::string& field) {
  if (!line->empty()) *line += '\t';
  *line += field;
}

std::string Seconds(double s) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", s);
  return buf;
}

}  // namespace

std::string ExchangeRoundsHeader(int robots) {
  std::string line;
  for (const char* c : {"round", "time_s", "robots_placed", "robots", "pairs_merged", "pairs_registered",
                        "pairs_kept", "scans_requested", "scans_widened", "scans_refined"}) {
    AddField(&line, c);
  }
  for (std::size_t k = 0; k < kTrafficKinds; ++k) AddField(&line, std::string(TrafficKindName(static_cast<TrafficKind>(k))) + "_B");
  AddField(&line, "total_B");
  for (int r = 0; r < robots; ++r) AddField(&line, "robot" + std::to_string(r) + "_B");
  AddField(&line, "placed");
  AddField(&line, "pairs");
  return line + "\n";
}

Status StartExchangeRounds(const std::string& path, int robots) {
  return WriteText(path, "w", ExchangeRoundsHeader(robots));
}

Status AppendExchangeRound(const std::string& path, const ExchangeRoundRow& row) {
  std::string line;
  AddField(&line, std::to_string(row.round));
  AddField(&line, Seconds(row.time_s));
  for (std::size_t v : {static_cast<std::size_t>(row.robots_placed), static_cast<std::size_t>(row.robots),
                        row.pairs_merged, row.pairs_registered, row.pairs_kept, row.scans_requested, row.scans_widened,
                        row.scans_refined}) {
    AddField(&line, std::to_string(v));
  }
  std::uint64_t total = 0;
  for (std::uint64_t b : row.bytes) {
    AddField(&line, std::to_string(b));
    total += b;
  }
  AddField(&line, std::to_string(total));
  for (std::uint64_t b : row.robot_bytes) AddField(&line, std::to_string(b));
  std::string placed;
  for (int r : row.placed) placed += (placed.empty() ? "" : ",") + std::to_string(r);
  AddField(&line, placed.empty() ? "-" : placed);
  std::string pairs = row.pairs.empty() ? "-" : row.pairs;
  for (char& c : pairs) {
    if (c == '\t' || c == '\n' || c == '\r') c = ' ';
  }
  AddField(&line, pairs);
  return WriteText(path, "a", line + "\n");
}

Status WriteExchangeSummary(const std::string& path, const MissionTraffic& traffic, const ExchangeSummary& summary) {
  std::string text = "# commerge server: what the robots sent this server (eqs. exchmetric, commmetric)\n";
  const auto put = [&text](const std::string& key, const std::string& value) { text += key + "\t" + value + "\n"; };
  put("d_exch_bytes", std::to_string(traffic.ExchangedBytes()));
  put("t_comm_s", Seconds(traffic.CommSeconds()));
  put("total_bytes", std::to_string(traffic.Total()));
  for (std::size_t k = 0; k < kTrafficKinds; ++k) {
    const auto kind = static_cast<TrafficKind>(k);
    put(std::string(TrafficKindName(kind)) + "_bytes", std::to_string(traffic.KindTotal(kind)));
  }
  put("other_bytes", std::to_string(traffic.other_bytes()));
  put("rounds", std::to_string(summary.rounds));
  put("send_all_bytes", std::to_string(summary.send_all_bytes));
  put("policies_sent_bytes", std::to_string(summary.policies_sent_bytes));
  for (std::size_t r = 0; r < summary.keyframes.size(); ++r) {
    const int robot = static_cast<int>(r);
    const std::string p = "robot" + std::to_string(r) + "_";
    put(p + "bytes", std::to_string(traffic.RobotTotal(robot)));
    put(p + "first_s", Seconds(traffic.first_s(robot)));
    put(p + "last_s", Seconds(traffic.last_s(robot)));
    put(p + "keyframes", std::to_string(summary.keyframes[r]));
    put(p + "scans_received", std::to_string(r < summary.scans_received.size() ? summary.scans_received[r] : 0));
  }
  return WriteText(path, "w", text);
}

StackedSeriesInput ExchangeBytesChart(const MissionTraffic& traffic, int robots, Span<const double> round_end_s) {
  StackedSeriesInput in;
  const std::size_t n = traffic.num_samples();
  // The axis starts at the first exchange message; a point at 0 bytes there, so the first sample is a step up.
  double origin = n > 0 ? traffic.sample_time_s(0) : 0.0;
  for (int r = 0; r < robots; ++r) {
    if (traffic.first_s(r) >= 0.0) origin = std::min(origin, traffic.first_s(r));
  }
  in.times_s.push_back(0.0);
  for (int r = 0; r < robots; ++r) in.series.push_back("robot " + std::to_string(r));
  in.values.assign(static_cast<std::size_t>(robots), 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    in.times_s.push_back(traffic.sample_time_s(i) - origin);
    for (int r = 0; r < robots; ++r) in.values.push_back(static_cast<double>(traffic.sample_bytes(i, r)));
  }
  for (double t : round_end_s) in.marks_s.push_back(t - origin);
  in.title = "Bytes the robots sent the server (dotted: merge rounds)";
  in.time_label = "time since the first message [s]";
  in.value_label = "bytes received";
  in.width_px = 1000;
  in.height_px = 560;
  return in;
}

Status WriteExchangeBytesPng(const std::string& path, const MissionTraffic& traffic, int robots,
                             Span<const double> round_end_s) {
  auto image = RenderStackedSeries(ExchangeBytesChart(traffic, robots, round_end_s));
  if (!image.ok()) return image.status();
  return WritePng(path, *image);
}

}  // namespace commerge::platform
