// SPDX-License-Identifier: BSD-3-Clause
// Stage A (streaming sequential matching) against a naive reference: full matrix, BFS 8-connected
// labelling, span / mean / tau_area selection. Random matrices with planted bands under many tile sizes,
// structured descriptor cases (diagonal, anti-diagonal, two bands, band across tile borders) and the
// no-candidate reasons.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "core/common/float_limits.hpp"
#include "core/exchange/affinity.hpp"
#include "core/exchange/neighbour_rank.hpp"
#include "core/exchange/sequence_smoothing.hpp"
#include "core/exchange/sequential_matching.hpp"

namespace commerge {
namespace {


// A stored matrix served as tiles (deterministic by construction).
class MatrixTileSource final : public AffinityTileSource {
 public:
  MatrixTileSource(std::vector<float> a, std::size_t n, std::size_t m) : a_(std::move(a)), n_(n), m_(m) {}
  std::size_t num_rows() const noexcept override { return n_; }
  std::size_t num_cols() const noexcept override { return m_; }
  Status ComputeTile(std::size_t r0, std::size_t c0, std::size_t rows, std::size_t cols, AffinityTile* t) override {
    if (rows == 0 || cols == 0 || r0 + rows > n_ || c0 + cols > m_) return InvalidArgument("tile outside");
    *t = AffinityTile{r0, c0, rows, cols, m_, a_.data() + r0 * m_ + c0};
    return Status::Ok();
  }
  const std::vector<float>& matrix() const { return a_; }

