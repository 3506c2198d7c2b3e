// SPDX-License-Identifier: BSD-3-Clause
// Tiled affinity kernel: distances against the naive SolidDistance reference, invalid keyframes (flag, NaN,
// zero vector, overflowing norm) at +inf, tile enumeration order and coverage, bad inputs; position
// independence (a cell is the same float in every tile), tile minima, Extend on grown sets, cell counter.
#include <doctest/doctest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "core/exchange/affinity.hpp"
#include "tests/core/exchange/affinity_tiles_check.hpp"

namespace commerge {
namespace {

// count unit-normalised non-negative descriptors of dimension dim.
std::vector<float> RandomUnitDescriptors(std::size_t count, std::size_t dim, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<float> v(count * dim);
  for (std::size_t i = 0; i < count; ++i) {
    double n2 = 0.0;
    for (std::size_t k = 0; k < dim; ++k) {
      v[i * dim + k] = u(rng);
      n2 += static_cast<double>(v[i * dim + k]) * static_cast<double>(v[i * dim + k]);
    }
    const auto inv = static_cast<float>(1.0 / std::sqrt(n2));
    for (std::size_t k = 0; k < dim; ++k) v[i * dim + k] *= inv;
  }
  return v;
}

// Checks the kernel, tiled as tile_rows x tile_cols, against the naive reference.
void CheckAgainstNaive(const DescriptorSetView& a, const DescriptorSetView& b, std::size_t tile_rows,
                       std::size_t tile_cols) {
  std::vector<double> ref;
  REQUIRE(ComputeAffinityNaive(a, b, &ref).ok());
  auto kernel = AffinityTileKernel::Create(a, b, tile_rows, tile_cols);
  REQUIRE(kernel.ok());
  const std::size_t n = a.count(), m = b.count();
  std::vector<int> seen(n * m, 0);
  std::size_t expect_r0 = 0, expect_c0 = 0;
  double max_err_d2 = 0.0;
  bool inf_mismatch = false;
  const Status s = ForEachAffinityTile(*kernel, tile_rows, tile_cols, [&](const AffinityTile& t) {
    CHECK(t.row_begin == expect_r0);  // row-major tile order
    CHECK(t.col_begin == expect_c0);
    expect_c0 += t.cols;
    if (expect_c0 == m) {
      expect_c0 = 0;
      expect_r0 += t.rows;
    }
    for (std::size_t r = 0; r < t.rows; ++r) {
      for (std::size_t c = 0; c < t.cols; ++c) {
        const std::size_t i = t.row_begin + r, j = t.col_begin + c;
        ++seen[i * m + j];
        const double k = static_cast<double>(t.at(r, c)), e = ref[i * m + j];
        if (std::isinf(e) || std::isinf(k)) {
          inf_mismatch = inf_mismatch || !(std::isinf(e) && std::isinf(k));
        } else {
          max_err_d2 = std::max(max_err_d2, std::fabs(k * k - e * e));
        }
      }
    }
    return Status::Ok();
  });
  REQUIRE(s.ok());
  CHECK(expect_r0 == n);
  for (int v : seen) REQUIRE(v == 1);
  CHECK_FALSE(inf_mismatch);
  CHECK(max_err_d2 < 1e-5);  // float GEMM form vs double cosine form
}

TEST_CASE("affinity kernel matches the naive SolidDistance reference for several tile sizes") {
  const std::size_t dim = 40;
  for (const auto& nm : {std::pair<std::size_t, std::size_t>{1, 1}, {1, 300}, {257, 3}, {70, 90}}) {
    const std::vector<float> va = RandomUnitDescriptors(nm.first, dim, 1), vb = RandomUnitDescriptors(nm.second, dim, 2);
    const DescriptorSetView a{va, dim, {}}, b{vb, dim, {}};
    for (const auto& tile : {std::pair<std::size_t, std::size_t>{1, 1}, {7, 5}, {64, 64}, {256, 256}}) {
      CAPTURE(nm.first);
      CAPTURE(nm.second);
      CAPTURE(tile.first);
      CheckAgainstNaive(a, b, tile.first, tile.second);
    }
  }
}

TEST_CASE("affinity kernel is exact on identical and near-identical descriptors") {
  const std::size_t dim = 40;
  std::vector<float> va = RandomUnitDescriptors(5, dim, 3);
  const DescriptorSetView a{va, dim, {}};
  auto kernel = AffinityTileKernel::Create(a, a, 8, 8);
  REQUIRE(kernel.ok());
  AffinityTile t;
  REQUIRE(kernel->ComputeTile(0, 0, 5, 5, &t).ok());
  for (std::size_t i = 0; i < 5; ++i) CHECK(t.at(i, i) < 2e-3f);  // cancellation near d = 0 (documented)
  for (std::size_t i = 0; i < 5; ++i) {
    for (std::size_t j = 0; j < 5; ++j) {
      CHECK(t.at(i, j) >= 0.0f);
      CHECK(t.at(i, j) <= 1.4143f);
    }
  }
}

TEST_CASE("affinity invalid keyframes flag NaN and zero vectors are infinitely far") {
  const std::size_t dim = 8;
  std::vector<float> va = RandomUnitDescriptors(4, dim, 4), vb = RandomUnitDescriptors(3, dim, 5);
  va[1 * dim + 2] = std::numeric_limits<float>::quiet_NaN();  // alpha 1: NaN
  for (std::size_t k = 0; k < dim; ++k) vb[2 * dim + k] = 0.0f;  // beta 2: zero vector
  vb[0 * dim + 0] = std::numeric_limits<float>::infinity();      // beta 0: inf
  const std::vector<std::uint8_t> flags_a = {1, 1, 0, 1};         // alpha 2: flagged invalid
  const DescriptorSetView a{va, dim, flags_a}, b{vb, dim, {}};
  auto kernel = AffinityTileKernel::Create(a, b, 2, 2);
  REQUIRE(kernel.ok());
  CHECK(kernel->alpha_valid(0));
  CHECK_FALSE(kernel->alpha_valid(1));
  CHECK_FALSE(kernel->alpha_valid(2));
  CHECK_FALSE(kernel->beta_valid(0));
  CHECK(kernel->beta_valid(1));
  CHECK_FALSE(kernel->beta_valid(2));
  const Status s = ForEachAffinityTile(*kernel, 2, 2, [&](const AffinityTile& t) {
    for (std::size_t r = 0; r < t.rows; ++r) {
      for (std::size_t c = 0; c < t.cols; ++c) {
        const std::size_t i = t.row_begin + r, j = t.col_begin + c;
        const bool valid = (i == 0 || i == 3) && j == 1;
        CHECK(std::isinf(t.at(r, c)) == !valid);
      }
    }
    return Status::Ok();
  });
  CHECK(s.ok());
  CheckAgainstNaive(a, b, 3, 2);
}

TEST_CASE("affinity rejects malformed sets and out of range tiles") {
  const std::vector<float> v40(80, 0.1f), v39(39, 0.1f), v10(10, 0.1f);
  const std::vector<std::uint8_t> one_flag = {1};
  CHECK_FALSE(ValidateDescriptorSet({v39, 40, {}}, "x").ok());
  CHECK_FALSE(ValidateDescriptorSet({v40, 0, {}}, "x").ok());
  CHECK_FALSE(ValidateDescriptorSet({v40, 40, one_flag}, "x").ok());
  CHECK(ValidateDescriptorSet({v40, 40, {}}, "x").ok());
  CHECK(ValidateDescriptorSet({{}, 40, {}}, "x").ok());  // empty set is well formed
  CHECK_FALSE(AffinityTileKernel::Create({v40, 40, {}}, {v10, 10, {}}, 4, 4).ok());
  CHECK_FALSE(AffinityTileKernel::Create({v40, 40, {}}, {v40, 40, {}}, 0, 4).ok());
  auto kernel = AffinityTileKernel::Create({v40, 40, {}}, {v40, 40, {}}, 1, 1);
  REQUIRE(kernel.ok());
  AffinityTile t;
  CHECK_FALSE(kernel->ComputeTile(0, 0, 2, 1, &t).ok());  // above capacity
  CHECK_FALSE(kernel->ComputeTile(2, 0, 1, 1, &t).ok());  // outside
  CHECK_FALSE(kernel->ComputeTile(0, 0, 0, 1, &t).ok());  // empty
  CHECK(kernel->ComputeTile(1, 1, 1, 1, &t).ok());
  CHECK_FALSE(ForEachAffinityTile(*kernel, 0, 1, [](const AffinityTile&) { return Status::Ok(); }).ok());
  // Empty sets: no tile at all.
  auto empty = AffinityTileKernel::Create({{}, 40, {}}, {v40, 40, {}}, 4, 4);
  REQUIRE(empty.ok());
  int tiles = 0;
  CHECK(ForEachAffinityTile(*empty, 4, 4, [&](const AffinityTile&) {
          ++tiles;
          return Status::Ok();
        }).ok());
  CHECK(tiles == 0);
}

// Every cell of the whole matrix in one tile (the reference for bit-identity below).
std::vector<float> WholeMatrix(const DescriptorSetView& a, const DescriptorSetView& b) {
  auto k = AffinityTileKernel::Create(a, b, std::max<std::size_t>(a.count(), 1), std::max<std::size_t>(b.count(), 1));
  REQUIRE(k.ok());
  AffinityTile t;
  REQUIRE(k->ComputeTile(0, 0, a.count(), b.count(), &t).ok());
  return std::vector<float>(t.distances, t.distances + a.count() * b.count());
}

TEST_CASE("affinity kernel values are position independent and tiles report their minimum") {
  const std::size_t dim = 40, n = 61, m = 75;
  std::vector<float> va = RandomUnitDescriptors(n, dim, 8), vb = RandomUnitDescriptors(m, dim, 9);
  for (std::size_t k = 0; k < dim; ++k) vb[3 * dim + k] = va[5 * dim + k];  // one exact pair: d ~ 0
  vb[10 * dim + 4] = std::numeric_limits<float>::quiet_NaN();              // one invalid column
  const DescriptorSetView a{va, dim, {}}, b{vb, dim, {}};
  const std::vector<float> whole = WholeMatrix(a, b);
  auto kernel = AffinityTileKernel::Create(a, b, 40, 40);
  REQUIRE(kernel.ok());
  // Arbitrary blocks: offsets not aligned to the 6 x 8 micro blocks, 1-wide, full-capacity.
  std::mt19937 rng(4);
  const std::uint64_t cells = test::CheckRandomTiles(*kernel, whole, n, m, 40, 300, &rng);
  AffinityTile t;
  CHECK(kernel->cells_computed() == cells);
  CHECK(whole[5 * m + 3] < 2e-3f);
  CHECK(std::isinf(whole[7 * m + 10]));
  // A tile made only of the invalid column: minimum +inf.
  REQUIRE(kernel->ComputeTile(0, 10, 7, 1, &t).ok());
  CHECK(std::isinf(t.min_distance));
}

TEST_CASE("affinity kernel Extend on grown sets equals a kernel on the whole sets") {
  const std::size_t dim = 40, n = 50, m = 45;
  const std::vector<float> va = RandomUnitDescriptors(n, dim, 11), vb = RandomUnitDescriptors(m, dim, 12);
  std::vector<std::uint8_t> fa(n, 1), fb(m, 1);
  fa[20] = 0;
  fb[44] = 0;
  auto prefix = [&](const std::vector<float>& v, const std::vector<std::uint8_t>& f, std::size_t count) {
    return DescriptorSetView{Span<const float>(v.data(), count * dim), dim, Span<const std::uint8_t>(f.data(), count)};
  };
  const std::vector<float> whole = WholeMatrix(prefix(va, fa, n), prefix(vb, fb, m));
  auto kernel = AffinityTileKernel::Create(prefix(va, fa, 0), prefix(vb, fb, 3), 16, 16);
  REQUIRE(kernel.ok());
  kernel->Reserve(n, m);
  const std::size_t steps[][2] = {{1, 0}, {0, 5}, {13, 1}, {0, 0}, {20, 30}, {16, 6}};
  std::size_t na = 0, nb = 3;
  for (const auto& st : steps) {
    na += st[0];
    nb += st[1];
    REQUIRE(kernel->Extend(prefix(va, fa, na), prefix(vb, fb, nb)).ok());
    CHECK(kernel->num_rows() == na);
    CHECK(kernel->num_cols() == nb);
    const Status s = ForEachAffinityTile(*kernel, 16, 16, [&](const AffinityTile& t) {
      for (std::size_t r = 0; r < t.rows; ++r) {
        for (std::size_t c = 0; c < t.cols; ++c) REQUIRE(t.at(r, c) == whole[(t.row_begin + r) * m + t.col_begin + c]);
      }
      return Status::Ok();
    });
    CHECK(s.ok());
  }
  CHECK(na == n);
  CHECK(nb == m);
  CHECK_FALSE(kernel->alpha_valid(20));
  CHECK_FALSE(kernel->beta_valid(44));
  CHECK(kernel->Extend(prefix(va, fa, n - 1), prefix(vb, fb, m)).code() == StatusCode::kInvalidArgument);  // shrank
  const DescriptorSetView other_dim{Span<const float>(va.data(), 39 * 10), 39, {}};
  CHECK_FALSE(kernel->Extend(other_dim, prefix(vb, fb, m)).ok());
  CHECK(kernel->num_rows() == n);  // unchanged by the failed calls
}

TEST_CASE("affinity huge or tiny norms are invalid instead of overflowing") {
  const std::size_t dim = 4;
  std::vector<float> va = {1e20f, 1e20f, 1e20f, 1e20f,       // ||v||^2 = 4e40: above kMaxDescriptorNorm2
                           1e-30f, 0.0f, 0.0f, 0.0f,         // ||v||^2 = 1e-60: rounds to 0 in float
                           1e14f, 1e14f, 1e14f, 1e14f,       // ||v||^2 = 4e28: valid, still finite math
                           0.5f, 0.5f, 0.5f, 0.5f};
  const DescriptorSetView a{va, dim, {}};
  auto kernel = AffinityTileKernel::Create(a, a, 4, 4);
  REQUIRE(kernel.ok());
  CHECK_FALSE(kernel->alpha_valid(0));
  CHECK_FALSE(kernel->alpha_valid(1));
  CHECK(kernel->alpha_valid(2));
  CHECK(kernel->alpha_valid(3));
  AffinityTile t;
  REQUIRE(kernel->ComputeTile(0, 0, 4, 4, &t).ok());
  for (std::size_t r = 0; r < 4; ++r) {
    for (std::size_t c = 0; c < 4; ++c) {
      const bool valid = r >= 2 && c >= 2;
      CHECK(std::isinf(t.at(r, c)) == !valid);
      CHECK_FALSE(std::isnan(t.at(r, c)));
    }
  }
  CHECK(t.at(3, 3) < 1e-3f);
  CHECK(t.at(2, 2) >= 0.0f);  // cancellation at 4e28 leaves garbage >= 0, never NaN or negative
}

}  // namespace
}  // namespace commerge
