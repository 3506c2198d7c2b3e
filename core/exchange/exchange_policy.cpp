// SPDX-License-Identifier: BSD-3-Clause
#include "core/exchange/exchange_policy.hpp"

#include <algorithm>
#include <limits>
#include <string>

#include "core/cloud/scan_codec.hpp"

namespace commerge {
namespace {

Status FillRequest(std::vector<std::uint32_t> keyframes, Span<const std::uint32_t> points,
                   std::uint32_t assumed_points, const char* robot, RobotScanRequest* out) {
  std::sort(keyframes.begin(), keyframes.end());
  keyframes.erase(std::unique(keyframes.begin(), keyframes.end()), keyframes.end());
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

Result<ExchangePolicy> MakeExchangePolicy(Span<const SequentialLoopCell> selected_loops,
                                          Span<const std::uint32_t> alpha_points,
                                          Span<const std::uint32_t> beta_points, const ExchangePolicyParams& params) {
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
  if (Status s = FillRequest(std::move(alpha), alpha_points, params.assumed_points_per_scan, "alpha", &policy.alpha);
      !s.ok()) {
    return s;
  }
  if (Status s = FillRequest(std::move(beta), beta_points, params.assumed_points_per_scan, "beta", &policy.beta);
      !s.ok()) {
    return s;
  }
  return policy;
}

}  // namespace commerge