 private:
  std::vector<float> a_;
  std::size_t n_, m_;
};

struct RefResult {
  bool found = false;
  SequentialCluster best;
  std::vector<std::pair<std::size_t, std::size_t>> cells;
  std::size_t num_clusters = 0;
  std::uint64_t num_below = 0, largest_area = 0, second_area = 0;
  /// Every cluster in the order of its first cell (row-major), its cells row-major.
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> clusters;
};

// Naive stage A: threshold, BFS labelling over the whole matrix, scoring (same tie-break as documented).
template <class T>
RefResult NaiveStageA(const std::vector<T>& a, std::size_t n, std::size_t m, double tau, std::uint64_t tau_area) {
  RefResult out;
  const auto tau_f = static_cast<float>(tau);
  std::vector<char> b(n * m);
  for (std::size_t k = 0; k < n * m; ++k) b[k] = static_cast<float>(a[k]) <= tau_f;
  std::vector<int> label(n * m, -1);
  std::vector<std::vector<std::pair<std::size_t, std::size_t>>> clusters;
  for (std::size_t s = 0; s < n * m; ++s) {
    if (!b[s] || label[s] >= 0) continue;
    ++out.num_below;
    std::vector<std::pair<std::size_t, std::size_t>> cl;
    std::vector<std::size_t> stack = {s};
    label[s] = static_cast<int>(clusters.size());
    while (!stack.empty()) {
      const std::size_t q = stack.back();
      stack.pop_back();
      const std::size_t i = q / m, j = q % m;
      cl.push_back({i, j});
      for (int di = -1; di <= 1; ++di) {
        for (int dj = -1; dj <= 1; ++dj) {
          const long ii = static_cast<long>(i) + di, jj = static_cast<long>(j) + dj;
          if (ii < 0 || jj < 0 || ii >= static_cast<long>(n) || jj >= static_cast<long>(m)) continue;
          const std::size_t r = static_cast<std::size_t>(ii) * m + static_cast<std::size_t>(jj);
          if (b[r] && label[r] < 0) {
            label[r] = label[s];
            stack.push_back(r);
          }
        }
      }
    }
    out.num_below += cl.size() - 1;
    std::sort(cl.begin(), cl.end());
    clusters.push_back(std::move(cl));
  }
  out.num_clusters = clusters.size();
  std::vector<std::uint64_t> areas;
  for (auto& cl : clusters) {
    SequentialCluster c;
    c.row_min = c.col_min = std::numeric_limits<std::size_t>::max();
    for (const auto& ij : cl) {
      c.row_min = std::min(c.row_min, ij.first);
      c.row_max = std::max(c.row_max, ij.first);
      c.col_min = std::min(c.col_min, ij.second);
      c.col_max = std::max(c.col_max, ij.second);
      c.distance_sum += static_cast<double>(static_cast<float>(a[ij.first * m + ij.second]));
    }
    c.cell_count = cl.size();
    areas.push_back(c.span_area());
    out.largest_area = std::max(out.largest_area, c.span_area());
    if (c.span_area() < tau_area) continue;
    const double mc = c.mean_distance(), mb = out.best.mean_distance();
    const bool better = !out.found || mc < mb - 1e-12 ||
                        (std::fabs(mc - mb) <= 1e-12 &&
                         std::make_pair(c.row_min, c.col_min) < std::make_pair(out.best.row_min, out.best.col_min));
    if (better) {
      out.found = true;
      out.best = c;
      std::sort(cl.begin(), cl.end());
      out.cells = cl;
    }
  }
  std::sort(areas.begin(), areas.end(), std::greater<std::uint64_t>());
  if (areas.size() >= 2) out.second_area = areas[1];
  out.clusters = clusters;
  return out;
}

// SequentialMatchResult::clusters against the reference's clusters: same order, spans, counts, cells, distances.
void CheckClusterSet(const SequentialClusterSet& got, const RefResult& ref, const std::vector<float>& a, std::size_t m) {
  REQUIRE(got.clusters.size() == ref.clusters.size());
  REQUIRE(got.begin.size() == ref.clusters.size() + 1);
  REQUIRE(got.cells.size() == ref.num_below);
  for (std::size_t k = 0; k < ref.clusters.size(); ++k) {
    CAPTURE(k);
    const auto& want = ref.clusters[k];
    const Span<const SequentialLoopCell> cells = got.CellsOf(k);
    REQUIRE(cells.size() == want.size());
    double sum = 0.0;
    std::size_t row_min = want[0].first, row_max = 0, col_min = want[0].second, col_max = 0;
    for (std::size_t q = 0; q < want.size(); ++q) {
      REQUIRE(cells[q].alpha_index == want[q].first);
      REQUIRE(cells[q].beta_index == want[q].second);
      CHECK(cells[q].distance == a[want[q].first * m + want[q].second]);
      sum += static_cast<double>(a[want[q].first * m + want[q].second]);
      row_min = std::min(row_min, want[q].first);
      row_max = std::max(row_max, want[q].first);
      col_min = std::min(col_min, want[q].second);
      col_max = std::max(col_max, want[q].second);
    }
    const SequentialCluster& c = got.clusters[k];
    CHECK(c.cell_count == want.size());
    CHECK(c.row_min == row_min);
    CHECK(c.row_max == row_max);
    CHECK(c.col_min == col_min);
    CHECK(c.col_max == col_max);
    CHECK(c.distance_sum == doctest::Approx(sum).epsilon(1e-9));
  }
}

template <class T>
void CheckEqual(const SequentialMatchResult& got, const RefResult& ref, const std::vector<T>& a, std::size_t m) {
  CHECK(got.num_clusters == ref.num_clusters);
  CHECK(got.num_cells_below_threshold == ref.num_below);
  CHECK(got.largest_span_area == ref.largest_area);
  CHECK(got.second_span_area == ref.second_area);
  REQUIRE(got.found == ref.found);
  if (!ref.found) {
    CHECK_FALSE(got.no_candidate_reason.empty());
    return;
  }
  CHECK(got.no_candidate_reason.empty());
  CHECK(got.best.row_min == ref.best.row_min);
  CHECK(got.best.row_max == ref.best.row_max);
  CHECK(got.best.col_min == ref.best.col_min);
  CHECK(got.best.col_max == ref.best.col_max);
  CHECK(got.best.cell_count == ref.best.cell_count);
  CHECK(got.best.mean_distance() == doctest::Approx(ref.best.mean_distance()).epsilon(1e-9));
  REQUIRE(got.cells.size() == ref.cells.size());
  for (std::size_t k = 0; k < ref.cells.size(); ++k) {
    REQUIRE(got.cells[k].alpha_index == ref.cells[k].first);
    REQUIRE(got.cells[k].beta_index == ref.cells[k].second);
    CHECK(got.cells[k].distance == static_cast<float>(a[ref.cells[k].first * m + ref.cells[k].second]));
  }
}

// Random matrix: background above tau except for sparse noise of density `noise`, plus diagonal bands.
std::vector<float> RandomMatrixWithBands(std::size_t n, std::size_t m, double noise, int bands, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> high(0.11f, 1.4f), low(0.0f, 0.1f);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<float> a(n * m);
  for (float& v : a) v = u(rng) < noise ? low(rng) : high(rng);
  for (int k = 0; k < bands; ++k) {
    const auto i0 = static_cast<std::size_t>(u(rng) * static_cast<double>(n));
    const auto j0 = static_cast<std::size_t>(u(rng) * static_cast<double>(m));
    const bool anti = u(rng) < 0.3;
    const std::size_t len = 1 + static_cast<std::size_t>(u(rng) * static_cast<double>(std::max(n, m)));
    for (std::size_t t = 0; t < len; ++t) {
      const std::size_t i = i0 + t;
      const long j = anti ? static_cast<long>(j0) - static_cast<long>(t) : static_cast<long>(j0 + t);
      if (i >= n || j < 0 || static_cast<std::size_t>(j) >= m) break;
      for (long w = 0; w < 2; ++w) {  // band two cells wide
        if (static_cast<std::size_t>(j + w) < m) a[i * m + static_cast<std::size_t>(j + w)] = low(rng);
      }
    }
  }
  if (!a.empty() && u(rng) < 0.5) a[a.size() / 2] = kFloatInf;  // an invalid pair somewhere
  return a;
}

TEST_CASE("sequential matching streaming equals the naive BFS reference on random matrices") {
  const std::vector<std::pair<std::size_t, std::size_t>> sizes = {{1, 1}, {1, 1000}, {1000, 1}, {257, 3},
                                                                   {3, 257}, {60, 75},  {130, 140}};
  const std::vector<std::pair<std::size_t, std::size_t>> tiles = {{1, 1}, {2, 3}, {7, 7}, {16, 5}, {64, 64}, {256, 256}};
  std::uint32_t seed = 10;
  for (const auto& nm : sizes) {
    for (const double noise : {0.0, 0.05, 0.35}) {
      const std::size_t n = nm.first, m = nm.second;
      if (n * m > 5000 && noise > 0.3) continue;  // keep the case fast
      MatrixTileSource src(RandomMatrixWithBands(n, m, noise, 3, ++seed), n, m);
      for (const std::uint64_t tau_area : {std::uint64_t{1}, std::uint64_t{30}, std::uint64_t{400}}) {
        const RefResult ref = NaiveStageA(src.matrix(), n, m, 0.10, tau_area);
        for (const auto& tile : tiles) {
          if (n * m > 10000 && tile.first * tile.second < 10) continue;
          CAPTURE(n);
          CAPTURE(m);
          CAPTURE(noise);
          CAPTURE(tau_area);
          CAPTURE(tile.first);
          CAPTURE(tile.second);
          SequentialMatchParams p;
          p.tau_area = tau_area;
          p.tile_rows = tile.first;
          p.tile_cols = tile.second;
          auto got = RunSequentialMatching(src, p);
          REQUIRE(got.ok());
          CheckEqual(*got, ref, src.matrix(), m);
        }
      }
    }
  }
}

TEST_CASE("Stage A's cluster set equals the naive BFS clusters on every tile grid and is skipped above its cell "
          "cap") {
  const std::vector<std::pair<std::size_t, std::size_t>> sizes = {{1, 1}, {1, 300}, {300, 1}, {60, 75}, {130, 140}};
  const std::vector<std::pair<std::size_t, std::size_t>> tiles = {{1, 1}, {2, 3}, {7, 7}, {16, 5}, {256, 256}};
  std::uint32_t seed = 700;
  std::size_t multi = 0;
  for (const auto& nm : sizes) {
    for (const double noise : {0.0, 0.05, 0.35}) {
      const std::size_t n = nm.first, m = nm.second;
      MatrixTileSource src(RandomMatrixWithBands(n, m, noise, 4, ++seed), n, m);
      const RefResult ref = NaiveStageA(src.matrix(), n, m, 0.10, 30);
      multi += ref.clusters.size() >= 2 ? 1 : 0;
      for (const auto& tile : tiles) {
        if (n * m > 10000 && tile.first * tile.second < 10) continue;
        CAPTURE(n);
        CAPTURE(m);
        CAPTURE(noise);
        CAPTURE(tile.first);
        CAPTURE(tile.second);
        SequentialMatchParams p;
        p.tau_area = 30;
        p.tile_rows = tile.first;
        p.tile_cols = tile.second;
        p.all_clusters_max_cells = ref.num_below;  // exactly at the cap: collected
        auto streamed = RunSequentialMatching(src, p);
        REQUIRE(streamed.ok());
        CheckEqual(*streamed, ref, src.matrix(), m);  // S* and its cells unchanged by the extra pass
        if (ref.num_below == 0) {
          CHECK(streamed->clusters.clusters.empty());
          CHECK_FALSE(streamed->clusters_skipped);
          continue;
        }
        CHECK_FALSE(streamed->clusters_skipped);
        CheckClusterSet(streamed->clusters, ref, src.matrix(), m);
        if (ref.num_below < 2) continue;
        p.all_clusters_max_cells = ref.num_below - 1;  // one cell over the cap: not collected, said so
        auto capped = RunSequentialMatching(src, p);
        REQUIRE(capped.ok());
        CHECK(capped->clusters_skipped);
        CHECK(capped->clusters.clusters.empty());
        CHECK(capped->found == ref.found);
      }
      SequentialMatchParams off;  // the paper: no cluster set
      off.tau_area = 30;
      auto plain = RunSequentialMatching(src, off);
      REQUIRE(plain.ok());
      CHECK(plain->clusters.clusters.empty());
      CHECK_FALSE(plain->clusters_skipped);
    }
  }
  CHECK(multi > 5);  // the matrices have several clusters, so order and grouping are exercised
}

// Smooth trajectory of unit descriptors: each keyframe a small random step from the previous one.
std::vector<float> RandomWalkDescriptors(std::size_t count, std::size_t dim, float step, std::mt19937* rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, 1.0f);
  std::vector<float> v(count * dim);
  std::vector<float> cur(dim);
  for (float& x : cur) x = u(*rng);
  for (std::size_t i = 0; i < count; ++i) {
    double n2 = 0.0;
    for (float x : cur) n2 += static_cast<double>(x) * static_cast<double>(x);
    const auto inv = static_cast<float>(1.0 / std::sqrt(n2));
    for (std::size_t k = 0; k < dim; ++k) {
      v[i * dim + k] = cur[k] * inv;
      cur[k] = std::fabs(cur[k] * inv + step * g(*rng));
    }
  }
  return v;
}

// beta[j0 + s * t] = alpha[i0 + t] + noise for t < len (s = +1 diagonal revisit, -1 opposite direction).
void PlantRevisit(const std::vector<float>& alpha, std::vector<float>* beta, std::size_t dim, std::size_t i0,
                  std::size_t j0, int s, std::size_t len, std::mt19937* rng) {
  std::normal_distribution<float> g(0.0f, 0.004f);
  for (std::size_t t = 0; t < len; ++t) {
    const std::size_t i = i0 + t;
    const std::size_t j = s > 0 ? j0 + t : j0 - t;
    double n2 = 0.0;
    for (std::size_t k = 0; k < dim; ++k) {
      float& x = (*beta)[j * dim + k];
      x = std::fabs(alpha[i * dim + k] + g(*rng));
      n2 += static_cast<double>(x) * static_cast<double>(x);
    }
    const auto inv = static_cast<float>(1.0 / std::sqrt(n2));
    for (std::size_t k = 0; k < dim; ++k) (*beta)[j * dim + k] *= inv;
  }
}

// Runs stage A on descriptors and compares with the naive reference on the double SolidDistance matrix.
SequentialMatchResult RunAndCompare(const std::vector<float>& va, const std::vector<float>& vb, std::size_t dim,
                                    const SequentialMatchParams& p) {
  const DescriptorSetView a{va, dim, {}}, b{vb, dim, {}};
  std::vector<double> ref_matrix;
  REQUIRE(ComputeAffinityNaive(a, b, &ref_matrix).ok());
  std::size_t near_tau = 0;  // float vs double could flip these; the fixed seeds keep them away
  for (double d : ref_matrix) near_tau += std::fabs(d - p.tau_inter) < 1e-4 ? 1 : 0;
  REQUIRE(near_tau == 0);
  const RefResult ref = NaiveStageA(ref_matrix, a.count(), b.count(), p.tau_inter, p.tau_area);
  auto got = RunSequentialMatching(a, b, p);
  REQUIRE(got.ok());
  CHECK(got->num_clusters == ref.num_clusters);
  CHECK(got->num_cells_below_threshold == ref.num_below);
  REQUIRE(got->found == ref.found);
  if (ref.found) {
    CHECK(got->best.row_min == ref.best.row_min);
    CHECK(got->best.row_max == ref.best.row_max);
    CHECK(got->best.col_min == ref.best.col_min);
    CHECK(got->best.col_max == ref.best.col_max);
    CHECK(got->best.cell_count == ref.best.cell_count);
    CHECK(got->best.mean_distance() == doctest::Approx(ref.best.mean_distance()).epsilon(1e-4));
    REQUIRE(got->cells.size() == ref.cells.size());
    for (std::size_t k = 0; k < ref.cells.size(); ++k) {
      CHECK(got->cells[k].alpha_index == ref.cells[k].first);
      CHECK(got->cells[k].beta_index == ref.cells[k].second);
    }
  }
  return std::move(got.value());
}

TEST_CASE("sequential matching finds a diagonal revisit band across tile borders") {
  std::mt19937 rng(7);
  const std::size_t dim = 40;
  const std::vector<float> va = RandomWalkDescriptors(300, dim, 0.05f, &rng);
  std::vector<float> vb = RandomWalkDescriptors(280, dim, 0.05f, &rng);
  PlantRevisit(va, &vb, dim, 40, 100, +1, 150, &rng);  // alpha 40..189 revisited by beta 100..249
  for (const auto& tile : {std::pair<std::size_t, std::size_t>{256, 256}, {64, 64}, {5, 3}, {1, 1}}) {
    SequentialMatchParams p;
    p.tau_area = 5000;
    p.tile_rows = tile.first;
    p.tile_cols = tile.second;
    const SequentialMatchResult r = RunAndCompare(va, vb, dim, p);
    REQUIRE(r.found);
    CHECK(r.best.row_min <= 42);
    CHECK(r.best.row_max >= 187);
    CHECK(r.best.col_min <= 102);
    CHECK(r.best.col_max >= 247);
    for (const SequentialLoopCell& c : r.cells) {
      CHECK(c.distance <= 0.10f);
      CHECK(std::labs(static_cast<long>(c.beta_index) - static_cast<long>(c.alpha_index) - 60) <= 8);
    }
  }
}

TEST_CASE("sequential matching anti-diagonal band and two disjoint bands pick the best qualifying") {
  std::mt19937 rng(11);
  const std::size_t dim = 40;
  const std::vector<float> va = RandomWalkDescriptors(260, dim, 0.05f, &rng);
  std::vector<float> vb = RandomWalkDescriptors(260, dim, 0.05f, &rng);
  PlantRevisit(va, &vb, dim, 10, 239, -1, 110, &rng);  // opposite direction: beta 239 down to 130
  PlantRevisit(va, &vb, dim, 150, 10, +1, 40, &rng);   // short diagonal revisit
  SequentialMatchParams p;
  p.tile_rows = 32;
  p.tile_cols = 48;
  p.tau_area = 5000;  // only the long anti-diagonal qualifies
  SequentialMatchResult r = RunAndCompare(va, vb, dim, p);
  REQUIRE(r.found);
  CHECK(r.best.row_min <= 12);
  CHECK(r.best.col_max >= 237);
  CHECK(r.num_clusters >= 2);
  for (const SequentialLoopCell& c : r.cells) {
    CHECK(std::labs(static_cast<long>(c.alpha_index + c.beta_index) - 249) <= 8);
  }
  p.tau_area = 100;  // both qualify: the choice is the lower mean, whatever it is, as in the reference
  r = RunAndCompare(va, vb, dim, p);
  CHECK(r.found);
  p.tau_area = 1000000;  // none qualifies
  r = RunAndCompare(va, vb, dim, p);
  CHECK_FALSE(r.found);
  CHECK(r.no_candidate_reason.find("no cluster with span area >= tau_area") != std::string::npos);
  CHECK(r.no_candidate_reason.find("largest was " + std::to_string(r.largest_span_area)) != std::string::npos);
  CHECK(r.largest_span_area > 5000);
}

TEST_CASE("sequential matching no-candidate reasons for degenerate inputs") {
  const std::size_t dim = 40;
  std::mt19937 rng(5);
  const std::vector<float> va = RandomWalkDescriptors(50, dim, 0.3f, &rng);
  SequentialMatchParams p;

  SUBCASE("empty sets") {
    auto r = RunSequentialMatching(DescriptorSetView{{}, dim, {}}, DescriptorSetView{va, dim, {}}, p);
    REQUIRE(r.ok());
    CHECK_FALSE(r->found);
    CHECK(r->no_candidate_reason.find("robot alpha") != std::string::npos);
    r = RunSequentialMatching(DescriptorSetView{va, dim, {}}, DescriptorSetView{{}, dim, {}}, p);
    REQUIRE(r.ok());
    CHECK(r->no_candidate_reason.find("robot beta") != std::string::npos);
  }
  SUBCASE("one keyframe each, identical: one cell, span area 1 below tau_area") {
    const std::vector<float> one(va.begin(), va.begin() + static_cast<std::ptrdiff_t>(dim));
    auto r = RunSequentialMatching(DescriptorSetView{one, dim, {}}, DescriptorSetView{one, dim, {}}, p);
    REQUIRE(r.ok());
    CHECK_FALSE(r->found);
    CHECK(r->num_clusters == 1);
    CHECK(r->no_candidate_reason == "no cluster with span area >= tau_area = 10000: largest was 1 (next 0, 1 clusters)");
    p.tau_area = 1;
    r = RunSequentialMatching(DescriptorSetView{one, dim, {}}, DescriptorSetView{one, dim, {}}, p);
    REQUIRE(r.ok());
    CHECK(r->found);
    REQUIRE(r->cells.size() == 1);
    CHECK(r->cells[0].alpha_index == 0);
    CHECK(r->best.span_area() == 1);
  }
  SUBCASE("all above threshold") {
    p.tau_inter = 0.0;  // nothing at distance exactly 0 between different random descriptors
    const std::vector<float> vb = RandomWalkDescriptors(30, dim, 0.3f, &rng);
    auto r = RunSequentialMatching(DescriptorSetView{va, dim, {}}, DescriptorSetView{vb, dim, {}}, p);
    REQUIRE(r.ok());
    CHECK_FALSE(r->found);
    CHECK(r->num_clusters == 0);
    CHECK(r->no_candidate_reason.rfind("no cell below tau_inter = 0 (smallest distance ", 0) == 0);
  }
  SUBCASE("NaN descriptors and flags: never match, no crash") {
    std::vector<float> vb = va;
    for (float& x : vb) x = std::numeric_limits<float>::quiet_NaN();
    auto r = RunSequentialMatching(DescriptorSetView{va, dim, {}}, DescriptorSetView{vb, dim, {}}, p);
    REQUIRE(r.ok());
    CHECK_FALSE(r->found);
    CHECK(r->no_candidate_reason.find("no valid descriptor pair") != std::string::npos);
    const std::vector<std::uint8_t> none(50, 0);
    r = RunSequentialMatching(DescriptorSetView{va, dim, none}, DescriptorSetView{va, dim, {}}, p);
    REQUIRE(r.ok());
    CHECK(r->num_cells_below_threshold == 0);
  }
  SUBCASE("bad parameters and malformed sets are errors") {
    p.tau_inter = -1.0;
    CHECK_FALSE(RunSequentialMatching(DescriptorSetView{va, dim, {}}, DescriptorSetView{va, dim, {}}, p).ok());
    p.tau_inter = std::numeric_limits<double>::quiet_NaN();
    CHECK_FALSE(RunSequentialMatching(DescriptorSetView{va, dim, {}}, DescriptorSetView{va, dim, {}}, p).ok());
    p = SequentialMatchParams{};
    p.tile_cols = 0;
    CHECK_FALSE(RunSequentialMatching(DescriptorSetView{va, dim, {}}, DescriptorSetView{va, dim, {}}, p).ok());
    p = SequentialMatchParams{};
    CHECK_FALSE(RunSequentialMatching(DescriptorSetView{va, dim, {}}, DescriptorSetView{va, dim - 1, {}}, p).ok());
  }
}

TEST_CASE("sequential matching span area is inclusive rows x cols and selection respects tau_area") {
  // 6 x 8 matrix: cluster X = 3 cells on a diagonal (span 3 x 3 = 9), mean 0.05; cluster Y = 1 x 4 row, mean 0.02.
  std::vector<float> a(6 * 8, 1.0f);
  a[0 * 8 + 0] = 0.04f;
  a[1 * 8 + 1] = 0.05f;
  a[2 * 8 + 2] = 0.06f;
  for (std::size_t j = 4; j < 8; ++j) a[5 * 8 + j] = 0.02f;
  MatrixTileSource src(a, 6, 8);
  SequentialMatchParams p;
  p.tile_rows = 2;
  p.tile_cols = 3;
  p.tau_area = 4;  // both qualify (9 and 4): lower mean wins
  auto r = RunSequentialMatching(src, p);
  REQUIRE(r.ok());
  REQUIRE(r->found);
  CHECK(r->num_clusters == 2);
  CHECK(r->best.row_min == 5);
  CHECK(r->best.span_area() == 4);
  CHECK(r->best.mean_distance() == doctest::Approx(0.02));
  p.tau_area = 5;  // only the diagonal (area 9)
  r = RunSequentialMatching(src, p);
  REQUIRE(r->found);
  CHECK(r->best.row_min == 0);
  CHECK(r->best.row_max == 2);
  CHECK(r->best.span_rows() == 3);
  CHECK(r->best.span_area() == 9);
  CHECK(r->best.cell_count == 3);
  CHECK(r->cells.size() == 3);
  CHECK(r->best.mean_distance() == doctest::Approx(0.05));
  p.tau_area = 10;
  r = RunSequentialMatching(src, p);
  CHECK_FALSE(r->found);
  // The diagonal spans 9 cells, the row 4: the reason names both.
  CHECK(r->second_span_area == 4);
  CHECK(r->no_candidate_reason == "no cluster with span area >= tau_area = 10: largest was 9 (next 4, 2 clusters)");
}

TEST_CASE("sequential matching tile minimum skips do not change the result") {
  // The descriptor kernel reports a tile minimum; the labeller then skips tiles above tau. Same source with
  // and without the minimum: identical results.
  class NoMinimum final : public AffinityTileSource {
   public:
    explicit NoMinimum(AffinityTileSource& s) : s_(s) {}
    std::size_t num_rows() const noexcept override { return s_.num_rows(); }
    std::size_t num_cols() const noexcept override { return s_.num_cols(); }
    Status ComputeTile(std::size_t r0, std::size_t c0, std::size_t rows, std::size_t cols, AffinityTile* t) override {
      Status st = s_.ComputeTile(r0, c0, rows, cols, t);
      t->min_distance = std::numeric_limits<float>::quiet_NaN();
      return st;
    }

   private:
    AffinityTileSource& s_;
  };
  std::mt19937 rng(17);
  const std::size_t dim = 40;
  const std::vector<float> va = RandomWalkDescriptors(300, dim, 0.05f, &rng);
  std::vector<float> vb = RandomWalkDescriptors(280, dim, 0.05f, &rng);
  PlantRevisit(va, &vb, dim, 40, 100, +1, 150, &rng);
  SequentialMatchParams p;
  p.tau_area = 400;
  for (const auto& tile : {std::pair<std::size_t, std::size_t>{256, 256}, {32, 16}, {5, 9}}) {
    p.tile_rows = tile.first;
    p.tile_cols = tile.second;
    auto kernel = AffinityTileKernel::Create({va, dim, {}}, {vb, dim, {}}, p.tile_rows, p.tile_cols);
    REQUIRE(kernel.ok());
    NoMinimum plain(*kernel);
    auto a = RunSequentialMatching(*kernel, p);
    auto b = RunSequentialMatching(plain, p);
    REQUIRE(a.ok());
    REQUIRE(b.ok());
    REQUIRE(a->found);
    CHECK(a->found == b->found);
    CHECK(a->num_clusters == b->num_clusters);
    CHECK(a->num_cells_below_threshold == b->num_cells_below_threshold);
    CHECK(a->min_distance == b->min_distance);
    CHECK(a->best.distance_sum == b->best.distance_sum);
    CHECK(a->cells.size() == b->cells.size());
  }
}

// ---- Sequence smoothing (sequence_half_window w >= 1), against a dense reference written here.

// S over the whole matrix, straight from the definition: for each line (diagonal, anti-diagonal) the mean of
// its finite in-matrix cells for k = -w .. w in ascending k (double sums), +inf where A_ij is +inf.
std::vector<float> DenseSmoothed(const std::vector<float>& a, std::size_t n, std::size_t m, std::size_t w) {
  std::vector<float> s(n * m);
  const long ln = static_cast<long>(n), lm = static_cast<long>(m), lw = static_cast<long>(w);
  for (long i = 0; i < ln; ++i) {
    for (long j = 0; j < lm; ++j) {
      if (!std::isfinite(a[static_cast<std::size_t>(i * lm + j)])) {
        s[static_cast<std::size_t>(i * lm + j)] = kFloatInf;
        continue;
      }
      double sum[2] = {0.0, 0.0};
      int count[2] = {0, 0};
      for (long k = -lw; k <= lw; ++k) {
        const long ii = i + k;
        if (ii < 0 || ii >= ln) continue;
        const long cols[2] = {j + k, j - k};
        for (int line = 0; line < 2; ++line) {
          if (cols[line] < 0 || cols[line] >= lm) continue;
          const float v = a[static_cast<std::size_t>(ii * lm + cols[line])];
          if (!std::isfinite(v)) continue;
          sum[line] += static_cast<double>(v);
          ++count[line];
        }
      }
      s[static_cast<std::size_t>(i * lm + j)] =
          static_cast<float>(std::min(sum[0] / count[0], sum[1] / count[1]));
    }
  }
  return s;
}

// V, what stage A thresholds: the lowest S among the (up to) 3 x 3 cells around each cell, +inf where A is.
std::vector<float> DenseServed(const std::vector<float>& a, std::size_t n, std::size_t m, std::size_t w) {
  const std::vector<float> s = DenseSmoothed(a, n, m, w);
  std::vector<float> v(n * m, kFloatInf);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < m; ++j) {
      if (!std::isfinite(a[i * m + j])) continue;
      for (std::size_t ii = i == 0 ? 0 : i - 1; ii <= i + 1 && ii < n; ++ii) {
        for (std::size_t jj = j == 0 ? 0 : j - 1; jj <= j + 1 && jj < m; ++jj) {
          v[i * m + j] = std::min(v[i * m + j], s[ii * m + jj]);
        }
      }
    }
  }
  return v;
}

