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
  /// Points per stored scan assumed when a robot did not report its stored point counts. 4 300 is what a
  /// 64-beam scan keeps after the 1 m voxel grid (KITTI 00: 124 668 -> 4 273 points).
  std::uint32_t assumed_points_per_scan = 4300;
};

/// Scans one robot must send, and their predicted size.
struct RobotScanRequest {
  std::vector<std::uint32_t> keyframes;  ///< unique keyframe indices, ascending
  std::uint64_t predicted_bytes = 0;     ///< sum of encoded scan sizes
  std::size_t estimated_scans = 0;       ///< scans whose size used assumed_points_per_scan (no reported count)
};

struct ExchangePolicy {
  RobotScanRequest alpha;
  RobotScanRequest beta;
  std::size_t loops = 0;  ///< |L_K|
  std::uint64_t predicted_bytes() const noexcept { return alpha.predicted_bytes + beta.predicted_bytes; }
  std::size_t scans() const noexcept { return alpha.keyframes.size() + beta.keyframes.size(); }
};

/// Builds the policy from L_K. `alpha_points` / `beta_points`: stored point count per keyframe index as reported by
/// the robots (an empty span, or an entry of 0, means unknown -> assumed_points_per_scan). Errors
/// (InvalidArgument): a keyframe index beyond 2^32 - 1, a reported span shorter than a requested index.
Result<ExchangePolicy> MakeExchangePolicy(Span<const SequentialLoopCell> selected_loops,
                                          Span<const std::uint32_t> alpha_points,
                                          Span<const std::uint32_t> beta_points, const ExchangePolicyParams& params);

}  // namespace commerge
