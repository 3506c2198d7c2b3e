// SPDX-License-Identifier: BSD-3-Clause
// Incremental stage A: after every batch (alpha and beta growing independently, empty and one-keyframe
// batches included) the result equals the full streaming RunSequentialMatching on the same prefix sets, field
// for field (the distance sums bit for bit), and the update computed exactly the new cells. Hit-store
// overflow falls back to the full pass; capacity and format errors; degenerate inputs.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "core/exchange/affinity.hpp"
#include "core/exchange/incremental_matching.hpp"
#include "core/exchange/sequential_matching.hpp"

namespace commerge {
namespace {

constexpr std::size_t kDim = 40;

void Normalise(float* v, std::size_t dim) {
  double n2 = 0.0;
  for (std::size_t k = 0; k < dim; ++k) n2 += static_cast<double>(v[k]) * static_cast<double>(v[k]);
  const auto inv = static_cast<float>(1.0 / std::sqrt(n2));
  for (std::size_t k = 0; k < dim; ++k) v[k] *= inv;
}

// A trajectory of unit descriptors, each a small random step from the previous one (consecutive keyframes
// ~0.06 apart, so a revisit makes a band a few cells wide below tau_inter = 0.10).
std::vector<float> Trajectory(std::size_t count, float step, std::mt19937* rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g(0.0f, step);
  std::vector<float> v(count * kDim), cur(kDim);
  for (float& x : cur) x = u(*rng);
  Normalise(cur.data(), kDim);
  for (std::size_t i = 0; i < count; ++i) {
    std::copy(cur.begin(), cur.end(), v.begin() + static_cast<std::ptrdiff_t>(i * kDim));
    for (float& x : cur) x = std::fabs(x + g(*rng));
    Normalise(cur.data(), kDim);
  }
  return v;
}

// beta[j0 + s t] = alpha[i0 + t] + noise for t < len (s = +1: revisit in the same direction, -1: opposite).
void Revisit(const std::vector<float>& alpha, std::vector<float>* beta, std::size_t i0, std::size_t j0, int s,
             std::size_t len, std::mt19937* rng) {
  std::normal_distribution<float> g(0.0f, 0.003f);
  for (std::size_t t = 0; t < len; ++t) {
    const std::size_t j = s > 0 ? j0 + t : j0 - t;
    float* dst = beta->data() + j * kDim;
    for (std::size_t k = 0; k < kDim; ++k) dst[k] = std::fabs(alpha[(i0 + t) * kDim + k] + g(*rng));
    Normalise(dst, kDim);
  }
}

// The structured pair: two bands (a diagonal and an anti-diagonal revisit) plus isolated noise matches.
struct PairData {
  std::vector<float> alpha, beta;
};
PairData MakePair(std::size_t n, std::size_t m, std::uint32_t seed) {
  std::mt19937 rng(seed);
  PairData d;
  d.alpha = Trajectory(n, 0.01f, &rng);
  d.beta = Trajectory(m, 0.01f, &rng);
  Revisit(d.alpha, &d.beta, n / 10, m / 3, +1, std::min(n, m) / 3, &rng);
  Revisit(d.alpha, &d.beta, n / 2, m - 5, -1, std::min(n, m) / 4, &rng);
  std::uniform_int_distribution<std::size_t> pick_a(0, n - 1), pick_b(0, m / 3 - 1);
  for (int k = 0; k < 12; ++k) Revisit(d.alpha, &d.beta, pick_a(rng), pick_b(rng), +1, 1, &rng);  // noise
  return d;
}

DescriptorSetView Rows(const std::vector<float>& v, std::size_t begin, std::size_t count) {
  return DescriptorSetView{Span<const float>(v.data() + begin * kDim, count * kDim), kDim, {}};
}

// Every field of the incremental result against the full streaming pass: exact, sums included.
void CheckSameResult(const SequentialMatchResult& got, const SequentialMatchResult& want) {
  CHECK(got.found == want.found);
  CHECK(got.num_clusters == want.num_clusters);
  CHECK(got.num_cells_below_threshold == want.num_cells_below_threshold);
  CHECK(got.largest_span_area == want.largest_span_area);
  CHECK(got.second_span_area == want.second_span_area);
  CHECK(got.min_distance == want.min_distance);  // both +inf when there is no valid pair
  CHECK(got.no_candidate_reason == want.no_candidate_reason);
  CHECK(got.best.row_min == want.best.row_min);
  CHECK(got.best.row_max == want.best.row_max);
  CHECK(got.best.col_min == want.best.col_min);
  CHECK(got.best.col_max == want.best.col_max);
  CHECK(got.best.cell_count == want.best.cell_count);
  CHECK(got.best.distance_sum == want.best.distance_sum);  // bit for bit: same additions in the same order
  REQUIRE(got.cells.size() == want.cells.size());
  for (std::size_t k = 0; k < want.cells.size(); ++k) {
    CHECK(got.cells[k].alpha_index == want.cells[k].alpha_index);
    CHECK(got.cells[k].beta_index == want.cells[k].beta_index);
    CHECK(got.cells[k].distance == want.cells[k].distance);
  }
}

TEST_CASE("incremental matching equals the full pass after every growing batch") {
  const std::size_t n = 420, m = 380;
  const PairData data = MakePair(n, m, 21);
  struct Config {
    std::size_t tile_rows, tile_cols;
    std::uint64_t tau_area;
    std::uint32_t seed;
  };
  // Tiny tile grids are covered on stored matrices (test_sequential_matching.cpp); here the descriptor kernel
  // runs a full pass per update, so the grids stay coarse enough for qemu.
  for (const Config& cfg : {Config{256, 256, 2000, 1}, Config{16, 24, 2000, 2}, Config{7, 5, 300, 3},
                            Config{64, 9, 1, 5}}) {
    CAPTURE(cfg.tile_rows);
    CAPTURE(cfg.tile_cols);
    CAPTURE(cfg.tau_area);
    IncrementalMatchParams ip;
    ip.stage_a.tile_rows = cfg.tile_rows;
    ip.stage_a.tile_cols = cfg.tile_cols;
    ip.stage_a.tau_area = cfg.tau_area;
    ip.dim = kDim;
    ip.alpha_capacity = n;
    ip.beta_capacity = m;
    auto matcher = IncrementalSequentialMatcher::Create(ip);
    REQUIRE(matcher.ok());
    std::mt19937 rng(cfg.seed);
    std::uniform_int_distribution<int> kind(0, 9);
    std::size_t na = 0, nb = 0, updates = 0, found_updates = 0;
    std::uint64_t total_cells = 0;
    while (na < n || nb < m) {
      // Batch sizes: 0 (30 %), 1 (20 %), else up to 60 keyframes; alpha and beta independently.
      auto batch = [&](std::size_t have, std::size_t cap) -> std::size_t {
        const int k = kind(rng);
        const std::size_t want = k < 3 ? 0 : k < 5 ? 1 : std::uniform_int_distribution<std::size_t>(2, 60)(rng);
        return std::min(want, cap - have);
      };
      const std::size_t da = batch(na, n), db = batch(nb, m);
      REQUIRE(matcher->AppendAlpha(Rows(data.alpha, na, da)).ok());
      REQUIRE(matcher->AppendBeta(Rows(data.beta, nb, db)).ok());
      auto got = matcher->Update();
      REQUIRE(got.ok());
      const std::size_t n_old = na, m_old = nb;
      na += da;
      nb += db;
      ++updates;
      CAPTURE(na);
      CAPTURE(nb);
      // Only the new cells: new rows x all columns + old rows x new columns.
      const std::uint64_t expect_cells = static_cast<std::uint64_t>(da) * nb + static_cast<std::uint64_t>(n_old) * db;
      CHECK(matcher->stats().last_update_cells == expect_cells);
      total_cells += expect_cells;
      CHECK(matcher->stats().num_alpha == na);
      CHECK(matcher->stats().num_beta == nb);
      CHECK_FALSE(matcher->stats().last_update_full_pass);
      CHECK(m_old <= nb);
      auto want = RunSequentialMatching(Rows(data.alpha, 0, na), Rows(data.beta, 0, nb), ip.stage_a);
      REQUIRE(want.ok());
      CheckSameResult(*got, *want);
      found_updates += got->found ? 1 : 0;
    }
    const IncrementalMatchStats& st = matcher->stats();
    CHECK(st.updates == updates);
    CHECK(st.total_cells == total_cells);
    CHECK(st.total_cells == static_cast<std::uint64_t>(n) * m);  // every cell exactly once over the history
    CHECK(st.full_pass_fallbacks == 0);
    CHECK(found_updates > 0);               // the bands qualify once grown
    CHECK(found_updates < updates);         // ... and did not at the start
    // The hit store is exactly the set of cells <= tau of the whole matrix (one kernel over everything).
    auto kernel = AffinityTileKernel::Create(Rows(data.alpha, 0, n), Rows(data.beta, 0, m), n, m);
    REQUIRE(kernel.ok());
    AffinityTile t;
    REQUIRE(kernel->ComputeTile(0, 0, n, m, &t).ok());
    std::vector<CompactHit> expect_hits;
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t j = 0; j < m; ++j) {
        if (t.at(i, j) <= 0.10f) expect_hits.push_back({static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(j), t.at(i, j)});
      }
    }
    const Span<const CompactHit> hits = matcher->hits();
    REQUIRE(hits.size() == expect_hits.size());
    CHECK(st.num_hits == hits.size());
    for (std::size_t k = 0; k < hits.size(); ++k) {
      CHECK(hits[k].alpha_index == expect_hits[k].alpha_index);
      CHECK(hits[k].beta_index == expect_hits[k].beta_index);
      CHECK(hits[k].distance == expect_hits[k].distance);
    }
    CHECK(hits.size() > 100);
  }
}

