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
    params.min_scans_per_robot = 0;  // the paper's policy (the padding has its own tests below)
    params.min_points_per_robot = 0;
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
    CHECK(policy->alpha.padded_scans == 0);  // both rules 0: exactly the paper's endpoints
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
  exact.min_points_per_robot = 0;
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
    params.min_points_per_robot = 0;
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

TEST_CASE("Exchange policy: min_points_per_robot pads until the scans hold that many reported points") {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 300; ++trial) {
    const std::size_t n_a = 1 + rng() % 60;
    std::uniform_int_distribution<std::size_t> ia(0, n_a - 1);
    std::vector<SequentialLoopCell> loops, overlap;
    std::set<std::uint32_t> ends, pool;
    for (int k = 0; k < 1 + trial % 4; ++k) {
      loops.push_back({ia(rng), 0, 0.05f});
      ends.insert(static_cast<std::uint32_t>(loops.back().alpha_index));
    }
    for (int k = 0; k < static_cast<int>(rng() % 30); ++k) {
      overlap.push_back({ia(rng), 0, 0.08f});
      pool.insert(static_cast<std::uint32_t>(overlap.back().alpha_index));
    }
    // Reported counts, some unknown (0 -> assumed), and on odd trials a list shorter than the pool's indices.
    std::vector<std::uint32_t> points(trial % 2 ? n_a : n_a / 2 + 1);
    for (std::uint32_t& n : points) n = rng() % 4 == 0 ? 0 : static_cast<std::uint32_t>(50 + rng() % 2000);
    const std::size_t max_end = *ends.rbegin();
    if (points.size() <= max_end) points.resize(max_end + 1, 700);  // every requested L_K keyframe is reported
    ExchangePolicyParams params;
    params.assumed_points_per_scan = 900;
    params.min_scans_per_robot = static_cast<std::uint32_t>(trial % 5 == 0 ? rng() % 8 : 0);
    params.min_points_per_robot = static_cast<std::uint32_t>(rng() % 12000);
    // The pool keyframes the policy may add must be reported too (a requested keyframe without a count is an
    // error, tested above), so the reference extends the list the same way.
    const std::uint32_t max_pool = pool.empty() ? 0 : *pool.rbegin();
    if (points.size() <= max_pool) points.resize(max_pool + 1, 0);
    auto policy = MakeExchangePolicy(loops, overlap, points, {}, params);
    REQUIRE(policy.ok());
    const auto count_of = [&](std::uint32_t k) -> std::uint64_t {
      return points[k] ? points[k] : params.assumed_points_per_scan;
    };
    // Reference: the pool outside L_K in (distance to L_K, index) order; take the shortest prefix after which
    // both rules hold, or all of it.
    std::vector<std::pair<std::size_t, std::uint32_t>> order;
    for (std::uint32_t k : pool) {
      if (!ends.count(k)) order.emplace_back(DistanceToSet(k, ends), k);
    }
    std::sort(order.begin(), order.end());
    std::set<std::uint32_t> want = ends;
    std::uint64_t held = 0;
    for (std::uint32_t k : ends) held += count_of(k);
    for (const auto& [d, k] : order) {
      if (want.size() >= params.min_scans_per_robot && held >= params.min_points_per_robot) break;
      want.insert(k);
      held += count_of(k);
    }
    CHECK(policy->alpha.keyframes == std::vector<std::uint32_t>(want.begin(), want.end()));
    CHECK(policy->alpha.padded_scans == want.size() - ends.size());
    std::uint64_t got_points = 0;
    for (std::uint32_t k : policy->alpha.keyframes) got_points += count_of(k);
    // Either the rule holds, or the whole pool was taken.
    CHECK((got_points >= params.min_points_per_robot || want.size() == ends.size() + order.size()));
  }
  ExchangePolicyParams too_many;
  too_many.min_points_per_robot = kMaxMinPointsPerRobot + 1;
  auto refused = MakeExchangePolicy(std::vector<SequentialLoopCell>{{1, 1, 0.01f}}, {}, {}, {}, too_many);
  REQUIRE_FALSE(refused.ok());
  CHECK(refused.status().message().find("min_points_per_robot") != std::string::npos);
}

}  // namespace
}  // namespace commerge
