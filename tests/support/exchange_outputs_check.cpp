// SPDX-License-Identifier: BSD-3-Clause
// cm_check_exchange_outputs DIR ROBOTS [RECEIVED_BYTES]: reads back what `commerge server --out DIR` wrote about
// the mission's bytes (platform/io/exchange_outputs.hpp) and checks it holds together:
//   exchange_rounds.tsv   the documented columns; rounds 1..N in order; time and every byte column never
//                         decreasing; total_B = the sum of the kinds = the sum of the robots; robots_placed <= robots
//                         and as many robots listed in `placed`;
//   exchange_summary.tsv  d_exch = total - robot status - other; the last round's bytes within the total; rounds = N;
//                         the robots' bytes add up; first <= last transmission; t_comm = the sum of last - first;
//                         the total equals RECEIVED_BYTES (the server's exit line) when given; the policies the
//                         server sent (policies_sent_bytes, its outgoing traffic) are counted, and not zero when a
//                         round requested scans;
//   exchange_bytes.png    decodes (tests/support/png_reader.hpp) at 1000 x 560, with pixels of every robot's colour
//                         that sent bytes.
// Prints one line and exits 0 when all hold, else names the first that does not and exits 1 (2: usage).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "core/eval/mission_traffic.hpp"
#include "platform/io/exchange_outputs.hpp"
#include "platform/report/raster_image.hpp"
#include "tests/support/png_reader.hpp"

namespace {

using commerge::kTrafficKinds;

std::vector<std::string> SplitTabs(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, '\t')) out.push_back(field);
  return out;
}

int Fail(const std::string& why) {
  std::printf("exchange outputs: %s\n", why.c_str());
  return 1;
}

