// SPDX-License-Identifier: BSD-3-Clause
// commerge: the server's record of what the mission exchanged (apps/README.md "Exchange outputs"):
//   exchange_rounds.tsv   one row per merge round: when it ended, robots placed, pairs registered and kept, the
//                         scans it requested and why (per pair), and the bytes received so far by kind and robot;
//   exchange_summary.tsv  at exit, key<TAB>value: the paper's d_exch (eq. exchmetric) and t_comm (eq. commmetric),
//                         bytes by kind and robot, what sending every stored scan would have cost, and the bytes of
//                         the exchange policies the server itself sent;
//   exchange_bytes.png    the bytes each robot sent over time, stacked (descriptors growing steadily, scans in a
//                         few jumps), with a dotted line where each round ended.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/eval/mission_traffic.hpp"
#include "platform/report/report_charts.hpp"

namespace commerge::platform {

struct ExchangeRoundRow {
  int round = 0;
  double time_s = 0.0;  ///< since the server started
  int robots_placed = 0;
  int robots = 0;  ///< robots heard of
  std::size_t pairs_merged = 0;  ///< pair results that hold a transform (registered now or kept)
  std::size_t pairs_registered = 0, pairs_kept = 0;
  std::size_t scans_requested = 0, scans_widened = 0;
  std::size_t scans_refined = 0;  ///< asked for by the final refinement of accepted pairs (MergeRoundResult)
  std::array<std::uint64_t, kTrafficKinds> bytes{};  ///< received so far, by TrafficKind
  std::vector<std::uint64_t> robot_bytes;           ///< received so far, per robot 0..n-1 (every kind)
  std::vector<int> placed;                          ///< the robots in the world frame after the round
  std::string pairs;  ///< per pair "a-b reason scans[+widened]", joined by "; " (ExchangeDecisionsText)
};

/// The columns of exchange_rounds.tsv for `robots` robots, tab-separated: round, time_s, robots_placed, robots,
/// pairs_merged, pairs_registered, pairs_kept, scans_requested, scans_widened, scans_refined, <kind>_B for every
/// TrafficKind, total_B,
/// robot<r>_B for r = 0..robots-1, placed (robot ids joined by ",", "-" for none), pairs.
std::string ExchangeRoundsHeader(int robots);
/// Creates (or empties) the file with its header line.
Status StartExchangeRounds(const std::string& path, int robots);
/// Appends one row (robot_bytes.size() must be the file's robot count).
Status AppendExchangeRound(const std::string& path, const ExchangeRoundRow& row);

struct ExchangeSummary {
  int rounds = 0;
  std::uint64_t send_all_bytes = 0;  ///< the keyframe records received plus every stored scan the robots reported
  /// Exchange policies (scan requests, repeats included) the server published, encoded: its outgoing traffic,
  /// not part of the received total.
  std::uint64_t policies_sent_bytes = 0;
  std::vector<std::uint32_t> keyframes;       ///< per robot, held by the server
  std::vector<std::uint32_t> scans_received;  ///< per robot, complete scans held
};

/// key<TAB>value lines: d_exch_bytes, t_comm_s, total_bytes, <kind>_bytes, other_bytes, rounds, send_all_bytes,
/// policies_sent_bytes, and per robot r robot<r>_bytes, robot<r>_first_s, robot<r>_last_s (-1: nothing sent),
/// robot<r>_keyframes, robot<r>_scans_received.
Status WriteExchangeSummary(const std::string& path, const MissionTraffic& traffic, const ExchangeSummary& summary);

/// The chart of exchange_bytes.png: robots 0..robots-1 stacked over the traffic's time series, marks at the
/// rounds' ends.
StackedSeriesInput ExchangeBytesChart(const MissionTraffic& traffic, int robots, Span<const double> round_end_s);
Status WriteExchangeBytesPng(const std::string& path, const MissionTraffic& traffic, int robots,
                             Span<const double> round_end_s);

}  // namespace commerge::platform