TEST_CASE("incremental matching hit store overflow falls back to the exact full pass") {
  const std::size_t n = 200, m = 180;
  const PairData data = MakePair(n, m, 33);
  IncrementalMatchParams ip;
  ip.stage_a.tile_rows = 32;
  ip.stage_a.tile_cols = 48;
  ip.stage_a.tau_area = 500;
  ip.dim = kDim;
  ip.alpha_capacity = n;
  ip.beta_capacity = m;
  ip.max_hits = 150;  // the bands hold several hundred cells
  auto matcher = IncrementalSequentialMatcher::Create(ip);
  REQUIRE(matcher.ok());
  std::size_t na = 0, nb = 0;
  std::uint64_t fallbacks = 0;
  bool saw_incremental = false;
  for (const std::size_t step : {20, 20, 40, 1, 0, 60, 60, 0}) {
    const std::size_t da = std::min(step, n - na), db = std::min(step, m - nb);
    REQUIRE(matcher->AppendAlpha(Rows(data.alpha, na, da)).ok());
    REQUIRE(matcher->AppendBeta(Rows(data.beta, nb, db)).ok());
    const std::uint64_t before = matcher->stats().total_cells;
    auto got = matcher->Update();
    REQUIRE(got.ok());
    na += da;
    nb += db;
    auto want = RunSequentialMatching(Rows(data.alpha, 0, na), Rows(data.beta, 0, nb), ip.stage_a);
    REQUIRE(want.ok());
    CheckSameResult(*got, *want);  // exact in both modes
    const IncrementalMatchStats& st = matcher->stats();
    CHECK(st.total_cells - before == st.last_update_cells);
    if (st.overflowed) {
      ++fallbacks;
      CHECK(st.last_update_full_pass);
      CHECK(st.num_hits == 0);
      CHECK(matcher->hits().empty());
      CHECK(st.last_update_cells >= static_cast<std::uint64_t>(na) * nb);  // the whole matrix, again
    } else {
      saw_incremental = true;
      CHECK(fallbacks == 0);  // the overflow is permanent
      CHECK_FALSE(st.last_update_full_pass);
      CHECK(st.num_hits <= ip.max_hits);
    }
    CHECK(st.full_pass_fallbacks == fallbacks);
  }
  CHECK(saw_incremental);
  CHECK(fallbacks >= 2);  // once overflowed, every later update is a full pass (hits only accumulate)

  SUBCASE("a too-loose threshold: everything matches") {
    IncrementalMatchParams loose = ip;
    loose.stage_a.tau_inter = 2.0;  // above every unit distance
    loose.max_hits = 1000;
    auto lm = IncrementalSequentialMatcher::Create(loose);
    REQUIRE(lm.ok());
    REQUIRE(lm->AppendAlpha(Rows(data.alpha, 0, 30)).ok());
    REQUIRE(lm->AppendBeta(Rows(data.beta, 0, 30)).ok());
    auto r = lm->Update();  // 900 hits: fits
    REQUIRE(r.ok());
    CHECK_FALSE(lm->stats().overflowed);
    CHECK(r->num_cells_below_threshold == 900);
    REQUIRE(lm->AppendAlpha(Rows(data.alpha, 30, 10)).ok());
    r = lm->Update();  // 1200 hits: falls back
    REQUIRE(r.ok());
    CHECK(lm->stats().overflowed);
    CHECK(lm->stats().full_pass_fallbacks == 1);
    CHECK(r->num_cells_below_threshold == 1200);
    CHECK(r->found);
    CHECK(r->num_clusters == 1);
    CHECK(r->cells.size() == 1200);
  }
}

