// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/exchange_policy.hpp"

#include <algorithm>
#include <limits>
#include <string>

#include "core/cloud/scan_codec.hpp"

namespace commerge {
namespace {

// Adds trajectory neighbours of the (sorted, unique) selected keyframes until there are min(min_scans,
// num_keyframes) of them: index distance 1 around every selected keyframe in order, then 2, ... Returns how many.
std::size_t PadWithNeighbours(std::vector<std::uint32_t>* keyframes, std::size_t num_keyframes,
                              std::uint32_t min_scans) {
  const std::size_t target = std::min<std::size_t>(min_scans, num_keyframes);
  if (keyframes->empty() || keyframes->size() >= target) return 0;
  const std::vector<std::uint32_t> selected = *keyframes;
  std::vector<bool> taken(num_keyframes, false);
  for (std::uint32_t k : selected) taken[k] = true;
  std::size_t added = 0;
  for (std::size_t d = 1; d < num_keyframes && keyframes->size() < target; ++d) {
    for (std::uint32_t k : selected) {
      for (int side = -1; side <= 1 && keyframes->size() < target; side += 2) {
        if (side < 0 ? k < d : k + d >= num_keyframes) continue;
        const std::size_t n = side < 0 ? k - d : k + d;
        if (taken[n]) continue;
        taken[n] = true;
        keyframes->push_back(static_cast<std::uint32_t>(n));
        ++added;
      }
      if (keyframes->size() >= target) break;
    }
  }
  std::sort(keyframes->begin(), keyframes->end());
  return added;
}

Status FillRequest(std::vector<std::uint32_t> keyframes, Span<const std::uint32_t> points,
                   std::size_t num_keyframes, const ExchangePolicyParams& params, const char* robot,
                   RobotScanRequest* out) {
  const std::uint32_t assumed_points = params.assumed_points_per_scan;
  std::sort(keyframes.begin(), keyframes.end());
  keyframes.erase(std::unique(keyframes.begin(), keyframes.end()), keyframes.end());
  if (!keyframes.empty() && keyframes.back() >= num_keyframes) {
    return InvalidArgument(std::string("exchange policy: robot ") + robot + " keyframe " +
                           std::to_string(keyframes.back()) + " is not below its keyframe count " +
                           std::to_string(num_keyframes));
  }
  out->padded_scans = PadWithNeighbours(&keyframes, num_keyframes, params.min_scans_per_robot);
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

Status ValidateExchangePolicyParams(const ExchangePolicyParams& params) {
  if (params.assumed_points_per_scan == 0) {
    return InvalidArgument("exchange policy: assumed_points_per_scan must be > 0");
  }
  if (params.min_scans_per_robot > kMaxMinScansPerRobot) {
    return InvalidArgument("exchange policy: min_scans_per_robot = " + std::to_string(params.min_scans_per_robot) +
                           " is above " + std::to_string(kMaxMinScansPerRobot));
  }
  return Status::Ok();
}

Result<ExchangePolicy> MakeExchangePolicy(Span<const SequentialLoopCell> selected_loops,
                                          Span<const std::uint32_t> alpha_points,
                                          Span<const std::uint32_t> beta_points, std::size_t alpha_keyframes,
                                          std::size_t beta_keyframes, const ExchangePolicyParams& params) {
  if (Status s = ValidateExchangePolicyParams(params); !s.ok()) return s;
  std::vector<std::uint32_t> alpha, beta;
  alpha.reserve(selected_loops.size());
  beta.reserve(selected_loops.size());
  constexpr std::size_t kMaxIndex = std::numeric_limits<std::uint32_t>::max();
  for (const SequentialLoopCell& l : selected_loops) {
    if (l.alpha_index > kMaxIndex || l.beta_index > kMaxIndex) {
      return InvalidArgument("exchange policy: keyframe index beyond 2^32 - 1");
    }
    alpha.push_back(static_cast<std::uint32_t>(l.alpha_index));
    beta.push_back(static_cast<std::uint32_t>(l.beta_index));
  }
  ExchangePolicy policy;
  policy.loops = selected_loops.size();
  if (Status s = FillRequest(std::move(alpha), alpha_points, alpha_keyframes, params, "alpha", &policy.alpha);
      !s.ok()) {
    return s;
  }
  if (Status s = FillRequest(std::move(beta), beta_points, beta_keyframes, params, "beta", &policy.beta);
      !s.ok()) {
    return s;
  }
  return policy;
}

}  // namespace commerge