bool ToNumber(const std::string& s, double* v) {
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return !s.empty() && end == s.c_str() + s.size() && std::isfinite(*v);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::fprintf(stderr, "usage: cm_check_exchange_outputs DIR ROBOTS [RECEIVED_BYTES]\n");
    return 2;
  }
  const std::string dir = argv[1];
  const int robots = std::atoi(argv[2]);
  const double received = argc == 4 ? std::atof(argv[3]) : -1.0;
  if (robots < 1 || robots > 64) return Fail("ROBOTS must be 1..64");

  // ---- exchange_rounds.tsv
  std::ifstream rounds_file(dir + "/exchange_rounds.tsv");
  if (!rounds_file) return Fail("cannot read " + dir + "/exchange_rounds.tsv");
  std::string line;
  std::getline(rounds_file, line);
  std::string expected = commerge::platform::ExchangeRoundsHeader(robots);
  expected.pop_back();  // its newline
  if (line != expected) return Fail("header is '" + line + "', not '" + expected + "'");
  const std::vector<std::string> columns = SplitTabs(line);
  const std::size_t first_kind = 10, total_column = first_kind + kTrafficKinds, first_robot = total_column + 1;
  std::vector<double> previous(columns.size(), 0.0);
  int rows = 0;
  const std::size_t scans_requested_column =
      static_cast<std::size_t>(std::find(columns.begin(), columns.end(), "scans_requested") - columns.begin());
  if (scans_requested_column >= first_kind) return Fail("exchange_rounds.tsv has no scans_requested column");
  double scans_requested = 0.0;  // over every round
  while (std::getline(rounds_file, line)) {
    const std::vector<std::string> f = SplitTabs(line);
    const std::string where = "exchange_rounds.tsv row " + std::to_string(rows + 1);
    if (f.size() != columns.size()) return Fail(where + ": " + std::to_string(f.size()) + " fields");
    std::vector<double> v(f.size(), 0.0);
    for (std::size_t c = 0; c + 2 < f.size(); ++c) {
      if (!ToNumber(f[c], &v[c]) || v[c] < 0.0) return Fail(where + ": " + columns[c] + " = '" + f[c] + "'");
    }
    if (f.back().empty()) return Fail(where + ": no pairs text");
    const std::string& placed = f[f.size() - 2];
    const std::size_t listed = placed == "-" ? 0 : static_cast<std::size_t>(std::count(placed.begin(), placed.end(), ',')) + 1;
    if (listed != static_cast<std::size_t>(v[2])) return Fail(where + ": placed '" + placed + "' for robots_placed " + f[2]);
    if (v[0] != rows + 1) return Fail(where + ": round " + f[0]);
    if (v[2] > v[3] || v[3] > robots) return Fail(where + ": " + f[2] + " of " + f[3] + " robots placed");
    for (std::size_t c : {std::size_t{1}}) {
      if (v[c] < previous[c]) return Fail(where + ": time_s went back");
    }
    double kinds = 0.0, per_robot = 0.0;
    for (std::size_t c = first_kind; c < first_kind + kTrafficKinds; ++c) kinds += v[c];
    for (std::size_t c = first_robot; c + 2 < f.size(); ++c) per_robot += v[c];
    if (kinds != v[total_column]) return Fail(where + ": total_B is not the sum of the kinds");
    if (per_robot != v[total_column]) return Fail(where + ": total_B is not the sum of the robots");
    for (std::size_t c = first_kind; c + 2 < f.size(); ++c) {
      if (v[c] < previous[c]) return Fail(where + ": " + columns[c] + " went down");
    }
    scans_requested += v[scans_requested_column];
    previous = v;
    ++rows;
  }
  if (rows == 0) return Fail("exchange_rounds.tsv has no round");

  // ---- exchange_summary.tsv
  std::ifstream summary_file(dir + "/exchange_summary.tsv");
  if (!summary_file) return Fail("cannot read " + dir + "/exchange_summary.tsv");
  std::map<std::string, double> s;
  while (std::getline(summary_file, line)) {
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> f = SplitTabs(line);
    double v = 0.0;
    if (f.size() != 2 || !ToNumber(f[1], &v)) return Fail("exchange_summary.tsv: line '" + line + "'");
    s[f[0]] = v;
  }
  for (const char* key : {"d_exch_bytes", "t_comm_s", "total_bytes", "robot_status_bytes", "other_bytes", "rounds",
                          "send_all_bytes", "policies_sent_bytes"}) {
    if (!s.count(key)) return Fail(std::string("exchange_summary.tsv has no ") + key);
  }
  if (s["d_exch_bytes"] != s["total_bytes"] - s["robot_status_bytes"] - s["other_bytes"]) {
    return Fail("d_exch_bytes is not total - robot status - other");
  }
  // Scans come on request: a round that requested scans published a policy (its bytes are what the server sent,
  // apart from what it received).
  if (s["policies_sent_bytes"] < 0.0 || (scans_requested > 0.0 && s["policies_sent_bytes"] <= 0.0)) {
    return Fail("policies_sent_bytes " + std::to_string(s["policies_sent_bytes"]) + " after " +
                std::to_string(scans_requested) + " scans requested");
  }
  if (s["rounds"] != rows) return Fail("summary rounds " + std::to_string(s["rounds"]) + " for " + std::to_string(rows) + " rows");
  if (previous[total_column] > s["total_bytes"]) return Fail("the last round's total_B exceeds total_bytes");
  double robot_sum = 0.0, comm = 0.0;
  for (int r = 0; r < robots; ++r) {
    const std::string p = "robot" + std::to_string(r) + "_";
    if (!s.count(p + "bytes") || !s.count(p + "first_s") || !s.count(p + "last_s")) return Fail("no " + p + "*");
    robot_sum += s[p + "bytes"];
    if (s[p + "first_s"] >= 0.0) {
      if (s[p + "last_s"] < s[p + "first_s"]) return Fail(p + "last_s before first_s");
      comm += s[p + "last_s"] - s[p + "first_s"];
    }
  }
  if (robot_sum != s["total_bytes"] - s["other_bytes"]) return Fail("the robots' bytes do not add up to the total");
  if (std::fabs(comm - s["t_comm_s"]) > 0.01 * robots) return Fail("t_comm_s is not the sum of last - first");
  if (received >= 0.0 && s["total_bytes"] != received) {
    return Fail("total_bytes " + std::to_string(s["total_bytes"]) + " is not the server's " + std::to_string(received));
  }

  // ---- exchange_bytes.png
  const commerge::test::DecodedPng png = commerge::test::DecodePngFile(dir + "/exchange_bytes.png");
  if (!png.ok) return Fail("exchange_bytes.png: " + png.error);
  if (png.width != 1000 || png.height != 560) {
    return Fail("exchange_bytes.png is " + std::to_string(png.width) + " x " + std::to_string(png.height));
  }
  for (int r = 0; r < robots; ++r) {
    if (s["robot" + std::to_string(r) + "_bytes"] <= 0.0) continue;
    const commerge::platform::Rgb c = commerge::platform::RobotColour(r);
    const std::uint32_t want = (std::uint32_t{c.r} << 16) | (std::uint32_t{c.g} << 8) | c.b;
    long pixels = 0;
    for (int y = 0; y < png.height; ++y) {
      for (int x = 0; x < png.width; ++x) pixels += png.At(x, y) == want ? 1 : 0;
    }
    if (pixels < 200) return Fail("exchange_bytes.png shows robot " + std::to_string(r) + " in " + std::to_string(pixels) + " pixels");
  }
  std::printf("exchange outputs OK: %d rounds, %.0f bytes (d_exch %.0f), t_comm %.1f s, %.0f policy bytes sent, "
              "chart %d x %d\n", rows, s["total_bytes"], s["d_exch_bytes"], s["t_comm_s"], s["policies_sent_bytes"],
              png.width, png.height);
  return 0;
}