// A random matrix with bands (RandomMatrixWithBands) and a few more invalid pairs.
std::vector<float> RandomMatrixWithHoles(std::size_t n, std::size_t m, std::uint32_t seed) {
  std::vector<float> a = RandomMatrixWithBands(n, m, 0.05, 3, seed);
  std::mt19937 rng(seed + 1000);
  for (std::size_t k = 0; k < a.size() / 50; ++k) a[rng() % a.size()] = kFloatInf;
  return a;
}

TEST_CASE("Sequence smoothing: tiles grown by the halo equal the dense definition for every grid and window") {
  const std::vector<std::pair<std::size_t, std::size_t>> sizes = {{1, 1}, {1, 40}, {40, 1}, {37, 53}, {70, 65}};
  const std::vector<std::pair<std::size_t, std::size_t>> tiles = {{1, 1}, {2, 3}, {7, 7}, {16, 5}, {64, 64}};
  std::uint32_t seed = 300;
  for (const auto& nm : sizes) {
    for (const bool holes : {true, false}) {  // without invalid pairs the source sweeps whole rows at once
      const std::size_t n = nm.first, m = nm.second;
      std::vector<float> a = RandomMatrixWithHoles(n, m, ++seed);
      if (!holes) {
        for (float& v : a) v = std::isfinite(v) ? v : 1.3f;
      }
      MatrixTileSource inner(std::move(a), n, m);
      for (const std::size_t w : {std::size_t{0}, std::size_t{1}, std::size_t{3}, std::size_t{8}}) {
        const std::vector<float> smoothed = DenseSmoothed(inner.matrix(), n, m, w);
        if (w == 0) {  // S = A exactly
          for (std::size_t k = 0; k < smoothed.size(); ++k) REQUIRE(smoothed[k] == inner.matrix()[k]);
        }
        for (std::size_t i = 0; i < n; ++i) {
          for (std::size_t j = 0; j < m; ++j) {
            REQUIRE(SequenceSmoothedCell(inner.matrix().data(), n, m, i, j, w) == smoothed[i * m + j]);
          }
        }
        const std::vector<float> ref = DenseServed(inner.matrix(), n, m, w);
        for (const auto& tile : tiles) {
          CAPTURE(n);
          CAPTURE(m);
          CAPTURE(holes);
          CAPTURE(w);
          CAPTURE(tile.first);
          CAPTURE(tile.second);
          auto src = SequenceSmoothedTileSource::Create(&inner, w, tile.first, tile.second);
          REQUIRE(src.ok());
          REQUIRE(src->num_rows() == n);
          REQUIRE(src->num_cols() == m);
          std::size_t cells = 0;
          REQUIRE(ForEachAffinityTile(*src, tile.first, tile.second, [&](const AffinityTile& t) {
                    float tile_min = kFloatInf;
                    for (std::size_t r = 0; r < t.rows; ++r) {
                      for (std::size_t c = 0; c < t.cols; ++c) {
                        const float want = ref[(t.row_begin + r) * m + t.col_begin + c];
                        if (!(t.at(r, c) == want)) return InvalidArgument("cell differs");
                        tile_min = std::min(tile_min, want);
                        ++cells;
                      }
                    }
                    return t.min_distance == tile_min ? Status::Ok() : InvalidArgument("tile minimum differs");
                  }).ok());
          CHECK(cells == n * m);
        }
      }
    }
  }
  // Errors: a window above the limit, a zero capacity, a tile outside the matrix or above the capacity.
  MatrixTileSource inner(RandomMatrixWithHoles(10, 10, 1), 10, 10);
  CHECK_FALSE(SequenceSmoothedTileSource::Create(&inner, kMaxSequenceHalfWindow + 1, 4, 4).ok());
  CHECK_FALSE(SequenceSmoothedTileSource::Create(&inner, 2, 0, 4).ok());
  CHECK_FALSE(SequenceSmoothedTileSource::Create(nullptr, 2, 4, 4).ok());
  auto src = SequenceSmoothedTileSource::Create(&inner, 2, 4, 4);
  REQUIRE(src.ok());
  AffinityTile t;
  CHECK_FALSE(src->ComputeTile(8, 0, 4, 4, &t).ok());
  CHECK_FALSE(src->ComputeTile(0, 0, 5, 4, &t).ok());
  CHECK_FALSE(src->ComputeTile(0, 0, 0, 4, &t).ok());
  CHECK(src->ComputeTile(6, 6, 4, 4, &t).ok());
}

