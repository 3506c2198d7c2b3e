// SPDX-License-Identifier: BSD-3-Clause
// Exchange policy: the unique endpoint keyframes of L_K per robot (paper eqs. exchange_policy_alpha/_beta) and the
// predicted bytes recomputed from the scan codec's size rule (12 + 6 n per scan).
#include <doctest/doctest.h>

#include <algorithm>
#include <cstdint>
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
    params.min_scans_per_robot = 0;  // the paper's policy (the padding has its own test below)
    auto policy = MakeExchangePolicy(loops, {}, points_a, points_b, params);
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
    CHECK(policy->alpha.padded_scans == 0);  // min_scans_per_robot = 0: exactly the paper's endpoints
    CHECK(policy->beta.padded_scans == 0);
    CHECK(policy->scans() == ref_a.size() + ref_b.size());
    CHECK(policy->predicted_bytes() == policy->alpha.predicted_bytes + policy->beta.predicted_bytes);
  }
}

TEST_CASE("Exchange policy: a reported point list that misses a requested keyframe is an error") {
  const std::vector<SequentialLoopCell> loops = {{7, 2, 0.01f}};
  const std::vector<std::uint32_t> short_list(5, 100);
  ExchangePolicyParams exact;
  exact.min_scans_per_robot = 0;
  auto policy = MakeExchangePolicy(loops, {}, short_list, {}, exact);
  REQUIRE_FALSE(policy.ok());
  CHECK(policy.status().message().find("keyframe 7") != std::string::npos);

  // An overlap loop beyond 32-bit keyframe indices, and an out-of-range parameter, are named errors.
  const std::vector<SequentialLoopCell> huge = {{std::size_t{1} << 33, 2, 0.01f}};
  auto beyond = MakeExchangePolicy(loops, huge, {}, {}, ExchangePolicyParams{});
  REQUIRE_FALSE(beyond.ok());
  CHECK(beyond.status().message().find("beyond 2^32 - 1") != std::string::npos);
  ExchangePolicyParams too_many;
  too_many.min_scans_per_robot = kMaxMinScansPerRobot + 1;
  auto refused = MakeExchangePolicy(loops, {}, {}, {}, too_many);
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().message().find("min_scans_per_robot") != std::string::npos);
}

// Index distance from k to the nearest keyframe of `selected`.
std::size_t DistanceToSet(std::uint32_t k, const std::set<std::uint32_t>& selected) {
  std::size_t best = SIZE_MAX;
  for (std::uint32_t s : selected) best = std::min<std::size_t>(best, k > s ? k - s : s - k);
  return best;
}

TEST_CASE("Exchange policy: min_scans_per_robot pads each robot with the nearest keyframes of the overlap loops") {
  std::mt19937 rng(3);
  for (int trial = 0; trial < 300; ++trial) {
    const std::size_t n_a = 1 + rng() % 60, n_b = 1 + rng() % 40;
    std::uniform_int_distribution<std::size_t> ia(0, n_a - 1), ib(0, n_b - 1);
    std::vector<SequentialLoopCell> loops, overlap;
    std::set<std::uint32_t> ends_a, ends_b, pool_a, pool_b;
    const int count = 1 + trial % 6;
    for (int k = 0; k < count; ++k) {
      loops.push_back({ia(rng), ib(rng), 0.05f});
      ends_a.insert(static_cast<std::uint32_t>(loops.back().alpha_index));
      ends_b.insert(static_cast<std::uint32_t>(loops.back().beta_index));
    }
    const int overlap_count = static_cast<int>(rng() % 30);
    for (int k = 0; k < overlap_count; ++k) {
      overlap.push_back({ia(rng), ib(rng), 0.08f});
      pool_a.insert(static_cast<std::uint32_t>(overlap.back().alpha_index));
      pool_b.insert(static_cast<std::uint32_t>(overlap.back().beta_index));
    }
    if (trial % 3 == 0) overlap.insert(overlap.end(), loops.begin(), loops.end());  // L_K is part of L_seq
    ExchangePolicyParams params;
    params.min_scans_per_robot = static_cast<std::uint32_t>(rng() % 50);
    std::vector<std::uint32_t> points_a(n_a, 300);
    auto policy = MakeExchangePolicy(loops, overlap, points_a, {}, params);
    REQUIRE(policy.ok());
    const auto check = [&](const RobotScanRequest& r, const std::set<std::uint32_t>& ends,
                           const std::set<std::uint32_t>& pool) {
      std::set<std::uint32_t> allowed = ends;
      allowed.insert(pool.begin(), pool.end());
      const std::size_t want = ends.size() >= params.min_scans_per_robot
                                   ? ends.size()
                                   : std::min<std::size_t>(params.min_scans_per_robot, allowed.size());
      REQUIRE(r.keyframes.size() == want);
      CHECK(r.padded_scans == want - ends.size());
      CHECK(std::is_sorted(r.keyframes.begin(), r.keyframes.end()));
      const std::set<std::uint32_t> got(r.keyframes.begin(), r.keyframes.end());
      CHECK(got.size() == r.keyframes.size());
      for (std::uint32_t e : ends) CHECK(got.count(e) == 1);
      for (std::uint32_t k : got) CHECK(allowed.count(k) == 1);  // only scans of the overlap loops
      // Nearest first: no pool keyframe left out is closer to L_K's keyframes than one that was added.
      std::size_t farthest_added = 0, nearest_left = SIZE_MAX;
      for (std::uint32_t k : pool) {
        if (ends.count(k)) continue;
        const std::size_t d = DistanceToSet(k, ends);
        if (got.count(k)) farthest_added = std::max(farthest_added, d);
        else nearest_left = std::min(nearest_left, d);
      }
      CHECK(farthest_added <= nearest_left);
    };
    check(policy->alpha, ends_a, pool_a);
    check(policy->beta, ends_b, pool_b);
    CHECK(policy->alpha.predicted_bytes == policy->alpha.keyframes.size() * (12 + 6 * 300ull));
    CHECK(policy->loops == loops.size());
  }
}

}  // namespace
}  // namespace commerge
