// SPDX-License-Identifier: BSD-3-Clause
// Exchange policy: the unique endpoint keyframes of L_K per robot (paper eqs. exchange_policy_alpha/_beta) and the
// predicted bytes recomputed from the scan codec's size rule (12 + 6 n per scan).
#include <doctest/doctest.h>

#include <random>
#include <set>
#include <vector>

#include "core/exchange/exchange_policy.hpp"

namespace commerge {
namespace {

TEST_CASE("Exchange policy: unique endpoints per robot and predicted bytes") {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 200; ++trial) {
    std::uniform_int_distribution<std::size_t> ia(0, 49), ib(0, 29);
    std::vector<SequentialLoopCell> loops;
    std::set<std::uint32_t> ref_a, ref_b;
    const int count = trial % 25;
    for (int k = 0; k < count; ++k) {
      loops.push_back({ia(rng), ib(rng), 0.05f});
      ref_a.insert(static_cast<std::uint32_t>(loops.back().alpha_index));
      ref_b.insert(static_cast<std::uint32_t>(loops.back().beta_index));
    }
    std::vector<std::uint32_t> points_a(50), points_b;
    std::uniform_int_distribution<std::uint32_t> np(0, 6000);
    for (auto& p : points_a) p = np(rng);  // some 0 = unknown
    ExchangePolicyParams params;
    params.assumed_points_per_scan = 1000 + static_cast<std::uint32_t>(trial);
    auto policy = MakeExchangePolicy(loops, points_a, points_b, params);
    REQUIRE(policy.ok());
    CHECK(policy->loops == loops.size());
    CHECK(policy->alpha.keyframes == std::vector<std::uint32_t>(ref_a.begin(), ref_a.end()));
    CHECK(policy->beta.keyframes == std::vector<std::uint32_t>(ref_b.begin(), ref_b.end()));
    std::uint64_t bytes_a = 0;
    std::size_t estimated_a = 0;
    for (std::uint32_t k : ref_a) {
      const std::uint64_t n = points_a[k] ? points_a[k] : params.assumed_points_per_scan;
      estimated_a += points_a[k] == 0;
      bytes_a += 12 + 6 * n;
    }
    CHECK(policy->alpha.predicted_bytes == bytes_a);
    CHECK(policy->alpha.estimated_scans == estimated_a);
    CHECK(policy->beta.predicted_bytes == ref_b.size() * (12 + 6 * std::uint64_t{params.assumed_points_per_scan}));
    CHECK(policy->beta.estimated_scans == ref_b.size());
    CHECK(policy->scans() == ref_a.size() + ref_b.size());
    CHECK(policy->predicted_bytes() == policy->alpha.predicted_bytes + policy->beta.predicted_bytes);
  }
}

TEST_CASE("Exchange policy: a reported point list that misses a requested keyframe is an error") {
  const std::vector<SequentialLoopCell> loops = {{7, 2, 0.01f}};
  const std::vector<std::uint32_t> short_list(5, 100);
  auto policy = MakeExchangePolicy(loops, short_list, {}, ExchangePolicyParams{});
  REQUIRE_FALSE(policy.ok());
  CHECK(policy.status().message().find("keyframe 7") != std::string::npos);
}

}  // namespace
}  // namespace commerge