TEST_CASE("Sequence smoothing: stage A with a half window equals the naive stage A on the smoothed matrix") {
  const std::vector<std::pair<std::size_t, std::size_t>> sizes = {{1, 1}, {3, 257}, {60, 75}, {130, 140}};
  const std::vector<std::pair<std::size_t, std::size_t>> tiles = {{1, 1}, {7, 7}, {16, 5}, {64, 64}, {256, 256}};
  std::uint32_t seed = 400;
  for (const auto& nm : sizes) {
    const std::size_t n = nm.first, m = nm.second;
    MatrixTileSource src(RandomMatrixWithHoles(n, m, ++seed), n, m);
    for (const std::size_t w : {std::size_t{1}, std::size_t{4}}) {
      const std::vector<float> smoothed = DenseServed(src.matrix(), n, m, w);
      for (const std::uint64_t tau_area : {std::uint64_t{1}, std::uint64_t{400}}) {
        const RefResult ref = NaiveStageA(smoothed, n, m, 0.10, tau_area);
        for (const auto& tile : tiles) {
          if (n * m > 10000 && tile.first * tile.second < 10) continue;
          CAPTURE(n);
          CAPTURE(m);
          CAPTURE(w);
          CAPTURE(tau_area);
          CAPTURE(tile.first);
          SequentialMatchParams p;
          p.tau_area = tau_area;
          p.tile_rows = tile.first;
          p.tile_cols = tile.second;
          p.sequence_half_window = w;
          auto got = RunSequentialMatching(src, p);
          REQUIRE(got.ok());
          CheckEqual(*got, ref, smoothed, m);
        }
      }
    }
  }

  // On descriptors: the kernel's own matrix (position independent), smoothed densely, is the reference.
  std::mt19937 rng(77);
  const std::size_t dim = 40, n = 180, m = 150;
  std::vector<float> va = RandomWalkDescriptors(n, dim, 0.05f, &rng);
  std::vector<float> vb = RandomWalkDescriptors(m, dim, 0.05f, &rng);
  PlantRevisit(va, &vb, dim, 20, 10, +1, 120, &rng);
  const DescriptorSetView a{va, dim, {}}, b{vb, dim, {}};
  auto kernel = AffinityTileKernel::Create(a, b, n, m);
  REQUIRE(kernel.ok());
  AffinityTile whole;
  REQUIRE(kernel->ComputeTile(0, 0, n, m, &whole).ok());
  std::vector<float> matrix(whole.distances, whole.distances + n * m);
  SequentialMatchParams p;
  p.tile_rows = 64;
  p.tile_cols = 48;
  p.sequence_half_window = 5;
  const std::vector<float> smoothed = DenseServed(matrix, n, m, p.sequence_half_window);
  const RefResult ref = NaiveStageA(smoothed, n, m, p.tau_inter, p.tau_area);
  auto got = RunSequentialMatching(a, b, p);
  REQUIRE(got.ok());
  CHECK(got->found);
  CheckEqual(*got, ref, smoothed, m);
}

