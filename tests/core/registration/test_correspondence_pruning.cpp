// SPDX-License-Identifier: BSD-3-Clause
// Compatibility graph and maximum k-core / clique pruning (core/registration/correspondence_pruning):
// core numbers against a brute-force peeling oracle, the graph against a direct double-precision check, and
// outlier rejection against ground-truth inlier labels.
#include <doctest/doctest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "core/registration/correspondence_pruning.hpp"

namespace commerge {
namespace {

// Oracle: the k-core is what survives repeatedly deleting vertices of degree < k; core(v) = largest such k.
std::vector<int> CoreNumbersByPeeling(int n, const std::vector<std::vector<bool>>& adj) {
  std::vector<int> core(static_cast<std::size_t>(n), 0);
  for (int k = 1; k <= n; ++k) {
    std::vector<bool> alive(static_cast<std::size_t>(n), true);
    bool changed = true;
    while (changed) {
      changed = false;
      for (int v = 0; v < n; ++v) {
        if (!alive[static_cast<std::size_t>(v)]) continue;
        int deg = 0;
        for (int u = 0; u < n; ++u) deg += alive[static_cast<std::size_t>(u)] && adj[static_cast<std::size_t>(v)][static_cast<std::size_t>(u)];
        if (deg < k) alive[static_cast<std::size_t>(v)] = false, changed = true;
      }
    }
    for (int v = 0; v < n; ++v) {
      if (alive[static_cast<std::size_t>(v)]) core[static_cast<std::size_t>(v)] = k;
    }
  }
  return core;
}

struct Synthetic {
  std::vector<Eigen::Vector3f> a, b;
  std::vector<bool> inlier;
};

// `inliers` correspondences b = T a + noise (|noise| <= 0.2 m per axis), then `outliers` random pairs.
Synthetic MakeCorrespondences(std::uint32_t seed, int inliers, int outliers) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-40.0f, 40.0f), noise(-0.2f, 0.2f);
  Eigen::Isometry3f T = Eigen::Isometry3f::Identity();
  T.linear() = Eigen::AngleAxisf(1.3f, Eigen::Vector3f(0.2f, 0.1f, 1.0f).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3f(12.0f, -8.0f, 1.0f);
  Synthetic s;
  for (int i = 0; i < inliers + outliers; ++i) {
    const Eigen::Vector3f a(pos(rng), pos(rng), 0.2f * pos(rng));
    const bool in = i < inliers;
    s.a.push_back(a);
    s.b.push_back(in ? Eigen::Vector3f(T * a + Eigen::Vector3f(noise(rng), noise(rng), noise(rng)))
                     : Eigen::Vector3f(pos(rng), pos(rng), 0.2f * pos(rng)));
    s.inlier.push_back(in);
  }
  // Interleave deterministically so that inliers are not a prefix.
  std::vector<std::size_t> order(s.a.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), rng);
  Synthetic out;
  for (std::size_t i : order) out.a.push_back(s.a[i]), out.b.push_back(s.b[i]), out.inlier.push_back(s.inlier[i]);
  return out;
}

}  // namespace

TEST_CASE("Core numbers equal a brute-force peeling oracle on random graphs") {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 300; ++trial) {
    const int n = 1 + trial % 40;
    const double density = 0.05 + 0.9 * unit(rng);
    auto g = CliqueGraph::Create(n, false);
    REQUIRE(g.ok());
    std::vector<std::vector<bool>> adj(static_cast<std::size_t>(n), std::vector<bool>(static_cast<std::size_t>(n), false));
    for (int u = 0; u < n; ++u) {
      for (int v = u + 1; v < n; ++v) {
        if (unit(rng) < density) {
          REQUIRE(g->AddEdge(u, v).ok());
          adj[static_cast<std::size_t>(u)][static_cast<std::size_t>(v)] = adj[static_cast<std::size_t>(v)][static_cast<std::size_t>(u)] = true;
        }
      }
    }
    REQUIRE(CoreNumbers(*g) == CoreNumbersByPeeling(n, adj));
  }
  // A graph wider than one 64-bit word: a 70-clique plus a pendant path.
  auto g = CliqueGraph::Create(75, false);
  REQUIRE(g.ok());
  for (int u = 0; u < 70; ++u)
    for (int v = u + 1; v < 70; ++v) REQUIRE(g->AddEdge(u, v).ok());
  for (int v = 70; v < 75; ++v) REQUIRE(g->AddEdge(v - 1, v).ok());
  const std::vector<int> core = CoreNumbers(*g);
  for (int v = 0; v < 70; ++v) CHECK(core[static_cast<std::size_t>(v)] == 69);
  for (int v = 70; v < 75; ++v) CHECK(core[static_cast<std::size_t>(v)] == 1);
}

TEST_CASE("Compatibility graph equals a direct double-precision length check") {
  const Synthetic s = MakeCorrespondences(5, 30, 90);
  const double eps = 1.0;
  auto g = BuildCompatibilityGraph(s.a, s.b, eps);
  REQUIRE(g.ok());
  std::size_t edges = 0, checked = 0;
  for (std::size_t k = 0; k < s.a.size(); ++k) {
    for (std::size_t l = k + 1; l < s.a.size(); ++l) {
      const double da = (s.a[k].cast<double>() - s.a[l].cast<double>()).norm();
      const double db = (s.b[k].cast<double>() - s.b[l].cast<double>()).norm();
      const double diff = std::fabs(db - da);
      if (std::fabs(diff - eps) < 1e-4) continue;  // float rounding may decide these
      ++checked;
      const bool expected = diff <= eps;
      edges += expected;
      CHECK(g->HasEdge(static_cast<int>(k), static_cast<int>(l)) == expected);
    }
  }
  CHECK(checked > 7000);
  CHECK(edges > 400);  // the 30 inliers alone form a 435-edge clique
  CHECK(BuildCompatibilityGraph(Span<const Eigen::Vector3f>(s.a.data(), 3), Span<const Eigen::Vector3f>(s.b.data(), 2), 1.0)
            .status()
            .code() == StatusCode::kInvalidArgument);
}

TEST_CASE("Max k-core and max clique keep the inliers among 80 percent outliers") {
  for (PruningMethod method : {PruningMethod::kMaxCore, PruningMethod::kMaxClique}) {
    CAPTURE(static_cast<int>(method));
    const Synthetic s = MakeCorrespondences(9, 60, 240);
    PruningParams p;
    p.noise_bound_m = 1.0;
    p.method = method;
    std::vector<std::uint32_t> kept;
    auto stats = PruneCorrespondences(s.a, s.b, p, &kept);
    REQUIRE(stats.ok());
    std::size_t true_kept = 0;
    for (std::uint32_t k : kept) true_kept += s.inlier[k];
    CHECK(true_kept >= 58);                   // nearly every inlier survives
    CHECK(kept.size() - true_kept <= 6);      // and almost no outlier
    CHECK(std::is_sorted(kept.begin(), kept.end()));  // input order kept
    if (method == PruningMethod::kMaxClique) CHECK(stats->clique_optimal);
    // Deterministic.
    std::vector<std::uint32_t> again;
    REQUIRE(PruneCorrespondences(s.a, s.b, p, &again).ok());
    CHECK(again == kept);
  }
  std::vector<std::uint32_t> kept;
  PruningParams bad;
  bad.noise_bound_m = 0.0;
  CHECK(PruneCorrespondences({}, {}, bad, &kept).status().code() == StatusCode::kInvalidArgument);
  REQUIRE(PruneCorrespondences({}, {}, PruningParams{}, &kept).ok());
  CHECK(kept.empty());
}

}  // namespace commerge