TEST_CASE("incremental matching capacity and format errors") {
  IncrementalMatchParams ip;
  ip.dim = 4;
  ip.alpha_capacity = 3;
  ip.beta_capacity = 2;
  SUBCASE("bad creation parameters") {
    IncrementalMatchParams p = ip;
    p.dim = 0;
    CHECK_FALSE(IncrementalSequentialMatcher::Create(p).ok());
    p = ip;
    p.alpha_capacity = std::size_t{1} << 33;  // indices would not fit 32 bits
    CHECK_FALSE(IncrementalSequentialMatcher::Create(p).ok());
    p = ip;
    p.dim = std::numeric_limits<std::size_t>::max() / 2;  // capacity x dim overflows
    CHECK_FALSE(IncrementalSequentialMatcher::Create(p).ok());
    p = ip;
    p.max_hits = std::size_t{1} << 31;
    CHECK_FALSE(IncrementalSequentialMatcher::Create(p).ok());
    p = ip;
    p.stage_a.tau_inter = -0.1;
    CHECK_FALSE(IncrementalSequentialMatcher::Create(p).ok());
    p = ip;
    p.stage_a.tile_rows = 0;
    CHECK_FALSE(IncrementalSequentialMatcher::Create(p).ok());
    p = ip;
    p.stage_a.sequence_half_window = 1;  // smoothing changes old border cells: refused, not silently ignored
    const Status smoothing = IncrementalSequentialMatcher::Create(p).status();
    CHECK(smoothing.code() == StatusCode::kInvalidArgument);
    CHECK(smoothing.message().find("sequence_half_window") != std::string::npos);
    p = ip;
    p.stage_a.neighbour_rank = 1;  // ranks change as keyframes arrive: refused too
    const Status ranked = IncrementalSequentialMatcher::Create(p).status();
    CHECK(ranked.code() == StatusCode::kInvalidArgument);
    CHECK(ranked.message().find("neighbour_rank") != std::string::npos);
  }
  SUBCASE("appending beyond the capacity or a malformed batch changes nothing") {
    auto matcher = IncrementalSequentialMatcher::Create(ip);
    REQUIRE(matcher.ok());
    const std::vector<float> two(8, 0.5f), four(16, 0.5f), seven(7, 0.5f);
    REQUIRE(matcher->AppendAlpha({two, 4, {}}).ok());
    const Status over = matcher->AppendAlpha({two, 4, {}});  // 2 + 2 > 3
    CHECK(over.code() == StatusCode::kResourceExhausted);
    CHECK(over.message().find("capacity") != std::string::npos);
    CHECK(matcher->alpha().count() == 2);
    CHECK(matcher->AppendBeta({four, 4, {}}).code() == StatusCode::kResourceExhausted);  // 4 > 2
    CHECK(matcher->beta().count() == 0);
    CHECK_FALSE(matcher->AppendAlpha({seven, 4, {}}).ok());         // not a multiple of dim
    CHECK_FALSE(matcher->AppendAlpha({two, 2, {}}).ok());           // another dim
    const std::vector<std::uint8_t> one_flag = {1};
    CHECK_FALSE(matcher->AppendAlpha({two, 4, one_flag}).ok());     // 1 flag for 2 keyframes
    CHECK(matcher->alpha().count() == 2);
    CHECK(matcher->AppendAlpha({{}, 4, {}}).ok());                  // empty batch: no-op
    const DescriptorSetView one{Span<const float>(two.data(), 4), 4, {}};
    CHECK(matcher->AppendAlpha(one).ok());                           // exactly to the capacity
    CHECK(matcher->alpha().count() == 3);
    CHECK(matcher->AppendAlpha(one).code() == StatusCode::kResourceExhausted);
    auto r = matcher->Update();
    REQUIRE(r.ok());
    CHECK_FALSE(r->found);
    CHECK(r->no_candidate_reason.find("robot beta") != std::string::npos);
  }
  SUBCASE("hit lists out of order or above tau are rejected") {
    SequentialMatchParams p;
    const std::vector<CompactHit> unsorted = {{1, 2, 0.01f}, {1, 1, 0.01f}};
    CHECK_FALSE(RunSequentialMatchingOnHits(unsorted, 5, 5, 0.01, p).ok());
    const std::vector<CompactHit> dup = {{1, 1, 0.01f}, {1, 1, 0.01f}};
    CHECK_FALSE(RunSequentialMatchingOnHits(dup, 5, 5, 0.01, p).ok());
    const std::vector<CompactHit> outside = {{5, 1, 0.01f}};
    CHECK_FALSE(RunSequentialMatchingOnHits(outside, 5, 5, 0.01, p).ok());
    const std::vector<CompactHit> above = {{1, 1, 0.2f}};
    CHECK_FALSE(RunSequentialMatchingOnHits(above, 5, 5, 0.01, p).ok());
    CHECK_FALSE(RunSequentialMatchingOnHits({}, 5, 5, std::numeric_limits<double>::quiet_NaN(), p).ok());
  }
}