TEST_CASE("Sequence smoothing bridges a revisit cut by single-keyframe jumps, and builds none from scattered cells") {
  const std::size_t n = 300, m = 300;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> background(0.2f, 1.2f), near(0.02f, 0.07f);
  for (const int direction : {+1, -1}) {
    CAPTURE(direction);
    // A revisit of 200 keyframes, one cell wide: (i, i + 20) or (i, 280 - i); every 4th keyframe jumps to 0.15
    // (above tau_inter), which cuts the 8-connected line into pieces of 3 cells.
    std::vector<float> a(n * m);
    for (float& v : a) v = background(rng);
    auto band_col = [&](std::size_t i) { return direction > 0 ? i + 20 : 280 - i; };
    for (std::size_t i = 50; i < 250; ++i) a[i * m + band_col(i)] = i % 4 == 0 ? 0.15f : near(rng);
    MatrixTileSource src(a, n, m);
    SequentialMatchParams p;  // tau_inter 0.10, tau_area 10 000 (the paper's)
    auto paper = RunSequentialMatching(src, p);
    REQUIRE(paper.ok());
    CHECK_FALSE(paper->found);
    CHECK(paper->largest_span_area <= 9);
    p.sequence_half_window = 4;
    auto smoothed = RunSequentialMatching(src, p);
    REQUIRE(smoothed.ok());
    REQUIRE(smoothed->found);
    CHECK(smoothed->best.span_rows() >= 180);  // the ends lose up to w rows to the background
    std::size_t on_band = 0;
    for (const SequentialLoopCell& c : smoothed->cells) {  // every loop lies on the revisit or next to it
      // (the 3 x 3 neighbours of a diagonal line: up to 2 columns aside in the same row)
      const long offset = static_cast<long>(c.beta_index) - static_cast<long>(band_col(c.alpha_index));
      REQUIRE(std::labs(offset) <= 2);
      on_band += offset == 0 ? 1 : 0;
    }
    CHECK(on_band >= 180);
    CHECK(smoothed->cells.size() >= 3 * 180);  // the 3 x 3 minimum widens the band to 3 cells
  }

  // Control without a revisit: 35 % of the cells scattered below tau_inter. Per cell they percolate into
  // clusters; their sequence means never come near tau_inter.
  std::vector<float> a(n * m);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (float& v : a) v = u(rng) < 0.35 ? near(rng) : background(rng);
  MatrixTileSource src(a, n, m);
  SequentialMatchParams p;
  p.tau_area = 400;
  auto paper = RunSequentialMatching(src, p);
  REQUIRE(paper.ok());
  CHECK(paper->found);  // the per-cell threshold does build a cluster here
  p.sequence_half_window = 4;
  auto smoothed = RunSequentialMatching(src, p);
  REQUIRE(smoothed.ok());
  CHECK_FALSE(smoothed->found);
  MESSAGE("scattered cells: per cell " << paper->num_cells_below_threshold << " below, largest span "
                                       << paper->largest_span_area << "; smoothed " << smoothed->num_cells_below_threshold
                                       << " below, largest span " << smoothed->largest_span_area);
  CHECK(smoothed->num_cells_below_threshold * 20 < paper->num_cells_below_threshold);
  CHECK(smoothed->largest_span_area * 10 < paper->largest_span_area);
}

