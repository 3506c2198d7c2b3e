// SPDX-License-Identifier: BSD-3-Clause
// All-points capped radius neighbours (core/cloud/radius_neighbors) against a brute-force reference: every
// pair's squared distance computed the same way in float, sorted by (distance, index), cut at the cap. The library
// may fuse a * b + c into one multiply-add (GCC does on aarch64 at -O2) where the test code, built at another
// optimisation level, does not: distances then agree to a few ulp, and neighbours that close may swap places.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>
#include <vector>

#include "core/cloud/radius_neighbors.hpp"

namespace commerge {
namespace {

void CheckAgainstBruteForce(const std::vector<PointXYZI>& pts, float radius_m, std::size_t cap) {
  RadiusNeighbors nb;
  nb.Compute(pts, radius_m, cap);
  REQUIRE(nb.size() == pts.size());
  std::size_t total = 0, capped = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    std::vector<std::pair<float, std::uint32_t>> ref;
    for (std::size_t j = 0; j < pts.size(); ++j) {
      const float ex = pts[j].x - pts[i].x, ey = pts[j].y - pts[i].y, ez = pts[j].z - pts[i].z;
      const float d2 = ex * ex + ey * ey + ez * ez;
      if (d2 <= radius_m * radius_m) ref.emplace_back(d2, static_cast<std::uint32_t>(j));
    }
    std::sort(ref.begin(), ref.end());
    if (ref.size() > cap) {
      ref.resize(cap);
      ++capped;
    }
    const Span<const std::uint32_t> got = nb.indices(i);
    const Span<const float> got_d2 = nb.distances_sq(i);
    REQUIRE(got.size() == ref.size());
    const auto same_distance = [](float a, float b) {
      return std::fabs(a - b) <= 1e-6f * (1.0f + std::max(std::fabs(a), std::fabs(b)));
    };
    for (std::size_t k = 0; k < ref.size(); ++k) {
      CAPTURE(k);
      REQUIRE(same_distance(got_d2[k], ref[k].first));
      const bool swapped_tie =
          (k > 0 && got[k] == ref[k - 1].second && same_distance(ref[k - 1].first, ref[k].first)) ||
          (k + 1 < ref.size() && got[k] == ref[k + 1].second && same_distance(ref[k + 1].first, ref[k].first));
      REQUIRE((got[k] == ref[k].second || swapped_tie));
    }
    total += ref.size();
  }
  CHECK(nb.total() == total);
  CHECK(nb.num_capped() == capped);
}

}  // namespace

TEST_CASE("Radius neighbours equal brute force: random clouds, radii, caps, negative coordinates") {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 30; ++trial) {
    const int n = 1 + static_cast<int>(rng() % 400);
    const float extent = 0.5f + static_cast<float>(rng() % 200) / 10.0f;
    std::uniform_real_distribution<float> u(-extent, extent);
    std::vector<PointXYZI> pts(static_cast<std::size_t>(n));
    for (PointXYZI& p : pts) p = PointXYZI{u(rng) - 500.0f, u(rng), u(rng), 0.0f};
    const float radius = 0.2f + static_cast<float>(rng() % 50) / 10.0f;
    const std::size_t cap = 1 + rng() % 64;
    CAPTURE(trial);
    CheckAgainstBruteForce(pts, radius, cap);
  }
}

TEST_CASE("Radius neighbours: duplicates and lattice ties keep the lower index, cell borders are exact") {
  std::vector<PointXYZI> pts;
  // An integer lattice: many equal distances, points exactly on cell borders (radius 2 -> cells of 1 m), and
  // every point twice (distance 0 ties).
  for (int x = -3; x <= 3; ++x) {
    for (int y = -3; y <= 3; ++y) {
      for (int z = 0; z <= 1; ++z) {
        const PointXYZI p{static_cast<float>(x), static_cast<float>(y), static_cast<float>(z), 0.0f};
        pts.push_back(p);
        pts.push_back(p);
      }
    }
  }
  CheckAgainstBruteForce(pts, 2.0f, 10);
  CheckAgainstBruteForce(pts, 1.0f, 200);
}

TEST_CASE("Radius neighbours: dense clouds where the cap is reached well inside the radius") {
  // 800 points in a 3 m cube, radius 1.5 m: an interior ball holds about 420 points, (0.7 r)^3 of that about
  // 145 and (0.85 r)^3 about 260. Caps below, between and above those counts make the selection work from the
  // inner ball, the middle ball and the whole ball; every list must still be the exact closest ones.
  std::mt19937 rng(17);
  std::uniform_real_distribution<float> u(0.0f, 3.0f);
  std::vector<PointXYZI> pts(800);
  for (PointXYZI& p : pts) p = PointXYZI{u(rng), u(rng), u(rng), 0.0f};
  for (std::size_t cap : {40u, 120u, 200u, 330u, 600u}) {
    CAPTURE(cap);
    CheckAgainstBruteForce(pts, 1.5f, cap);
  }
}

TEST_CASE("Radius neighbours: huge coordinates share border cells but stay exact, empty and single clouds") {
  std::vector<PointXYZI> pts = {{1e12f, 0.0f, 0.0f, 0.0f}, {1e12f, 0.5f, 0.0f, 0.0f}, {-1e12f, 0.0f, 0.0f, 0.0f},
                                {0.0f, 0.0f, 0.0f, 0.0f},  {0.0f, 0.0f, 0.7f, 0.0f},  {3e7f, 3e7f, -3e7f, 0.0f}};
  CheckAgainstBruteForce(pts, 1.0f, 4);
  CheckAgainstBruteForce({}, 1.0f, 4);
  CheckAgainstBruteForce({{1.0f, 2.0f, 3.0f, 0.0f}}, 1.0f, 1);
}

}  // namespace commerge