TEST_CASE("incremental matching degenerate inputs give a reason and never crash") {
  std::mt19937 rng(3);
  const std::vector<float> a = Trajectory(30, 0.05f, &rng), b = Trajectory(30, 0.05f, &rng);
  IncrementalMatchParams ip;
  ip.dim = kDim;
  ip.alpha_capacity = 40;
  ip.beta_capacity = 40;
  auto matcher = IncrementalSequentialMatcher::Create(ip);
  REQUIRE(matcher.ok());

  // Nothing received yet.
  auto r = matcher->Update();
  REQUIRE(r.ok());
  CHECK_FALSE(r->found);
  CHECK(r->no_candidate_reason == "no keyframes: robot alpha has an empty descriptor set (N = 0, M = 0)");
  CHECK(matcher->stats().last_update_cells == 0);

  // A single keyframe each, identical: one cell, span area 1 < tau_area.
  REQUIRE(matcher->AppendAlpha(Rows(a, 0, 1)).ok());
  r = matcher->Update();
  REQUIRE(r.ok());
  CHECK(r->no_candidate_reason.find("robot beta") != std::string::npos);
  REQUIRE(matcher->AppendBeta(Rows(a, 0, 1)).ok());
  r = matcher->Update();
  REQUIRE(r.ok());
  CHECK(matcher->stats().last_update_cells == 1);
  CHECK_FALSE(r->found);
  CHECK(r->num_clusters == 1);
  CHECK(r->no_candidate_reason == "no cluster with span area >= tau_area = 10000: largest was 1 (next 0, 1 clusters)");

  // NaN, infinite, huge and flagged-invalid keyframes: never match, even against themselves.
  std::vector<float> bad(a.begin() + kDim, a.begin() + 5 * kDim);
  bad[0 * kDim + 3] = std::numeric_limits<float>::quiet_NaN();
  bad[1 * kDim + 0] = std::numeric_limits<float>::infinity();
  for (std::size_t k = 0; k < kDim; ++k) bad[2 * kDim + k] = 1e20f;  // ||v||^2 = 4e41: not representable
  const std::vector<std::uint8_t> flags = {1, 1, 1, 0};             // keyframe 3 valid values, flagged 0
  REQUIRE(matcher->AppendAlpha({bad, kDim, flags}).ok());
  REQUIRE(matcher->AppendBeta({bad, kDim, flags}).ok());
  r = matcher->Update();
  REQUIRE(r.ok());
  CHECK(r->num_cells_below_threshold == 1);  // still only the identical pair (0, 0)
  auto want = RunSequentialMatching(matcher->alpha(), matcher->beta(), ip.stage_a);
  REQUIRE(want.ok());
  CheckSameResult(*r, *want);

  // All pairs above the threshold, on fresh matchers.
  IncrementalMatchParams tight = ip;
  tight.stage_a.tau_inter = 0.0;
  auto far = IncrementalSequentialMatcher::Create(tight);
  REQUIRE(far.ok());
  REQUIRE(far->AppendAlpha(Rows(a, 0, 30)).ok());
  REQUIRE(far->AppendBeta(Rows(b, 0, 30)).ok());
  r = far->Update();
  REQUIRE(r.ok());
  CHECK_FALSE(r->found);
  CHECK(r->num_cells_below_threshold == 0);
  CHECK(r->no_candidate_reason.rfind("no cell below tau_inter = 0 (smallest distance ", 0) == 0);
  want = RunSequentialMatching(far->alpha(), far->beta(), tight.stage_a);
  REQUIRE(want.ok());
  CheckSameResult(*r, *want);

  // Only invalid keyframes: no valid pair at all.
  auto none = IncrementalSequentialMatcher::Create(ip);
  REQUIRE(none.ok());
  std::vector<float> nan_set(3 * kDim, std::numeric_limits<float>::quiet_NaN());
  REQUIRE(none->AppendAlpha({nan_set, kDim, {}}).ok());
  REQUIRE(none->AppendBeta(Rows(a, 0, 5)).ok());
  r = none->Update();
  REQUIRE(r.ok());
  CHECK_FALSE(r->found);
  CHECK(r->no_candidate_reason.find("no valid descriptor pair") != std::string::npos);
  CHECK(std::isinf(r->min_distance));
}

}  // namespace
}  // namespace commerge