TEST_CASE("Sequence smoothing: window limits") {
  SequentialMatchParams p;
  p.sequence_half_window = kMaxSequenceHalfWindow;
  CHECK(ValidateSequentialMatchParams(p).ok());
  p.sequence_half_window = kMaxSequenceHalfWindow + 1;
  const Status s = ValidateSequentialMatchParams(p);
  CHECK_FALSE(s.ok());
  CHECK(s.message().find("sequence_half_window") != std::string::npos);
}

// Dense reference of NeighbourRankTileSource: the k-th smallest finite value of every row and column by full
// sort, and a cell kept when at most either.
std::vector<float> DenseRanked(const std::vector<float>& a, std::size_t n, std::size_t m, std::size_t k) {
  auto kth = [&](std::vector<float> line) {
    line.erase(std::remove_if(line.begin(), line.end(), [](float v) { return !std::isfinite(v); }), line.end());
    std::sort(line.begin(), line.end());
    return line.size() < k ? kFloatInf : line[k - 1];
  };
  std::vector<float> row_kth(n), col_kth(m);
  for (std::size_t i = 0; i < n; ++i) row_kth[i] = kth(std::vector<float>(a.begin() + i * m, a.begin() + (i + 1) * m));
  for (std::size_t j = 0; j < m; ++j) {
    std::vector<float> col(n);
    for (std::size_t i = 0; i < n; ++i) col[i] = a[i * m + j];
    col_kth[j] = kth(col);
  }
  std::vector<float> out(n * m, kFloatInf);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = 0; j < m; ++j) {
      const float v = a[i * m + j];
      if (std::isfinite(v) && (v <= row_kth[i] || v <= col_kth[j])) out[i * m + j] = v;
    }
  }
  return out;
}

