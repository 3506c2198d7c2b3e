// SPDX-License-Identifier: BSD-3-Clause
#include "core/registration/fft2d.hpp"

#include <cmath>
#include <utility>

namespace commerge {

Status Fft2d::Init(int n) {
  if (n < 2 || n > 4096 || (n & (n - 1)) != 0) {
    return InvalidArgument("fft2d: the grid size must be a power of two in [2, 4096], got " + std::to_string(n));
  }
  if (n == n_) return Status::Ok();
  n_ = n;
  const std::size_t un = static_cast<std::size_t>(n);
  twiddles_f_.resize(un / 2);
  constexpr double kTwoPi = 6.283185307179586476925286766559;
  for (std::size_t k = 0; k < un / 2; ++k) {
    const double a = -kTwoPi * static_cast<double>(k) / static_cast<double>(n);
    twiddles_f_[k] = std::complex<float>(static_cast<float>(std::cos(a)), static_cast<float>(std::sin(a)));
  }
  bit_reverse_.resize(un);
  int bits = 0;
  while ((1 << bits) < n) ++bits;
  for (std::size_t i = 0; i < un; ++i) {
    std::size_t r = 0;
    for (int b = 0; b < bits; ++b) r |= ((i >> b) & 1u) << (bits - 1 - b);
    bit_reverse_[i] = r;
  }
  return Status::Ok();
}

Status Fft2d::Forward(Span<std::complex<float>> grid) { return Transform(grid, false); }
Status Fft2d::Inverse(Span<std::complex<float>> grid) { return Transform(grid, true); }

Status Fft2d::Transform(Span<std::complex<float>> grid, bool inverse) {
  const std::size_t un = static_cast<std::size_t>(n_);
  if (n_ == 0 || grid.size() != un * un) {
    return InvalidArgument("fft2d: grid has " + std::to_string(grid.size()) + " cells, expected " +
                           std::to_string(un * un) + " (call Init first)");
  }
  Rows(grid.data(), inverse);
  Transpose(grid.data());
  Rows(grid.data(), inverse);
  return Status::Ok();
}

void Fft2d::Rows(std::complex<float>* grid, bool inverse) const {
  const std::size_t n = static_cast<std::size_t>(n_);
  for (std::size_t r = 0; r < n; ++r) {
    std::complex<float>* a = grid + r * n;
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t j = bit_reverse_[i];
      if (i < j) std::swap(a[i], a[j]);
    }
    for (std::size_t len = 2; len <= n; len <<= 1) {
      const std::size_t half = len / 2;
      const std::size_t stride = n / len;  // twiddle index step
      for (std::size_t start = 0; start < n; start += len) {
        for (std::size_t k = 0; k < half; ++k) {
          std::complex<float> w = twiddles_f_[k * stride];
          if (inverse) w = std::conj(w);
          const std::complex<float> u = a[start + k];
          const std::complex<float> v = a[start + k + half] * w;
          a[start + k] = u + v;
          a[start + k + half] = u - v;
        }
      }
    }
  }
}

void Fft2d::Transpose(std::complex<float>* grid) const {
  const std::size_t n = static_cast<std::size_t>(n_);
  for (std::size_t r = 0; r < n; ++r) {
    for (std::size_t c = r + 1; c < n; ++c) std::swap(grid[r * n + c], grid[c * n + r]);
  }
}

}  // namespace commerge
