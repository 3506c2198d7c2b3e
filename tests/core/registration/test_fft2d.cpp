// SPDX-License-Identifier: BSD-3-Clause
// The radix-2 2-D FFT (core/registration/fft2d) against a direct double-precision DFT, its transposed
// spectrum layout, the unnormalised inverse, and its input checks.
#include <doctest/doctest.h>

#include <cmath>
#include <complex>
#include <random>
#include <vector>

#include "core/registration/fft2d.hpp"

namespace commerge {
namespace {

std::vector<std::complex<double>> NaiveDft2(const std::vector<std::complex<float>>& x, int n, double sign) {
  constexpr double kTwoPi = 6.283185307179586476925286766559;
  std::vector<std::complex<double>> out(static_cast<std::size_t>(n * n));
  for (int kr = 0; kr < n; ++kr) {
    for (int kc = 0; kc < n; ++kc) {
      std::complex<double> sum = 0.0;
      for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c) {
          const double a = sign * kTwoPi * static_cast<double>(kr * r + kc * c) / static_cast<double>(n);
          sum += std::complex<double>(x[static_cast<std::size_t>(r * n + c)]) * std::complex<double>(std::cos(a), std::sin(a));
        }
      }
      out[static_cast<std::size_t>(kr * n + kc)] = sum;
    }
  }
  return out;
}

std::vector<std::complex<float>> RandomGrid(int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<std::complex<float>> g(static_cast<std::size_t>(n * n));
  for (auto& v : g) v = {u(rng), u(rng)};
  return g;
}

}  // namespace

TEST_CASE("FFT 2-D equals a direct DFT (spectrum transposed) and the inverse returns n^2 times the grid") {
  for (int n : {2, 4, 8, 16}) {
    CAPTURE(n);
    const std::vector<std::complex<float>> x = RandomGrid(n, 7u + static_cast<std::uint32_t>(n));
    Fft2d fft;
    REQUIRE(fft.Init(n).ok());
    std::vector<std::complex<float>> y = x;
    REQUIRE(fft.Forward(y).ok());
    const std::vector<std::complex<double>> ref = NaiveDft2(x, n, -1.0);
    double max_err = 0.0;
    for (int kr = 0; kr < n; ++kr) {
      for (int kc = 0; kc < n; ++kc) {
        // Forward's layout: X[kr][kc] is stored at row kc, column kr.
        const std::complex<double> got(y[static_cast<std::size_t>(kc * n + kr)]);
        max_err = std::max(max_err, std::abs(got - ref[static_cast<std::size_t>(kr * n + kc)]));
      }
    }
    CHECK(max_err < 1e-4 * n * n);
    REQUIRE(fft.Inverse(y).ok());
    for (std::size_t i = 0; i < x.size(); ++i) {
      CHECK(std::abs(std::complex<double>(y[i]) / static_cast<double>(n * n) - std::complex<double>(x[i])) < 1e-5);
    }
  }
}

TEST_CASE("FFT 2-D correlation theorem: inverse(F(t) conj(F(s))) is the circular cross-correlation") {
  const int n = 8;
  const std::vector<std::complex<float>> t = RandomGrid(n, 1), s = RandomGrid(n, 2);
  std::vector<std::complex<float>> ft = t, fs = s;
  Fft2d fft;
  REQUIRE(fft.Init(n).ok());
  REQUIRE(fft.Forward(ft).ok());
  REQUIRE(fft.Forward(fs).ok());
  for (std::size_t i = 0; i < ft.size(); ++i) ft[i] *= std::conj(fs[i]);
  REQUIRE(fft.Inverse(ft).ok());
  for (int dy = 0; dy < n; ++dy) {
    for (int dx = 0; dx < n; ++dx) {
      std::complex<double> sum = 0.0;  // sum_x t(x + d) conj(s(x))
      for (int r = 0; r < n; ++r) {
        for (int c = 0; c < n; ++c) {
          sum += std::complex<double>(t[static_cast<std::size_t>(((r + dy) % n) * n + (c + dx) % n)]) *
                 std::conj(std::complex<double>(s[static_cast<std::size_t>(r * n + c)]));
        }
      }
      CHECK(std::abs(std::complex<double>(ft[static_cast<std::size_t>(dy * n + dx)]) / 64.0 - sum) < 1e-4);
    }
  }
}

TEST_CASE("FFT 2-D refuses sizes that are not powers of two and grids of the wrong size") {
  Fft2d fft;
  CHECK_FALSE(fft.Init(0).ok());
  CHECK_FALSE(fft.Init(12).ok());
  CHECK_FALSE(fft.Init(8192).ok());
  std::vector<std::complex<float>> g(16);
  CHECK_FALSE(fft.Forward(g).ok());  // not initialised
  REQUIRE(fft.Init(8).ok());
  const Status s = fft.Forward(g);
  CHECK_FALSE(s.ok());
  CHECK(s.message().find("16 cells") != std::string::npos);
}

}  // namespace commerge