TEST_CASE("Neighbour rank: served tiles equal the dense definition for every grid and k") {
  std::uint32_t seed = 900;
  for (const auto& nm : std::vector<std::pair<std::size_t, std::size_t>>{{1, 1}, {1, 9}, {17, 3}, {60, 75}}) {
    const std::size_t n = nm.first, m = nm.second;
    MatrixTileSource src(RandomMatrixWithHoles(n, m, ++seed), n, m);
    for (const std::size_t k : {std::size_t{1}, std::size_t{3}, kMaxNeighbourRank}) {
      const std::vector<float> ref = DenseRanked(src.matrix(), n, m, k);
      for (const auto& tile : std::vector<std::pair<std::size_t, std::size_t>>{{1, 1}, {7, 5}, {64, 64}}) {
        CAPTURE(n);
        CAPTURE(m);
        CAPTURE(k);
        CAPTURE(tile.first);
        auto ranked = NeighbourRankTileSource::Create(&src, k, tile.first, tile.second);
        REQUIRE(ranked.ok());
        AffinityTile t;
        CHECK_FALSE(ranked->ComputeTile(0, 0, 1, 1, &t).ok());  // before Prepare
        REQUIRE(ranked->Prepare().ok());
        for (std::size_t r0 = 0; r0 < n; r0 += tile.first) {
          for (std::size_t c0 = 0; c0 < m; c0 += tile.second) {
            const std::size_t rows = std::min(tile.first, n - r0), cols = std::min(tile.second, m - c0);
            REQUIRE(ranked->ComputeTile(r0, c0, rows, cols, &t).ok());
            float lowest = kFloatInf;
            for (std::size_t r = 0; r < rows; ++r) {
              for (std::size_t c = 0; c < cols; ++c) {
                const float want = ref[(r0 + r) * m + c0 + c];
                REQUIRE((t.at(r, c) == want || (std::isinf(want) && std::isinf(t.at(r, c)))));
                lowest = std::min(lowest, want);
              }
            }
            CHECK(t.min_distance == lowest);
          }
        }
      }
    }
  }
  MatrixTileSource src(RandomMatrixWithHoles(4, 4, 1), 4, 4);
  CHECK_FALSE(NeighbourRankTileSource::Create(&src, 0, 4, 4).ok());
  CHECK_FALSE(NeighbourRankTileSource::Create(&src, kMaxNeighbourRank + 1, 4, 4).ok());
  CHECK_FALSE(NeighbourRankTileSource::Create(&src, 1, 0, 4).ok());
}

TEST_CASE("Neighbour rank: stage A with k equals the naive stage A on the ranked (smoothed) matrix") {
  std::uint32_t seed = 950;
  for (const auto& nm : std::vector<std::pair<std::size_t, std::size_t>>{{3, 57}, {60, 75}, {130, 140}}) {
    const std::size_t n = nm.first, m = nm.second;
    MatrixTileSource src(RandomMatrixWithHoles(n, m, ++seed), n, m);
    for (const std::size_t w : {std::size_t{0}, std::size_t{3}}) {
      for (const std::size_t k : {std::size_t{1}, std::size_t{2}}) {
        const std::vector<float> served = DenseRanked(w == 0 ? src.matrix() : DenseServed(src.matrix(), n, m, w), n, m, k);
        for (const std::uint64_t tau_area : {std::uint64_t{1}, std::uint64_t{100}}) {
          const RefResult ref = NaiveStageA(served, n, m, 0.5, tau_area);
          for (const std::size_t tile : {std::size_t{16}, std::size_t{256}}) {
            CAPTURE(n);
            CAPTURE(w);
            CAPTURE(k);
            CAPTURE(tau_area);
            CAPTURE(tile);
            SequentialMatchParams p;
            p.tau_inter = 0.5;
            p.tau_area = tau_area;
            p.tile_rows = p.tile_cols = tile;
            p.sequence_half_window = w;
            p.neighbour_rank = k;
            auto got = RunSequentialMatching(src, p);
            REQUIRE(got.ok());
            CheckEqual(*got, ref, served, m);
          }
        }
      }
    }
  }
}

// Everything stage A returns, compared field by field (clusters with their cells included).
void CheckSameResult(const SequentialMatchResult& a, const SequentialMatchResult& b) {
  CHECK(a.found == b.found);
  CHECK(a.num_clusters == b.num_clusters);
  CHECK(a.num_cells_below_threshold == b.num_cells_below_threshold);
  CHECK(a.largest_span_area == b.largest_span_area);
  CHECK(a.second_span_area == b.second_span_area);
  CHECK(a.min_distance == b.min_distance);
  CHECK(a.no_candidate_reason == b.no_candidate_reason);
  CHECK(a.clusters_skipped == b.clusters_skipped);
  const auto same_cluster = [](const SequentialCluster& x, const SequentialCluster& y) {
    return x.row_min == y.row_min && x.row_max == y.row_max && x.col_min == y.col_min && x.col_max == y.col_max &&
           x.cell_count == y.cell_count && x.distance_sum == y.distance_sum;
  };
  const auto same_cells = [](const std::vector<SequentialLoopCell>& x, const std::vector<SequentialLoopCell>& y) {
    if (x.size() != y.size()) return false;
    for (std::size_t q = 0; q < x.size(); ++q) {
      if (x[q].alpha_index != y[q].alpha_index || x[q].beta_index != y[q].beta_index ||
          !(x[q].distance == y[q].distance)) {
        return false;
      }
    }
    return true;
  };
  if (a.found && b.found) CHECK(same_cluster(a.best, b.best));
  CHECK(same_cells(a.cells, b.cells));
  REQUIRE(a.clusters.clusters.size() == b.clusters.clusters.size());
  for (std::size_t k = 0; k < a.clusters.clusters.size(); ++k) {
    CHECK(same_cluster(a.clusters.clusters[k], b.clusters.clusters[k]));
  }
  CHECK(a.clusters.begin == b.clusters.begin);
  CHECK(same_cells(a.clusters.cells, b.clusters.cells));
}

TEST_CASE("Neighbour rank: kept cells stored or not (ties beyond the slots), stage A equals the dense passes") {
  std::uint32_t seed = 1200;
  for (const int kind : {0, 1, 2}) {  // random; values on a coarse grid (many ties); one value everywhere
    for (const auto& nm : std::vector<std::pair<std::size_t, std::size_t>>{{60, 75}, {130, 140}}) {
      const std::size_t n = nm.first, m = nm.second;
      std::vector<float> a = RandomMatrixWithHoles(n, m, ++seed);
      for (float& v : a) {
        if (!std::isfinite(v)) continue;
        if (kind == 1) v = std::round(v * 8.0f) / 8.0f;
        if (kind == 2) v = 0.25f;
      }
      MatrixTileSource src(std::move(a), n, m);
      for (const std::size_t k : {std::size_t{1}, std::size_t{2}}) {
        CAPTURE(kind);
        CAPTURE(n);
        CAPTURE(k);
        const std::vector<float> served = DenseRanked(src.matrix(), n, m, k);
        auto ranked = NeighbourRankTileSource::Create(&src, k, 16, 16);
        REQUIRE(ranked.ok());
        REQUIRE(ranked->Prepare().ok());
        if (kind == 0) CHECK(ranked->sparse());
        if (kind == 2) CHECK_FALSE(ranked->sparse());
        // Stage A through the rank source (sparse passes when the cells are stored) against stage A's dense
        // passes on the served matrix itself.
        MatrixTileSource dense(std::vector<float>(served), n, m);
        for (const std::size_t tile : {std::size_t{16}, std::size_t{64}}) {
          for (const std::uint64_t tau_area : {std::uint64_t{1}, std::uint64_t{100}}) {
            SequentialMatchParams p;
            p.tau_inter = 0.5;
            p.tau_area = tau_area;
            p.tile_rows = p.tile_cols = tile;
            p.all_clusters_max_cells = 1000000;
            SequentialMatchParams pr = p;
            pr.neighbour_rank = k;
            auto want = RunSequentialMatching(dense, p);
            auto got = RunSequentialMatching(src, pr);
            REQUIRE(want.ok());
            REQUIRE(got.ok());
            CheckSameResult(*got, *want);
          }
        }
      }
    }
  }
}

