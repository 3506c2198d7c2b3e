// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/exchange_policy.hpp"

#include <algorithm>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "core/cloud/scan_codec.hpp"

namespace commerge {
namespace {

// The alpha and beta endpoints of `loops`, as 32-bit keyframe indices; false when one is beyond 2^32 - 1.
bool SplitEndpoints(Span<const SequentialLoopCell> loops, std::vector<std::uint32_t>* alpha,
                    std::vector<std::uint32_t>* beta) {
  constexpr std::size_t kMaxIndex = std::numeric_limits<std::uint32_t>::max();
  alpha->reserve(loops.size());
  beta->reserve(loops.size());
  for (const SequentialLoopCell& l : loops) {
    if (l.alpha_index > kMaxIndex || l.beta_index > kMaxIndex) return false;
    alpha->push_back(static_cast<std::uint32_t>(l.alpha_index));
    beta->push_back(static_cast<std::uint32_t>(l.beta_index));
  }
  return true;
}

Status FillRequest(std::vector<std::uint32_t> keyframes, std::vector<std::uint32_t> pool,
                   Span<const std::uint32_t> points, const ExchangePolicyParams& params, const char* robot,
                   RobotScanRequest* out) {
  const std::uint32_t assumed_points = params.assumed_points_per_scan;
  std::sort(keyframes.begin(), keyframes.end());
  keyframes.erase(std::unique(keyframes.begin(), keyframes.end()), keyframes.end());
  out->padded_scans = PadKeyframesFromPool(&keyframes, std::move(pool), PolicyPadTarget(params, points));
  out->predicted_bytes = 0;
  out->estimated_scans = 0;
  for (std::uint32_t k : keyframes) {
    std::uint32_t n = 0;
    if (!points.empty()) {
      if (k >= points.size()) {
        return InvalidArgument(std::string("exchange policy: robot ") + robot + " keyframe " + std::to_string(k) +
                               " has no reported point count (" + std::to_string(points.size()) + " reported)");
      }
      n = points[k];
    }
    if (n == 0) {
      n = assumed_points;
      ++out->estimated_scans;
    }
    out->predicted_bytes += EncodedScanBytes(n);
  }
  out->keyframes = std::move(keyframes);
  return Status::Ok();
}

}  // namespace

std::size_t PadKeyframesFromPool(std::vector<std::uint32_t>* keyframes, std::vector<std::uint32_t> pool,
                                 const PadTarget& target) {
  const auto points_of = [&target](std::uint32_t k) -> std::uint64_t {
    const std::uint32_t n = k < target.points.size() ? target.points[k] : 0;
    return n > 0 ? n : target.assumed_points;
  };
  std::uint64_t held = 0;
  for (std::uint32_t k : *keyframes) held += points_of(k);
  const auto met = [&](std::size_t scans) { return scans >= target.min_scans && held >= target.min_points; };
  if (keyframes->empty() || met(keyframes->size())) return 0;
  std::sort(pool.begin(), pool.end());
  pool.erase(std::unique(pool.begin(), pool.end()), pool.end());
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ranked;  // (index distance to the selection, keyframe)
  ranked.reserve(pool.size());
  for (std::uint32_t k : pool) {
    const auto after = std::lower_bound(keyframes->begin(), keyframes->end(), k);
    if (after != keyframes->end() && *after == k) continue;  // already selected
    std::uint32_t d = std::numeric_limits<std::uint32_t>::max();
    if (after != keyframes->end()) d = *after - k;
    if (after != keyframes->begin()) d = std::min(d, k - *(after - 1));
    ranked.emplace_back(d, k);
  }
  std::sort(ranked.begin(), ranked.end());
  const std::size_t before = keyframes->size();
  for (const auto& [distance, k] : ranked) {
    if (met(keyframes->size())) break;
    keyframes->push_back(k);
    held += points_of(k);
  }
  std::sort(keyframes->begin(), keyframes->end());
  return keyframes->size() - before;
}

PadTarget PolicyPadTarget(const ExchangePolicyParams& params, Span<const std::uint32_t> points) {
  return PadTarget{params.min_scans_per_robot, params.min_points_per_robot, points, params.assumed_points_per_scan};
}

Status ValidateExchangePolicyParams(const ExchangePolicyParams& params) {
  if (params.assumed_points_per_scan == 0) {
    return InvalidArgument("exchange policy: assumed_points_per_scan must be > 0");
  }
  if (params.min_scans_per_robot > kMaxMinScansPerRobot) {
    return InvalidArgument("exchange policy: min_scans_per_robot = " + std::to_string(params.min_scans_per_robot) +
                           " is above " + std::to_string(kMaxMinScansPerRobot));
  }
  if (params.min_points_per_robot > kMaxMinPointsPerRobot) {
    return InvalidArgument("exchange policy: min_points_per_robot = " + std::to_string(params.min_points_per_robot) +
                           " is above " + std::to_string(kMaxMinPointsPerRobot));
  }
  return Status::Ok();
}

Result<ExchangePolicy> MakeExchangePolicy(Span<const SequentialLoopCell> selected_loops,
                                          Span<const SequentialLoopCell> overlap_loops,
                                          Span<const std::uint32_t> alpha_points,
                                          Span<const std::uint32_t> beta_points, const ExchangePolicyParams& params) {
  if (Status s = ValidateExchangePolicyParams(params); !s.ok()) return s;
  std::vector<std::uint32_t> alpha, beta, alpha_pool, beta_pool;
  const bool pads = params.min_scans_per_robot > 0 || params.min_points_per_robot > 0;
  if (!SplitEndpoints(selected_loops, &alpha, &beta) ||
      (pads && !SplitEndpoints(overlap_loops, &alpha_pool, &beta_pool))) {
    return InvalidArgument("exchange policy: keyframe index beyond 2^32 - 1");
  }
  ExchangePolicy policy;
  policy.loops = selected_loops.size();
  if (Status s = FillRequest(std::move(alpha), std::move(alpha_pool), alpha_points, params, "alpha", &policy.alpha);
      !s.ok()) {
    return s;
  }
  if (Status s = FillRequest(std::move(beta), std::move(beta_pool), beta_points, params, "beta", &policy.beta);
      !s.ok()) {
    return s;
  }
  return policy;
}

}  // namespace commerge
