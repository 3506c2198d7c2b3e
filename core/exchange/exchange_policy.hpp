// SPDX-License-Identifier: BSD-3-Clause
// commerge: exchange policy generation (paper "Exchange Policy Generation"): the server asks each robot for the
// unique endpoint keyframes of the selected loops L_K (eqs. exchange_policy_alpha / _beta), and predicts the
// bytes those scans will take on the wire in the compact scan encoding (core/cloud/scan_codec.hpp: 12 + 6 n
// bytes per scan of n points).
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "core/common/span.hpp"
#include "core/common/status.hpp"
#include "core/exchange/sequential_matching.hpp"

namespace commerge {

struct ExchangePolicyParams {
  /// Points per stored scan assumed when a robot did not report its stored point counts: what a 64-beam scan
  /// keeps after the 1 m voxel grid (core/agent/decisions/013-minimum-scans-per-robot.md).
  std::uint32_t assumed_points_per_scan = 4300;
  /// Fewest scans asked of each robot per pair (ours; 0 = no such rule). A floor by count; the default asks by
  /// points instead (min_points_per_robot).
  std::uint32_t min_scans_per_robot = 0;
  /// Fewest stored points asked of each robot per pair (ours, not in the paper; 0 = no such rule; with both rules
  /// 0 the policy is exactly the scans of L_K, the paper's). When L_K's keyframes of a robot hold fewer points by
  /// the counts the robot reported (assumed_points_per_scan where none was), keyframes of the same robot that
  /// stage A matched to the other robot (endpoints of L_seq, so they see the shared place) are added, nearest in
  /// trajectory index to one of L_K's first (ties: the lower index), until they hold this many: the submap grows
  /// along the same stretch of path and only with scans of the overlap, by what the coarse registration needs
  /// rather than by a count (core/agent/decisions/028-minimum-points-per-robot.md). The server pads every other
  /// exchange mode's selection by the same rules (MergeServer::Plan).
  std::uint32_t min_points_per_robot = 3000;
};

/// How far PadKeyframesFromPool grows a selection: until it has min_scans keyframes and its keyframes hold
/// min_points stored points (`points[k]` = keyframe k's reported count; an index past the span or a count of 0
/// counts as assumed_points).
struct PadTarget {
  std::uint32_t min_scans = 0;
  std::uint64_t min_points = 0;
  Span<const std::uint32_t> points;
  std::uint32_t assumed_points = ExchangePolicyParams{}.assumed_points_per_scan;
};

/// The policy's padding rules for one robot whose reported stored point counts are `points`.
PadTarget PolicyPadTarget(const ExchangePolicyParams& params, Span<const std::uint32_t> points);

/// Largest min_scans_per_robot accepted (a policy of more scans than this is not "a few scans").
inline constexpr std::uint32_t kMaxMinScansPerRobot = 1000;
/// Largest min_points_per_robot accepted (1000 scans of 10 000 points).
inline constexpr std::uint32_t kMaxMinPointsPerRobot = 10000000;

/// InvalidArgument naming the field for assumed_points_per_scan = 0, or min_scans_per_robot or
/// min_points_per_robot above its limit.
Status ValidateExchangePolicyParams(const ExchangePolicyParams& params);

/// Scans one robot must send, and their predicted size.
struct RobotScanRequest {
  std::vector<std::uint32_t> keyframes;  ///< unique keyframe indices, ascending
  std::uint64_t predicted_bytes = 0;     ///< sum of encoded scan sizes
  std::size_t estimated_scans = 0;       ///< scans whose size used assumed_points_per_scan (no reported count)
  std::size_t padded_scans = 0;          ///< keyframes added by the padding rules (L_seq's, not L_K's)
};

struct ExchangePolicy {
  RobotScanRequest alpha;
  RobotScanRequest beta;
  std::size_t loops = 0;  ///< |L_K|
  std::uint64_t predicted_bytes() const noexcept { return alpha.predicted_bytes + beta.predicted_bytes; }
  std::size_t scans() const noexcept { return alpha.keyframes.size() + beta.keyframes.size(); }
};

/// Adds keyframes of `pool` (e.g. endpoints of the overlap loops L_seq) to the sorted, unique `keyframes` until
/// they meet `target` or the pool is used up: nearest in index to a selected keyframe first (distances to the
/// selection as it was given), ties to the lower index. An empty `keyframes` stays empty (nothing to grow from).
/// Returns how many were added.
std::size_t PadKeyframesFromPool(std::vector<std::uint32_t>* keyframes, std::vector<std::uint32_t> pool,
                                 const PadTarget& target);

/// Builds the policy from L_K. `alpha_points` / `beta_points`: stored point count per keyframe index as reported by
/// the robots (an empty span, or an entry of 0, means unknown -> assumed_points_per_scan). `overlap_loops`: the
/// loops whose endpoints may pad a robot's request (L_seq; empty = no padding).
/// Errors (InvalidArgument): a keyframe index beyond 2^32 - 1, a reported span shorter than a requested index,
/// bad params.
Result<ExchangePolicy> MakeExchangePolicy(Span<const SequentialLoopCell> selected_loops,
                                          Span<const SequentialLoopCell> overlap_loops,
                                          Span<const std::uint32_t> alpha_points,
                                          Span<const std::uint32_t> beta_points, const ExchangePolicyParams& params);

}  // namespace commerge