TEST_CASE("Neighbour rank finds revisits that no one absolute threshold separates, and no cluster in noise") {
  // Two places seen by two sensors: in the first, every distance is low (background 0.1-0.6, revisit
  // 0.02-0.08); in the second, high (background 0.4-1.2, revisit 0.3-0.45). Each has 40 keyframes of shared
  // path (span 1 600 cells), one along the diagonal, one against it.
  const std::size_t n = 300, m = 260;
  std::mt19937 rng(11);
  struct Scene {
    float bg_lo, bg_hi, rv_lo, rv_hi;
    int direction;
  };
  const Scene scenes[] = {{0.1f, 0.6f, 0.02f, 0.08f, +1}, {0.4f, 1.2f, 0.3f, 0.45f, -1}};
  auto band_col = [](int direction, std::size_t i) { return direction > 0 ? i - 100 : 300 - i; };
  std::vector<MatrixTileSource> sources;
  for (const Scene& sc : scenes) {
    std::uniform_real_distribution<float> background(sc.bg_lo, sc.bg_hi), revisit(sc.rv_lo, sc.rv_hi);
    std::vector<float> a(n * m);
    for (float& v : a) v = background(rng);
    for (std::size_t i = 120; i < 160; ++i) a[i * m + band_col(sc.direction, i)] = revisit(rng);
    sources.emplace_back(a, n, m);
  }
  // Stage A finds the revisit when it selects a cluster whose cells all lie on it (or next to it).
  auto on_revisit = [&](const SequentialMatchResult& r, int direction) {
    if (!r.found) return false;
    for (const SequentialLoopCell& c : r.cells) {
      const long offset = static_cast<long>(c.beta_index) - static_cast<long>(band_col(direction, c.alpha_index));
      if (std::labs(offset) > 2) return false;
    }
    return r.best.span_rows() >= 30;
  };
  // The paper's rule: no tau_inter finds both (a low one misses the second, a high one floods the first).
  for (const double tau : {0.05, 0.08, 0.1, 0.2, 0.3, 0.45, 0.6}) {
    SequentialMatchParams p;
    p.tau_inter = tau;
    p.tau_area = 400;
    int found = 0;
    for (std::size_t s = 0; s < 2; ++s) {
      auto r = RunSequentialMatching(sources[s], p);
      REQUIRE(r.ok());
      found += on_revisit(*r, scenes[s].direction) ? 1 : 0;
    }
    CAPTURE(tau);
    CHECK(found < 2);
  }
  // Neighbour rank 1 after sequence smoothing (w = 4), tau_inter a cap only: both.
  SequentialMatchParams p;
  p.tau_inter = 1.5;
  p.tau_area = 400;
  p.sequence_half_window = 4;
  p.neighbour_rank = 1;
  for (std::size_t s = 0; s < 2; ++s) {
    auto r = RunSequentialMatching(sources[s], p);
    REQUIRE(r.ok());
    CAPTURE(s);
    CHECK(on_revisit(*r, scenes[s].direction));
    CHECK(r->best.span_rows() <= 50);
  }
  // Noise alone, several seeds: the row and column minima are scattered; sequence smoothing over 2w + 1 = 9
  // keyframes makes short chance chains (spans up to about (2w + 3)^2 = 121 cells), none reaches 20 x 20.
  for (std::uint32_t seed = 1; seed <= 5; ++seed) {
    std::mt19937 noise_rng(seed);
    std::uniform_real_distribution<float> background(0.3f, 1.2f);
    std::vector<float> a(n * m);
    for (float& v : a) v = background(noise_rng);
    MatrixTileSource src(a, n, m);
    auto got = RunSequentialMatching(src, p);
    REQUIRE(got.ok());
    CAPTURE(seed);
    CHECK_FALSE(got->found);
    CHECK(got->largest_span_area < 400);
  }
}

TEST_CASE("Neighbour rank: limits") {
  SequentialMatchParams p;
  p.neighbour_rank = kMaxNeighbourRank;
  CHECK(ValidateSequentialMatchParams(p).ok());
  p.neighbour_rank = kMaxNeighbourRank + 1;
  const Status s = ValidateSequentialMatchParams(p);
  CHECK_FALSE(s.ok());
  CHECK(s.message().find("neighbour_rank") != std::string::npos);
}

TEST_CASE("Stage A's span area scales with the shorter mission when tau_area_fraction is set") {
  SequentialMatchParams p;
  p.tau_area = 400;
  CHECK(EffectiveTauArea(p, 50, 800) == 400);  // off: the paper's fixed value
  p.tau_area_fraction = 0.3;
  p.min_tau_area = 100;
  CHECK(EffectiveTauArea(p, 800, 900) == 400);          // (0.3 * 800)^2 = 57 600 -> capped at tau_area
  CHECK(EffectiveTauArea(p, 49, 58) == 217);            // ceil((0.3 * 49)^2) = ceil(216.09)
  CHECK(EffectiveTauArea(p, 20, 300) == 100);           // 36 -> the floor
  p.tau_area = 4;
  CHECK(EffectiveTauArea(p, 20, 300) == 4);             // never above tau_area
  p.tau_area_fraction = -0.1;
  CHECK_FALSE(ValidateSequentialMatchParams(p).ok());

  // A 60 x 60 matrix whose robots share 16 keyframes (span 256): refused at tau_area 400, found when it scales
  // ((0.3 * 60)^2 = 324 > 256: found only with a fraction small enough, here 0.25 -> 225).
  const std::size_t n = 60, m = 60;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> background(0.4f, 1.2f), revisit(0.02f, 0.08f);
  std::vector<float> a(n * m);
  for (float& v : a) v = background(rng);
  for (std::size_t i = 30; i < 46; ++i) a[i * m + i - 20] = revisit(rng);
  MatrixTileSource src(a, n, m);
  SequentialMatchParams q;
  q.tau_area = 400;
  auto fixed = RunSequentialMatching(src, q);
  REQUIRE(fixed.ok());
  CHECK_FALSE(fixed->found);
  CHECK(fixed->no_candidate_reason.find("tau_area = 400") != std::string::npos);
  q.tau_area_fraction = 0.3;
  auto scaled_high = RunSequentialMatching(src, q);
  REQUIRE(scaled_high.ok());
  CHECK_FALSE(scaled_high->found);
  CHECK(scaled_high->no_candidate_reason.find("tau_area = 324") != std::string::npos);
  q.tau_area_fraction = 0.25;
  auto scaled = RunSequentialMatching(src, q);
  REQUIRE(scaled.ok());
  REQUIRE(scaled->found);
  CHECK(scaled->best.span_rows() == 16);
  CHECK(scaled->best.span_cols() == 16);
}

}  // namespace
}  // namespace commerge
